// Lattice meshing stages on real models: what a re-mesh costs.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <vector>
#include <filesystem>
#include <map>
#include <numeric>

#include "bench/bench_models.h"
#include "core/damping.h"
#include "core/elastic_forces.h"
#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "io/surface_mesh_io.h"
#include "meshing/exact_mass.h"
#include "meshing/lattice_mesh.h"
#include "meshing/material_parts.h"
#include "meshing/surface_upkeep.h"
#include "meshing/transfer.h"
#include "meshing/voxelize.h"
#include "solvers/remesh.h"

namespace {

const std::filesystem::path kAssets = GOO_ASSETS_DIR;
const char* const kModels[] = {"bunny00.off", "armadillo.off"};

const goo::TriangleMesh* model(int index) {
  static std::map<int, goo::TriangleMesh> cache;
  if (const auto it = cache.find(index); it != cache.end()) return &it->second;
  const auto path = kAssets / kModels[index];
  if (!std::filesystem::exists(path)) return nullptr;
  return &cache.emplace(index, goo::io::read_surface_mesh(path)).first->second;
}

using goo::bench::spacing_for;

void configure(benchmark::internal::Benchmark* b) {
  for (int m = 0; m < 2; ++m)
    for (const int k : {8, 20, 60}) b->Args({m, k});
  b->Unit(benchmark::kMillisecond);
}

// Args: model (0 bunny00, 1 armadillo), target thousands of tetrahedra.
void BM_Voxelize(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  const goo::LatticeMesh lm = goo::build_lattice_mesh(*mesh, h);
  for (auto _ : state) benchmark::DoNotOptimize(goo::voxelize(lm.lattice, *mesh));
  state.counters["tets"] = lm.mesh.num_elements();
}
BENCHMARK(BM_Voxelize)->Apply(configure);

/// The whole mesh generation: voxelisation, kept tetrahedra, numbering.
void BM_BuildTets(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  goo::Index tets = 0;
  for (auto _ : state) {
    const goo::LatticeMesh lm = goo::build_lattice_mesh(*mesh, h);
    tets = lm.mesh.num_elements();
  }
  state.counters["tets"] = tets;
}
BENCHMARK(BM_BuildTets)->Apply(configure);

void BM_Embed(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const goo::LatticeMesh lm =
      goo::build_lattice_mesh(*mesh, spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1))));
  for (auto _ : state) benchmark::DoNotOptimize(goo::embed(lm, mesh->vertices));
  state.counters["tets"] = lm.mesh.num_elements();
  state.SetItemsProcessed(state.iterations() * mesh->num_vertices());
}
BENCHMARK(BM_Embed)->Apply(configure);

/// Exact sub-element masses: the surface clipped to every element, then
/// the node masses.
void BM_ExactMass(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const goo::LatticeMesh lm =
      goo::build_lattice_mesh(*mesh, spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1))));
  for (auto _ : state) {
    const goo::ElementSolid solid = goo::clip_solid_to_elements(lm, *mesh);
    benchmark::DoNotOptimize(goo::exact_node_masses(lm, solid, 1000.0, {}, 0.0));
  }
  state.counters["tets"] = lm.mesh.num_elements();
}
BENCHMARK(BM_ExactMass)->Apply(configure);

/// The connected parts of every element's material (what a re-mesh must
/// keep apart), on a lattice mesh already built.
void BM_MaterialParts(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const goo::LatticeMesh lm =
      goo::build_lattice_mesh(*mesh, spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1))));
  for (auto _ : state) benchmark::DoNotOptimize(goo::material_parts(lm, *mesh));
  state.counters["tets"] = lm.mesh.num_elements();
}
BENCHMARK(BM_MaterialParts)->Apply(configure);

/// The same given the surface's pieces the exact masses sliced: what the
/// separated re-mesh adds to a plain one.
void BM_MaterialPartsFromPieces(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const goo::LatticeMesh lm =
      goo::build_lattice_mesh(*mesh, spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1))));
  const goo::SurfacePieces pieces = goo::slice_surface(lm, *mesh);
  for (auto _ : state) benchmark::DoNotOptimize(goo::material_parts(lm, *mesh, pieces));
  state.counters["tets"] = lm.mesh.num_elements();
}
BENCHMARK(BM_MaterialPartsFromPieces)->Apply(configure);

using goo::bench::deformed_body;

/// The state transfer alone, onto a new lattice mesh already built: node
/// location and velocity interpolation, overlap volumes, left-stretch
/// averaging.
void BM_Transfer(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  const goo::MeshedBody mb = deformed_body(*mesh, h);
  const goo::Body& body = mb.body;
  const goo::LatticeMesh lm = goo::build_lattice_mesh(mb.surface(), h);
  std::vector<Eigen::Matrix3d> Fe(static_cast<std::size_t>(body.num_elements()));
  for (goo::Index e = 0; e < body.num_elements(); ++e)
    Fe[static_cast<std::size_t>(e)] = goo::deformation_gradient(body, body.positions, e);
  for (auto _ : state) {
    const goo::NodeSources sources = goo::locate_in_old_mesh(body.tets, body.positions, lm);
    benchmark::DoNotOptimize(goo::interpolate(sources, body.tets, body.velocities));
    const goo::ElementOverlaps overlaps = goo::element_overlaps(body.tets, body.positions, lm);
    benchmark::DoNotOptimize(goo::transfer_elastic_state(overlaps, sources, Fe, body.alpha, lm, 0.05));
  }
  state.counters["tets"] = lm.mesh.num_elements();
}
BENCHMARK(BM_Transfer)->Apply(configure);

