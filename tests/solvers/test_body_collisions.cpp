// Collisions between bodies (W&T sec. 4, fig. 9): two bodies stepped
// together never pass through each other, keep their total momentum, stay
// two bodies (no element holds both), and give the same bits on one and two
// threads and after a resume.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <memory>

#include "io/scene_io.h"
#include "meshing/surface_intersections.h"
#include "solvers/simulation.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

/// Two gooey cubes of 0.1 m thrown at each other in free space, `offset`
/// apart sideways (0: head on), `spin` about z, with the key `between`.
std::string cubes_thrown_together(const std::string& between = "true", double offset = 0.0, double spin = 0.0,
                                  const std::string& integrator = R"({"type": "newmark"})") {
  return fmt::format(R"({{
    "gravity": [0, 0, 0],
    "integrator": {},
    "collisions_between_bodies": {},
    "objects": [
      {{"name": "left", "primitive": {{"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 6}},
        "transform": {{"translate": [-0.075, 0, 0]}}, "velocity": [1.5, 0, 0], "angular_velocity": [0, 0, {}],
        "material": {{"preset": "gooey_jelly", "min_mass_fraction": 0.05}}, "lattice_spacing": 0.025}},
      {{"name": "right", "primitive": {{"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 6}},
        "transform": {{"translate": [0.075, {}, 0], "rotate_degrees": [0, 0, 30]}}, "velocity": [-1.5, 0, 0],
        "material": {{"preset": "viscous_ooze", "youngs_modulus": 2e4, "min_mass_fraction": 0.05}},
        "lattice_spacing": 0.02}}
    ]
  }})",
                     integrator, between, spin, offset);
}

Scene scene_from(const std::string& text) { return io::parse_scene(text, "test.json", "."); }

/// Triangle pairs of two different bodies that cross (exact predicates).
std::size_t crossings_between(const Simulation& sim) {
  const std::vector<std::int32_t> body = sim.surface_bodies();
  std::size_t count = 0;
  for (const auto& [a, b] : self_intersecting_pairs(sim.surface()))
    if (body[static_cast<std::size_t>(a)] != body[static_cast<std::size_t>(b)]) ++count;
  return count;
}

/// The centre of mass of body i, m.
Eigen::Vector3d centre(const Simulation& sim, std::size_t i) {
  const Body& b = sim.bodies()[i].body;
  return (b.positions.array().colwise() * b.masses.array()).colwise().sum().transpose() / b.masses.sum();
}

void expect_same_state(const Simulation& a, const Simulation& b) { test::expect_same_records(a.save(), b.save()); }

TEST(BodyCollisions, CubesThrownHeadOnStopEachOtherAndNeverCross) {
  // The cubes' faces are 0.05 m apart and close at 3 m/s: they meet at
  // t ≈ 17 ms. Without the stage they pass through each other.
  for (const bool on : {false, true}) {
    SCOPED_TRACE(on ? "collisions between bodies" : "switched off");
    Simulation sim(scene_from(cubes_thrown_together(on ? "true" : "false", 0.03, 20.0)));
    const SimulationTotals start = sim.totals();
    std::size_t most = 0;
    double closest = 1.0;
    for (int frame = 1; frame <= 12; ++frame) {  // 0.1 s
      ASSERT_TRUE(sim.advance_to(frame / 120.0));
      most = std::max(most, crossings_between(sim));
      closest = std::min(closest, centre(sim, 1).x() - centre(sim, 0).x());
    }
    if (!on) {
      EXPECT_GT(most, 0u);
      EXPECT_LT(closest, 0.0);  // through each other
      continue;
    }
    EXPECT_EQ(most, 0u);
    // Each 0.1 m cube keeps the other's centre beyond its own half width
    // (they flatten against each other; they do not interpenetrate).
    EXPECT_GT(closest, 0.05);
    // No external force: the joint stage's impulses sum to zero, as the
    // elastic, damping and volume forces do; round-off scale as in
    // Simulation.MassIsConservedAndMomentumToo_WhenNoExternalForceActs.
    const SimulationTotals end = sim.totals();
    EXPECT_NEAR(end.mass, start.mass, 1e-12 * start.mass);
    EXPECT_LT((end.momentum - start.momentum).norm(), 1e-12 * start.mass * 3.0);
    // The approach was stopped: the centres no longer close at 3 m/s.
    const auto mean_velocity = [&](std::size_t i) {
      const Body& b = sim.bodies()[i].body;
      return Eigen::Vector3d((b.velocities.array().colwise() * b.masses.array()).colwise().sum().transpose() /
                             b.masses.sum());
    };
    EXPECT_GT(mean_velocity(1).x() - mean_velocity(0).x(), -0.5);
    EXPECT_GT(sim.self_collision_totals().impacts + sim.self_collision_totals().repulsions, 0);
  }
}

TEST(BodyCollisions, TheTwoHandsMeetInMidFlightAndNeverCross) {
  // scenes/two_hands.json (W&T fig. 9) on a coarser lattice, through the
  // meeting (the hands' knuckles are 0.07 m apart and close at 3 m/s).
  Scene scene = io::read_scene(std::filesystem::path(GOO_SOURCE_DIR) / "scenes" / "two_hands.json");
  for (SceneObject& o : scene.objects) o.lattice_spacing = 0.025;
  Simulation sim(scene);
  const double v0 = sim.totals().volume;
  for (int frame = 1; frame <= 4; ++frame) {
    sim.make_restart_point();
    ASSERT_TRUE(sim.advance_to(frame / scene.output.fps));
    EXPECT_EQ(self_intersecting_pairs(sim.surface()).size(), 0u) << "frame " << frame;  // within or between
    EXPECT_NEAR(sim.totals().volume, v0, 0.01 * v0) << "frame " << frame;  // both incompressible presets
  }
  EXPECT_GT(sim.self_collision_totals().impacts, 0);
  // They met and move on together: the centres' approach (3 m/s) is gone.
  const auto velocity = [&](std::size_t i) {
    const Body& b = sim.bodies()[i].body;
    return Eigen::Vector3d((b.velocities.array().colwise() * b.masses.array()).colwise().sum().transpose() /
                           b.masses.sum());
  };
  EXPECT_LT(std::abs(velocity(1).x() - velocity(0).x()), 0.5);
  EXPECT_GT(centre(sim, 1).x() - centre(sim, 0).x(), 0.0);  // in their order: not through each other
}

TEST(BodyCollisions, BackwardEulerBodiesStepTogetherToo) {
  Simulation sim(scene_from(cubes_thrown_together("true", 0.0, 0.0, R"({"type": "backward_euler", "time_step": 0.002})")));
  const SimulationTotals start = sim.totals();
  for (int frame = 1; frame <= 8; ++frame) {
    sim.make_restart_point();  // as goo run does each frame
    ASSERT_TRUE(sim.advance_to(frame / 120.0));
    EXPECT_EQ(crossings_between(sim), 0u) << "frame " << frame;
  }
  EXPECT_GT(centre(sim, 1).x() - centre(sim, 0).x(), 0.05);
  EXPECT_LT((sim.totals().momentum - start.momentum).norm(), 1e-12 * start.mass * 3.0);
}

TEST(BodyCollisions, SameBitsOnOneAndTwoThreadsAndAfterAResume) {
  const Scene scene = scene_from(cubes_thrown_together("{\"friction\": 0.5}", 0.03, 20.0));
  auto run = [&](int threads, int frames) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    auto sim = std::make_unique<Simulation>(scene);
    for (int frame = 1; frame <= frames; ++frame) {
      sim->make_restart_point();
      sim->advance_to(frame / 120.0);
    }
    return sim;
  };
  const auto one = run(1, 6), two = run(2, 6);
  EXPECT_GT(one->self_collision_totals().impacts + one->self_collision_totals().repulsions, 0);
  expect_same_state(*one, *two);
  // Resumed at frame 3 (the bodies in contact), on to frame 6.
  const auto first = run(2, 3);
  first->make_restart_point();
  Simulation resumed(scene);
  resumed.load(first->save());
  for (int frame = 4; frame <= 6; ++frame) {
    resumed.make_restart_point();
    resumed.advance_to(frame / 120.0);
  }
  expect_same_state(*two, resumed);
}

}  // namespace
}  // namespace goo
