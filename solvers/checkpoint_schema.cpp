#include "solvers/checkpoint_schema.h"

#include <fmt/format.h>

#include "core/error.h"
#include "core/surface_check.h"

namespace goo::checkpoint {

namespace {
constexpr const char* kTime = "time";
constexpr const char* kSteps = "steps";
constexpr const char* kRemeshes = "remeshes";
constexpr const char* kLastTimeStep = "last_time_step";
constexpr const char* kBodyCount = "bodies/count";
constexpr const char* kFrame = "run/frame";
constexpr const char* kInitialMass = "run/initial_mass";
constexpr const char* kInitialVolume = "run/initial_volume";
constexpr const char* kInitialMomentum = "run/initial_momentum";
constexpr const char* kSceneText = "scene/text";
constexpr const char* kSceneSource = "scene/source";
constexpr const char* kSceneBaseFolder = "scene/base_folder";
constexpr const char* kObstacleMeshCount = "scene/obstacle_meshes/count";

std::string obstacle_mesh_prefix(std::int64_t k) { return fmt::format("scene/obstacle_meshes/{}/", k); }
}  // namespace

void put_clock(StateSink& sink, const Clock& clock) {
  sink.put(kTime, clock.time);
  sink.put(kSteps, clock.steps);
  sink.put(kRemeshes, clock.remeshes);
  sink.put(kLastTimeStep, clock.last_time_step);
}

Clock get_clock(const StateRecord& record) {
  return Clock{record.real(kTime), record.integer(kSteps), record.integer(kRemeshes), record.real(kLastTimeStep)};
}

void put_body_count(StateSink& sink, std::size_t count) { sink.put(kBodyCount, static_cast<std::int64_t>(count)); }

std::int64_t get_body_count(const StateRecord& record) { return record.integer(kBodyCount); }

std::string body_prefix(std::size_t i) { return fmt::format("bodies/{}/", i); }

void put_body(StateSink& sink, std::size_t i, const std::string& name, bool lattice, double lattice_spacing,
              const Body& body, const std::vector<Index>& pinned) {
  const std::string p = body_prefix(i);
  sink.put_string(p + "name", name);
  sink.put(p + "lattice", static_cast<std::int64_t>(lattice));
  sink.put(p + "lattice_spacing", lattice_spacing);
  sink.put_matrix(p + "rest_positions", body.rest_positions);
  sink.put_matrix(p + "positions", body.positions);
  sink.put_matrix(p + "velocities", body.velocities);
  sink.put_vector(p + "masses", body.masses);
  sink.put(p + "tets", body.tets);
  sink.put(p + "Dm_inv", body.Dm_inv);
  sink.put_vector(p + "rest_volumes", body.rest_volumes);
  sink.put(p + "Fp", body.Fp);
  sink.put_vector(p + "alpha", body.alpha);
  sink.put_vector(p + "rest_condition", body.rest_condition);
  if (body.solid_fractions.size() > 0) sink.put_vector(p + "solid_fractions", body.solid_fractions);
  sink.put(p + "surface_triangles", body.surface_triangles);
  sink.put(p + "embedding_parent", body.embedding.parent);
  sink.put_matrix(p + "embedding_bary", body.embedding.bary);
  sink.put(p + "pinned", pinned);
  sink.put(p + "rest_material_volume", body.rest_material_volume);
}

StoredBody get_body(const StateRecord& record, std::size_t i) {
  const std::string p = body_prefix(i);
  StoredBody out;
  out.name = record.string(p + "name");
  out.lattice = record.integer(p + "lattice") != 0;
  out.lattice_spacing = record.real(p + "lattice_spacing");
  Body& body = out.body;
  body.rest_positions = record.points(p + "rest_positions");
  body.positions = record.points(p + "positions");
  body.velocities = record.points(p + "velocities");
  body.masses = record.vector(p + "masses");
  body.tets = record.tets(p + "tets");
  body.Dm_inv = record.matrices3(p + "Dm_inv");
  body.rest_volumes = record.vector(p + "rest_volumes");
  body.Fp = record.matrices3(p + "Fp");
  body.alpha = record.vector(p + "alpha");
  body.rest_condition = record.vector(p + "rest_condition");
  if (record.has(p + "solid_fractions")) body.solid_fractions = record.vector(p + "solid_fractions");
  body.surface_triangles = record.triangles(p + "surface_triangles");
  body.embedding.parent = record.indices(p + "embedding_parent");
  body.embedding.bary = record.matrix(p + "embedding_bary", 4);
  out.pinned = record.indices(p + "pinned");
  body.rest_material_volume = record.real(p + "rest_material_volume");
  return out;
}

void put_run(StateSink& sink, const RunFields& run) {
  sink.put(kFrame, run.frame);
  sink.put(kInitialMass, run.initial_mass);
  sink.put(kInitialVolume, run.initial_volume);
  sink.put_matrix(kInitialMomentum, run.initial_momentum.transpose());
}

RunFields get_run(const StateRecord& record) {
  RunFields run;
  run.frame = record.integer(kFrame);
  run.initial_mass = record.real(kInitialMass);
  run.initial_volume = record.real(kInitialVolume);
  const Eigen::MatrixXd momentum = record.matrix(kInitialMomentum, 3);
  if (momentum.rows() != 1)
    throw Error(fmt::format("{} must be one row of 3 values, got {} rows", kInitialMomentum, momentum.rows()));
  run.initial_momentum = momentum.row(0).transpose();
  return run;
}

void put_scene(StateSink& sink, const Scene& scene) {
  sink.put_string(kSceneText, scene.text);
  sink.put_string(kSceneSource, scene.source);
  sink.put_string(kSceneBaseFolder, scene.base_folder);
  sink.put(kObstacleMeshCount, static_cast<std::int64_t>(scene.obstacle_meshes.size()));
  std::int64_t k = 0;
  for (const auto& [field, mesh] : scene.obstacle_meshes) {
    const std::string p = obstacle_mesh_prefix(k++);
    sink.put_string(p + "field", field);
    sink.put_matrix(p + "vertices", mesh.vertices);
    sink.put(p + "triangles", mesh.triangles);
  }
}

const std::string& get_scene_text(const StateRecord& record) { return record.string(kSceneText); }
const std::string& get_scene_source(const StateRecord& record) { return record.string(kSceneSource); }
const std::string& get_scene_base_folder(const StateRecord& record) { return record.string(kSceneBaseFolder); }

std::map<std::string, TriangleMesh> get_obstacle_meshes(const StateRecord& record) {
  std::map<std::string, TriangleMesh> meshes;
  if (!record.has(kObstacleMeshCount)) return meshes;
  const std::int64_t count = record.integer(kObstacleMeshCount);
  if (count < 0 || count > 100000)
    throw Error(fmt::format("{} is {}, not a number of obstacles", kObstacleMeshCount, count));
  for (std::int64_t k = 0; k < count; ++k) {
    const std::string p = obstacle_mesh_prefix(k);
    TriangleMesh mesh;
    mesh.vertices = record.points(p + "vertices");
    mesh.triangles = record.triangles(p + "triangles");
    validate_surface(mesh, p + "vertices and triangles");
    meshes[record.string(p + "field")] = std::move(mesh);
  }
  return meshes;
}

}  // namespace goo::checkpoint