/// The transfer's overlap volumes alone (each old element sliced along the
/// new lattice's planes, lattice_slicing.h), on one thread: the slicer's
/// cost per old element. Old elements per second.
void BM_ElementOverlaps(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  const goo::MeshedBody mb = deformed_body(*mesh, h);
  const goo::LatticeMesh lm = goo::build_lattice_mesh(mb.surface(), h);
  std::size_t pairs = 0;
  for (auto _ : state) {
    const goo::ElementOverlaps overlaps = goo::element_overlaps(mb.body.tets, mb.body.positions, lm);
    pairs = overlaps.volume.size();
  }
  state.counters["pairs"] = static_cast<double>(pairs);
  state.SetItemsProcessed(state.iterations() * mb.body.num_elements());
}
BENCHMARK(BM_ElementOverlaps)->Apply(configure);

/// The whole re-mesh of a deformed, moving body: new lattice mesh, transfer,
/// exact masses, conservation, re-embedding; with `separate`, the copies per
/// part of the material too (what a scene does by default).
void remesh_benchmark(benchmark::State& state, bool separate) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  const goo::MeshedBody mb = deformed_body(*mesh, h);
  const goo::TriangleMesh surface = mb.surface();
  goo::Index tets = 0;
  goo::RemeshTimes times;
  for (auto _ : state) {
    goo::RemeshReport report;
    const goo::MeshedBody next = goo::remesh(mb.body, surface, h, &report, nullptr, nullptr, separate);
    tets = next.body.num_elements();
    times += report.times;
  }
  state.counters["tets"] = tets;
  // Each stage's share, in milliseconds a re-mesh.
  const double per = 1e3 / static_cast<double>(std::max<benchmark::IterationCount>(state.iterations(), 1));
  state.counters["lattice_ms"] = times.lattice * per;
  state.counters["transfer_ms"] = times.transfer * per;
  state.counters["masses_ms"] = times.masses * per;
  state.counters["conservation_ms"] = times.conservation * per;
  if (separate) state.counters["separation_ms"] = times.separation * per;
}
void BM_Remesh(benchmark::State& state) { remesh_benchmark(state, false); }
BENCHMARK(BM_Remesh)->Apply(configure);
void BM_RemeshSeparated(benchmark::State& state) { remesh_benchmark(state, true); }
BENCHMARK(BM_RemeshSeparated)->Apply(configure);

/// The surface upkeep a re-mesh runs first (splits, collapses, flips, each
/// refused where it would make the surface cross itself), on the deformed
/// model's surface: the whole-surface passes a re-mesh pays even when few
/// edges need work.
void BM_SurfaceUpkeep(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  const goo::TriangleMesh surface = deformed_body(*mesh, h).surface();
  goo::UpkeepReport report;
  for (auto _ : state) {
    goo::TriangleMesh upkept = surface;
    report = goo::upkeep_surface(upkept, h);
    benchmark::DoNotOptimize(upkept.triangles.data());
  }
  state.counters["triangles"] = static_cast<double>(surface.num_triangles());
  state.counters["splits"] = static_cast<double>(report.splits);
  state.counters["collapses"] = static_cast<double>(report.collapses);
  state.counters["flips"] = static_cast<double>(report.flips);
}
BENCHMARK(BM_SurfaceUpkeep)->Apply(configure);

/// The damping operator on a real model's lattice mesh, as a CG iteration
/// applies it: −C p, then p changed on the calling thread. Unlike
/// BM_DampingApply's box, whose nodes are numbered along its elements by
/// construction, this reads a lattice mesh's numbering: in space order as
/// the mesher numbers them (order 0), or in lattice key order, corners then
/// centres, as before session 32 (order 1: every element has nodes in both
/// halves of the node arrays, so two threads write and read each other's
/// data). Args: model, thousands of tetrahedra, threads, order. Elements per
/// second.
void BM_DampingApplyModel(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                                  static_cast<std::size_t>(state.range(2)));
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  goo::Material material;
  material.viscosity = 100.0;
  const goo::LatticeMesh lm = goo::build_lattice_mesh(*mesh, h);
  goo::TetMesh tets = lm.mesh;
  if (state.range(3) == 1) {  // renumbered in key order
    std::vector<goo::Index> by_key(lm.node_keys.size()), number(lm.node_keys.size());
    std::iota(by_key.begin(), by_key.end(), goo::Index{0});
    std::sort(by_key.begin(), by_key.end(), [&](goo::Index a, goo::Index b) {
      return lm.node_keys[static_cast<std::size_t>(a)] < lm.node_keys[static_cast<std::size_t>(b)];
    });
    for (std::size_t i = 0; i < by_key.size(); ++i) {
      number[static_cast<std::size_t>(by_key[i])] = static_cast<goo::Index>(i);
      tets.positions.row(static_cast<goo::Index>(i)) = lm.mesh.positions.row(by_key[i]);
    }
    for (goo::Index e = 0; e < tets.num_elements(); ++e)
      for (int k = 0; k < 4; ++k) tets.tets(e, k) = number[static_cast<std::size_t>(lm.mesh.tets(e, k))];
  }
  goo::Body body = goo::make_body(std::move(tets), material);
  goo::bench::deform(body);
  goo::ElasticForces forces;
  goo::Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  goo::Damping damping;
  damping.freeze(body, forces);
  goo::Points p = body.velocities, out;
  for (auto _ : state) {
    damping.apply(body, p, out);
    p -= 1e-9 * out;
    benchmark::DoNotOptimize(p.data());
  }
  state.SetItemsProcessed(state.iterations() * body.num_elements());
  state.counters["tets"] = body.num_elements();
  state.counters["threads"] = static_cast<double>(state.range(2));
}
BENCHMARK(BM_DampingApplyModel)
    ->ArgsProduct({{0}, {10, 60}, {1, 2}, {0, 1}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

}  // namespace
