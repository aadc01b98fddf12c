// The step pipeline behind Simulation: state save/load resumes bitwise,
// thread counts do not change results, conserved quantities stay conserved,
// tetrahedral bodies carry their boundary, and failures are diagnosed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <fmt/format.h>

#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "io/scene_io.h"
#include "solvers/simulation.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Scene scene_from(const std::string& text) { return io::parse_scene(text, "test.json", "."); }

/// A small plastic cube thrown at the floor: contacts, plastic flow and re-meshes in a few frames.
std::string thrown_cube(const std::string& integrator = R"({"type": "newmark"})") {
  return fmt::format(R"({{
    "integrator": {},
    "ground": {{"height": 0.0, "friction": 0.4}},
    "objects": [{{"name": "cube", "primitive": {{"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 6}},
                 "transform": {{"translate": [0, 0, 0.07], "rotate_degrees": [10, 20, 0]}},
                 "velocity": [0.3, 0, -2], "angular_velocity": [0, 4, 0],
                 "material": {{"preset": "splashing_fluid", "youngs_modulus": 2e4, "min_mass_fraction": 0.05}},
                 "lattice_spacing": 0.025}}]
  }})",
                     integrator);
}

void expect_same_state(const Simulation& a, const Simulation& b) { test::expect_same_records(a.save(), b.save()); }

TEST(Simulation, ResumingFromASavedStateIsBitwiseIdentical) {
  for (const std::string& integrator :
       {std::string(R"({"type": "newmark"})"), std::string(R"({"type": "backward_euler", "time_step": 0.005})")}) {
    SCOPED_TRACE(integrator);
    const Scene scene = scene_from(thrown_cube(integrator));
    Simulation straight(scene), first(scene);
    // Both make restart points at the same times (as goo run does each frame).
    for (int frame = 1; frame <= 4; ++frame) {
      straight.make_restart_point();
      ASSERT_TRUE(straight.advance_to(frame / 60.0));
    }
    for (int frame = 1; frame <= 2; ++frame) {
      first.make_restart_point();
      ASSERT_TRUE(first.advance_to(frame / 60.0));
    }
    first.make_restart_point();
    const StateRecord saved = first.save();
    Simulation resumed(scene);
    resumed.load(saved);
    for (int frame = 3; frame <= 4; ++frame) {
      resumed.make_restart_point();
      ASSERT_TRUE(resumed.advance_to(frame / 60.0));
    }
    EXPECT_GT(straight.steps(), 6);
    expect_same_state(straight, resumed);
  }
}

TEST(Simulation, RemeshesAndStaysBitwiseIdenticalOnOneAndTwoThreads) {
  const Scene scene = scene_from(thrown_cube());
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    auto sim = std::make_unique<Simulation>(scene);
    for (int frame = 1; frame <= 6; ++frame) {
      sim->make_restart_point();
      sim->advance_to(frame / 60.0);
    }
    return sim;
  };
  const auto one = run(1), two = run(2);
  EXPECT_GT(one->remeshes(), 0);  // the case exercises re-meshing
  expect_same_state(*one, *two);
}

TEST(Simulation, MassIsConservedAndMomentumToo_WhenNoExternalForceActs) {
  // No gravity, no floor: a spinning, stretching plastic cube re-meshes; its
  // mass and linear momentum stay what they were (re-meshing restores both
  // exactly, and internal forces sum to zero).
  Scene scene = scene_from(R"({
    "gravity": [0, 0, 0],
    "objects": [{"primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 6},
                 "velocity": [0.5, -0.2, 0.1], "angular_velocity": [0, 0, 30],
                 "material": {"preset": "splashing_fluid", "youngs_modulus": 2e4, "min_mass_fraction": 0.05},
                 "lattice_spacing": 0.025}]
  })");
  Simulation sim(scene);
  const SimulationTotals start = sim.totals();
  sim.advance_to(0.2);
  const SimulationTotals end = sim.totals();
  EXPECT_GT(sim.remeshes(), 0);
  EXPECT_NEAR(end.mass, start.mass, 1e-12 * start.mass);
  // Round-off scale: momentum sums of #N terms of size m |v|.
  EXPECT_LT((end.momentum - start.momentum).norm(), 1e-12 * start.mass * 3.0);
  EXPECT_TRUE(test::matrices_near(start.momentum, Eigen::Vector3d(0.5, -0.2, 0.1) * start.mass, 1e-12));
}

