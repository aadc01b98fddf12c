// The checkpoint schema: the keys a checkpoint holds are exactly the ones
// docs/running.md lists (tools outside goo read them), each group reads back
// what it wrote, bit for bit, and a damaged value is refused naming its key.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "core/error.h"
#include "core/primitives.h"
#include "io/scene_io.h"
#include "solvers/checkpoint_schema.h"
#include "solvers/simulation.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Scene two_body_scene() {
  return io::parse_scene(R"({
    "ground": {"height": 0.0},
    "objects": [
      {"name": "cube", "primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 4},
       "transform": {"translate": [0, 0, 0.1]}, "material": {"preset": "gooey_jelly"}, "lattice_spacing": 0.03},
      {"name": "ball", "primitive": {"type": "sphere", "radius": 0.05, "segments": 12},
       "transform": {"translate": [0.3, 0, 0.1]}, "material": {"preset": "jiggly_gelatin"}, "lattice_spacing": 0.03,
       "pinned": [{"box": {"min": [0.2, -1, -1], "max": [0.3, 1, 1]}}]}]
  })",
                         "schema.json", ".");
}

std::set<std::string> keys(const StateRecord& r) {
  std::set<std::string> out;
  for (const auto& [name, array] : r.arrays()) out.insert(name);
  for (const auto& [name, text] : r.strings()) out.insert(name);
  return out;
}

/// docs/running.md, "Checkpoints": every key of a checkpoint with two bodies
/// and one mesh obstacle.
std::set<std::string> documented_keys(bool solid_fractions) {
  std::set<std::string> out = {"time",
                               "steps",
                               "remeshes",
                               "last_time_step",
                               "run/frame",
                               "run/initial_mass",
                               "run/initial_volume",
                               "run/initial_momentum",
                               "scene/text",
                               "scene/source",
                               "scene/base_folder",
                               "scene/obstacle_meshes/count",
                               "scene/obstacle_meshes/0/field",
                               "scene/obstacle_meshes/0/vertices",
                               "scene/obstacle_meshes/0/triangles",
                               "bodies/count"};
  for (const char* body : {"bodies/0/", "bodies/1/"}) {
    for (const char* field : {"name", "lattice", "lattice_spacing", "rest_positions", "positions", "velocities",
                              "masses", "tets", "Dm_inv", "rest_volumes", "Fp", "alpha", "rest_condition",
                              "surface_triangles", "embedding_parent", "embedding_bary", "pinned",
                              "rest_material_volume"})
      out.insert(std::string(body) + field);
    if (solid_fractions) out.insert(std::string(body) + "solid_fractions");
  }
  return out;
}

TEST(CheckpointSchema, ACheckpointHoldsExactlyTheDocumentedKeys) {
  Scene scene = two_body_scene();
  scene.obstacle_meshes["/obstacles/0/shape/path"] = make_box(Eigen::Vector3d(0.1, 0.1, 0.1), 1);
  const Simulation sim(scene);
  StateRecord r;
  sim.save(r);
  checkpoint::put_run(r, checkpoint::RunFields{3, 1.5, 0.002, Eigen::Vector3d(1, 2, 3)});
  checkpoint::put_scene(r, scene);
  ASSERT_GT(sim.bodies()[0].body.solid_fractions.size(), 0);  // lattice bodies hold them
  EXPECT_EQ(keys(r), documented_keys(true));
}

