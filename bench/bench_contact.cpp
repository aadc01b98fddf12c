// The fine surface against itself: the broad phase, one self-collision
// stage, and the per-frame surface measurements.
#include <benchmark/benchmark.h>

#include <random>

#include "core/contact/box_pairs.h"
#include "core/contact/self_collisions.h"
#include "core/primitives.h"
#include "meshing/surface_intersections.h"
#include "solvers/remesh.h"

namespace {

goo::Material gel() {
  goo::Material m;
  m.density = 1000.0;
  m.youngs_modulus = 2e4;
  m.poisson_ratio = 0.3;
  m.min_mass_fraction = 0.05;
  return m;
}

/// A sphere of radius 0.1 m with about 2·segments² triangles, on a 0.02 m lattice.
goo::Body sphere_body(int segments) {
  return goo::mesh_body(goo::make_sphere(0.1, segments), gel(), 0.02).body;
}

void BM_TriangleBoxPairs(benchmark::State& state) {
  const goo::TriangleMesh mesh = goo::make_sphere(0.1, static_cast<int>(state.range(0)));
  std::vector<goo::Box3> boxes(static_cast<std::size_t>(mesh.num_triangles()));
  for (goo::Index t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) boxes[static_cast<std::size_t>(t)].extend(mesh.vertices.row(mesh.triangles(t, k)).transpose());
  std::size_t pairs = 0;
  for (auto _ : state) {
    pairs = goo::overlapping_pairs(boxes).size();
    benchmark::DoNotOptimize(pairs);
  }
  state.SetItemsProcessed(state.iterations() * mesh.num_triangles());
  state.counters["triangles"] = mesh.num_triangles();
  state.counters["pairs"] = static_cast<double>(pairs);
}
BENCHMARK(BM_TriangleBoxPairs)->Arg(64)->Arg(160)->Unit(benchmark::kMillisecond);

/// One stage on a step that moves every node by a small random amount (no
/// impact: the cost of watching), with the candidate list built (/0) or
/// kept from the step before (/1).
void BM_SelfCollisionStage(benchmark::State& state) {
  const goo::Body body = sphere_body(static_cast<int>(state.range(0)));
  const bool kept = state.range(1) != 0;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 1e-5);
  goo::Points d(body.num_nodes(), 3);
  for (goo::Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) d(n, k) = noise(rng);
  goo::SelfCollisions stage;
  const goo::SelfCollisionParameters parameters{2e-5, 0.0, 8};
  for (auto _ : state) {
    if (!kept) stage = goo::SelfCollisions();
    goo::Points step = d;
    benchmark::DoNotOptimize(stage.resolve(body, body.positions, step, {}, parameters));
  }
  state.SetItemsProcessed(state.iterations() * body.surface_triangles.rows());
  state.counters["triangles"] = static_cast<double>(body.surface_triangles.rows());
}
BENCHMARK(BM_SelfCollisionStage)->Args({64, 0})->Args({64, 1})->Args({160, 0})->Args({160, 1})->Unit(benchmark::kMillisecond);

void BM_SurfaceQuality(benchmark::State& state) {
  const goo::TriangleMesh mesh = goo::make_sphere(0.1, static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(goo::measure_surface_quality(mesh));
  state.SetItemsProcessed(state.iterations() * mesh.num_triangles());
  state.counters["triangles"] = mesh.num_triangles();
}
BENCHMARK(BM_SurfaceQuality)->Arg(64)->Arg(160)->Unit(benchmark::kMillisecond);

}  // namespace