TEST(Simulation, ATetMeshBodyCarriesItsBoundaryAsItsSurface) {
  test::TempDir dir;
  const TetMesh box =
      make_box_tets(Eigen::Vector3d(0.3, 0.1, 0.1), Eigen::Vector3i(6, 2, 2), Eigen::Vector3d(-0.15, -0.05, -0.05));
  std::string mesh = "MeshVersionFormatted 1\nDimension 3\nVertices\n" + std::to_string(box.positions.rows()) + "\n";
  for (Eigen::Index i = 0; i < box.positions.rows(); ++i)
    mesh += fmt::format("{:.17g} {:.17g} {:.17g} 0\n", box.positions(i, 0), box.positions(i, 1), box.positions(i, 2));
  mesh += "Tetrahedra\n" + std::to_string(box.tets.rows()) + "\n";
  for (Eigen::Index e = 0; e < box.tets.rows(); ++e)
    mesh += fmt::format("{} {} {} {} 0\n", box.tets(e, 0) + 1, box.tets(e, 1) + 1, box.tets(e, 2) + 1, box.tets(e, 3) + 1);
  mesh += "End\n";
  dir.write("box.mesh", mesh);
  const Scene scene = io::parse_scene(
      R"({"objects": [{"tet_mesh": "box.mesh", "material": "jiggly_gelatin",
          "pinned": [{"box": {"min": [-1, -1, -1], "max": [-0.1499, 1, 1]}}]}]})",
      "t.json", dir.path());
  Simulation sim(scene);
  const SurfaceReport report = analyze_surface(sim.surface());
  EXPECT_TRUE(report.closed() && report.manifold() && report.consistently_oriented());
  EXPECT_NEAR(report.volume, 0.3 * 0.1 * 0.1, 1e-15);
  const auto& b = sim.bodies()[0];
  EXPECT_FALSE(b.lattice);
  EXPECT_EQ(b.pinned.size(), 9u);  // the 3×3 nodes of the end face
  // The clamped beam sags; pinned nodes stay put.
  sim.advance_to(0.05);
  for (const Index n : b.pinned) EXPECT_TRUE(b.body.positions.row(n) == b.body.rest_positions.row(n));
  EXPECT_LT(sim.surface().vertices.col(2).minCoeff(), -0.05 - 1e-3);  // the free end has fallen
  EXPECT_EQ(sim.remeshes(), 0);
}

TEST(Simulation, ARunawayStateStopsWithADiagnosisNamingStepAndElement) {
  Scene scene = scene_from(thrown_cube());
  scene.limits.max_speed = 1.0;  // the cube is thrown at 2 m/s
  Simulation sim(scene);
  try {
    sim.advance_to(0.01);
    FAIL() << "no NumericalFailure";
  } catch (const NumericalFailure& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("at step 1 "));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("body 'cube', node"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("of element"));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("limits.max_speed"));
  }
}

TEST(Simulation, LoadRefusesAStateOfAnotherScene) {
  Simulation a(scene_from(thrown_cube()));
  StateRecord r = a.save();
  r.put("bodies/count", std::int64_t{2});
  EXPECT_TRUE(test::throws_error_containing([&] { a.load(r); }, "the state holds 2 bodies"));
  StateRecord bad = a.save();
  const Tets out_of_range = Tets::Constant(3, 4, 100000);
  bad.put("bodies/0/tets", out_of_range);
  EXPECT_TRUE(test::throws_error_containing([&] { a.load(bad); }, "ids do not agree"));
}

}  // namespace
}  // namespace goo