TEST(CheckpointSchema, EveryGroupReadsBackWhatItWroteBitForBit) {
  Scene scene = two_body_scene();
  scene.obstacle_meshes["/obstacles/0/shape/path"] = make_box(Eigen::Vector3d(0.1, 0.2, 0.3), 2);
  const Simulation sim(scene);
  StateRecord r;
  const checkpoint::Clock clock{0.125, 17, 2, 1.0 / 3.0};
  checkpoint::put_clock(r, clock);
  checkpoint::put_body_count(r, sim.bodies().size());
  for (std::size_t i = 0; i < sim.bodies().size(); ++i) {
    const SimulationBody& b = sim.bodies()[i];
    checkpoint::put_body(r, i, b.name, b.lattice, b.h, b.body, b.pinned);
  }
  const checkpoint::RunFields run{7, 0.75, 1e-3 / 3.0, Eigen::Vector3d(-0.1, 1.0 / 7.0, 2e-17)};
  checkpoint::put_run(r, run);
  checkpoint::put_scene(r, scene);

  const checkpoint::Clock c = checkpoint::get_clock(r);
  EXPECT_EQ(c.time, clock.time);
  EXPECT_EQ(c.steps, clock.steps);
  EXPECT_EQ(c.remeshes, clock.remeshes);
  EXPECT_EQ(c.last_time_step, clock.last_time_step);
  ASSERT_EQ(checkpoint::get_body_count(r), 2);
  for (std::size_t i = 0; i < 2; ++i) {
    const SimulationBody& b = sim.bodies()[i];
    const checkpoint::StoredBody s = checkpoint::get_body(r, i);
    EXPECT_EQ(s.name, b.name);
    EXPECT_EQ(s.lattice, b.lattice);
    EXPECT_EQ(s.lattice_spacing, b.h);
    EXPECT_EQ(s.pinned, b.pinned);
    EXPECT_EQ(s.body.rest_positions, b.body.rest_positions);
    EXPECT_EQ(s.body.positions, b.body.positions);
    EXPECT_EQ(s.body.velocities, b.body.velocities);
    EXPECT_EQ(s.body.masses, b.body.masses);
    EXPECT_EQ(s.body.tets, b.body.tets);
    EXPECT_EQ(s.body.Dm_inv, b.body.Dm_inv);
    EXPECT_EQ(s.body.rest_volumes, b.body.rest_volumes);
    EXPECT_EQ(s.body.Fp, b.body.Fp);
    EXPECT_EQ(s.body.alpha, b.body.alpha);
    EXPECT_EQ(s.body.rest_condition, b.body.rest_condition);
    EXPECT_EQ(s.body.solid_fractions, b.body.solid_fractions);
    EXPECT_EQ(s.body.surface_triangles, b.body.surface_triangles);
    EXPECT_EQ(s.body.embedding.parent, b.body.embedding.parent);
    EXPECT_EQ(s.body.embedding.bary, b.body.embedding.bary);
    EXPECT_EQ(s.body.rest_material_volume, b.body.rest_material_volume);
  }
  EXPECT_FALSE(sim.bodies()[1].pinned.empty());  // the round trip of a non-empty list was checked
  const checkpoint::RunFields back = checkpoint::get_run(r);
  EXPECT_EQ(back.frame, run.frame);
  EXPECT_EQ(back.initial_mass, run.initial_mass);
  EXPECT_EQ(back.initial_volume, run.initial_volume);
  EXPECT_EQ(back.initial_momentum, run.initial_momentum);
  EXPECT_EQ(checkpoint::get_scene_text(r), scene.text);
  EXPECT_EQ(checkpoint::get_scene_source(r), scene.source);
  EXPECT_EQ(checkpoint::get_scene_base_folder(r), scene.base_folder);
  const auto meshes = checkpoint::get_obstacle_meshes(r);
  ASSERT_EQ(meshes.size(), 1U);
  EXPECT_EQ(meshes.at("/obstacles/0/shape/path").vertices, scene.obstacle_meshes.at("/obstacles/0/shape/path").vertices);
  EXPECT_EQ(meshes.at("/obstacles/0/shape/path").triangles, scene.obstacle_meshes.at("/obstacles/0/shape/path").triangles);
}

TEST(CheckpointSchema, DamagedOrMissingValuesAreRefusedNamingTheKey) {
  const Simulation sim(two_body_scene());
  StateRecord full;
  sim.save(full);
  checkpoint::put_run(full, checkpoint::RunFields{1, 1.0, 1.0, Eigen::Vector3d::Zero()});

  StateRecord two_rows = full;
  two_rows.put_matrix("run/initial_momentum", Eigen::MatrixXd::Zero(2, 3));
  EXPECT_TRUE(test::throws_error_containing([&] { (void)checkpoint::get_run(two_rows); },
                                            "run/initial_momentum must be one row of 3 values, got 2 rows"));

  // Every key of a body, left out in turn, is named by the reader.
  for (const auto& [name, array] : full.arrays()) {
    if (name.rfind("bodies/1/", 0) != 0 || name == "bodies/1/solid_fractions") continue;  // optional
    StateRecord without;
    for (const auto& [other, a] : full.arrays())
      if (other != name) without.put_array(other, a);
    for (const auto& [other, text] : full.strings()) without.put_string(other, text);
    EXPECT_TRUE(test::throws_error_containing([&] { (void)checkpoint::get_body(without, 1); }, name)) << name;
  }
  StateRecord no_name;
  for (const auto& [other, a] : full.arrays()) no_name.put_array(other, a);
  EXPECT_TRUE(test::throws_error_containing([&] { (void)checkpoint::get_body(no_name, 0); }, "bodies/0/name"));

  StateRecord bad_count = full;
  bad_count.put("scene/obstacle_meshes/count", std::int64_t{-3});
  EXPECT_TRUE(test::throws_error_containing([&] { (void)checkpoint::get_obstacle_meshes(bad_count); },
                                            "scene/obstacle_meshes/count is -3"));
}

}  // namespace
}  // namespace goo
