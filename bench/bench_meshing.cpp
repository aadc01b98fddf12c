// Lattice meshing stages on real models: what a re-mesh costs.
#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>
#include <filesystem>
#include <map>

#include "core/elastic_forces.h"
#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "io/surface_mesh_io.h"
#include "meshing/exact_mass.h"
#include "meshing/lattice_mesh.h"
#include "meshing/transfer.h"
#include "solvers/remesh.h"
#include "meshing/voxelize.h"

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

/// Spacing giving about `tets` lattice tetrahedra inside the solid (12 per
/// cell volume h³ of solid; the surface layer adds more).
double spacing_for(const goo::TriangleMesh& mesh, double tets) {
  return std::cbrt(12.0 * goo::analyze_surface(mesh).volume / tets);
}

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

/// A body meshed around the model, then deformed smoothly (a twist and a
/// shear of a few percent, no longer lattice-aligned), moving and stressed:
/// what a re-mesh meets.
goo::MeshedBody deformed_body(const goo::TriangleMesh& mesh, double h) {
  goo::Material material;
  material.density = 1000.0;
  goo::MeshedBody mb = goo::mesh_body(mesh, material, h);
  goo::Points& x = mb.body.positions;
  const Eigen::AlignedBox3d box = goo::bounding_box(x);
  const double size = box.diagonal().norm();
  for (goo::Index n = 0; n < x.rows(); ++n) {
    const Eigen::Vector3d p = (x.row(n).transpose() - box.center()) / size;  // |p| ≤ ½
    const double angle = 0.3 * p.z();
    const Eigen::Vector3d q(std::cos(angle) * p.x() - std::sin(angle) * p.y() + 0.05 * p.z(),
                            std::sin(angle) * p.x() + std::cos(angle) * p.y(), 1.02 * p.z());
    x.row(n) = (box.center() + size * q).transpose();
    mb.body.velocities.row(n) = Eigen::RowVector3d(-p.y(), p.x(), 0.1);
  }
  return mb;
}

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

/// The whole re-mesh of a deformed, moving body: new lattice mesh, transfer,
/// exact masses, conservation, re-embedding.
void BM_Remesh(benchmark::State& state) {
  const goo::TriangleMesh* mesh = model(static_cast<int>(state.range(0)));
  if (!mesh) return state.SkipWithError("assets missing: run scripts/fetch-assets");
  const double h = spacing_for(*mesh, 1000.0 * static_cast<double>(state.range(1)));
  const goo::MeshedBody mb = deformed_body(*mesh, h);
  const goo::TriangleMesh surface = mb.surface();
  goo::Index tets = 0;
  for (auto _ : state) {
    const goo::MeshedBody next = goo::remesh(mb.body, surface, h);
    tets = next.body.num_elements();
  }
  state.counters["tets"] = tets;
}
BENCHMARK(BM_Remesh)->Apply(configure);

}  // namespace
