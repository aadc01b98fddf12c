// The embedded surface at work: collisions against a mesh obstacle and the
// floor, surface tension on the fine surface.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>

#include "core/collisions.h"
#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "core/surface_tension.h"
#include "io/surface_mesh_io.h"
#include "solvers/remesh.h"

namespace {

const std::filesystem::path kAssets = GOO_ASSETS_DIR;

const goo::TriangleMesh* bunny() {
  static const goo::TriangleMesh mesh = [] {
    const auto path = kAssets / "bunny00.off";
    return std::filesystem::exists(path) ? goo::io::read_surface_mesh(path) : goo::TriangleMesh{};
  }();
  return mesh.num_vertices() > 0 ? &mesh : nullptr;
}

/// Bunny00 (37.7k surface vertices) embedded in about 20k elements.
goo::MeshedBody bunny_body(const goo::TriangleMesh& mesh) {
  goo::Material material;
  material.min_mass_fraction = 0.1;
  return goo::mesh_body(mesh, material, std::cbrt(12.0 * goo::surface_integrals(mesh).volume / 20000.0));
}

/// Bunny00 (37.7k surface vertices) on about 20k elements, half sunk into a
/// triangle-mesh ball (a 64-segment sphere, 8k triangles): a velocity
/// collision pass tests every surface vertex of every element near the ball.
/// Arg: threads.
void BM_Collisions(benchmark::State& state) {
  const goo::TriangleMesh* mesh = bunny();
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  const goo::MeshedBody mb = bunny_body(*mesh);
  const Eigen::AlignedBox3d box = goo::bounding_box(mesh->vertices);
  goo::TriangleMesh ball = goo::make_sphere(0.4 * box.sizes().maxCoeff(), 64);
  ball.vertices.rowwise() += box.center().transpose() - Eigen::RowVector3d(0.0, 0.0, 0.5 * box.sizes().z());
  const std::vector<goo::Obstacle> obstacles = {{"ball", goo::make_mesh_shape(ball, "ball"), {}, 0.3}};
  goo::SurfaceCollisions collisions;
  goo::Points v(mb.body.num_nodes(), 3);
  goo::Index resolved = 0;
  for (auto _ : state) {
    v.setConstant(-1.0);
    resolved = collisions.resolve_velocities(mb.body, v, obstacles, 0.0, 1e-3, {}).resolved;
    benchmark::DoNotOptimize(v.data());
  }
  state.counters["resolved"] = resolved;
  state.SetItemsProcessed(state.iterations() * mb.body.embedding.num_vertices());
}
BENCHMARK(BM_Collisions)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

/// The floor under a puddle: the bunny body (20k tets) squashed to a tenth
/// of its height with its lowest twentieth below the floor, so that every
/// element is near the floor (a spread fluid's case: a floor's box and
/// ball tests skip none). Per iteration, from the same positions: the
/// velocity stage and the position stage (up to 4 passes). Arg: threads.
void BM_FloorContact(benchmark::State& state) {
  const goo::TriangleMesh* mesh = bunny();
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(0)));
  goo::MeshedBody mb = bunny_body(*mesh);
  goo::Body& squashed = mb.body;
  const double bottom = squashed.surface().vertices.col(2).minCoeff();
  squashed.positions.col(2) = bottom + 0.1 * (squashed.positions.col(2).array() - bottom);
  const double height = squashed.surface().vertices.col(2).maxCoeff() - bottom;
  const std::vector<goo::Obstacle> obstacles = {
      {"floor", goo::make_half_space(Eigen::Vector3d::UnitZ(), bottom + 0.05 * height), {}, 0.5}};
  goo::SurfaceCollisions collisions;
  goo::Index resolved = 0;
  goo::Body body = squashed;
  for (auto _ : state) {
    body.positions = squashed.positions;
    body.velocities.rowwise() = Eigen::RowVector3d(0.2, 0.1, -1.0);
    resolved = collisions.resolve_velocities(body, body.velocities, obstacles, 0.0, 1e-3, {}).resolved;
    resolved += collisions.resolve_positions(body, obstacles, 0.0, {}).resolved;
    benchmark::DoNotOptimize(body.positions.data());
  }
  state.counters["resolved"] = static_cast<double>(resolved);
  state.SetItemsProcessed(state.iterations() * mb.body.embedding.num_vertices());
}
BENCHMARK(BM_FloorContact)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

/// Surface-tension forces on bunny00 (75k triangles). Args: form (0 area
/// gradient, 1 the paper's), threads.
void BM_SurfaceTension(benchmark::State& state) {
  const goo::TriangleMesh* mesh = bunny();
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(1)));
  const goo::SurfaceTopology topology = goo::SurfaceTopology::build(mesh->triangles, mesh->num_vertices());
  const auto form = state.range(0) == 0 ? goo::SurfaceTensionForm::area_gradient : goo::SurfaceTensionForm::paper;
  goo::Points f;
  for (auto _ : state) {
    goo::surface_tension_forces(*mesh, topology, 0.07, form, f);
    benchmark::DoNotOptimize(f.data());
  }
  state.SetItemsProcessed(state.iterations() * mesh->num_triangles());
}
BENCHMARK(BM_SurfaceTension)->Args({0, 1})->Args({0, 2})->Args({1, 1})->Args({1, 2})->UseRealTime();

}  // namespace
