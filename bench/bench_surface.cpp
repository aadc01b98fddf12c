// Surface mesh input and checking: what every scene pays before it starts.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "core/primitives.h"
#include "core/surface_check.h"
#include "io/surface_mesh_io.h"

namespace {

const std::filesystem::path kAssets = GOO_ASSETS_DIR;

void BM_AnalyzeSurface(benchmark::State& state) {
  const goo::TriangleMesh mesh = goo::make_sphere(1.0, static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(goo::analyze_surface(mesh));
  state.SetItemsProcessed(state.iterations() * mesh.num_triangles());
  state.counters["triangles"] = mesh.num_triangles();
}
BENCHMARK(BM_AnalyzeSurface)->Arg(64)->Arg(256)->Unit(benchmark::kMillisecond);

void BM_ReadSurfaceMesh(benchmark::State& state) {
  const std::filesystem::path path = kAssets / "bunny00.off";
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("assets/bunny00.off missing: run scripts/fetch-assets");
    return;
  }
  goo::Index triangles = 0;
  for (auto _ : state) {
    const goo::TriangleMesh mesh = goo::io::read_surface_mesh(path);
    triangles = mesh.num_triangles();
    benchmark::DoNotOptimize(triangles);
  }
  state.SetItemsProcessed(state.iterations() * triangles);
}
BENCHMARK(BM_ReadSurfaceMesh)->Unit(benchmark::kMillisecond);

void BM_WriteBinaryPly(benchmark::State& state) {
  const goo::TriangleMesh mesh = goo::make_sphere(1.0, 256);
  const std::filesystem::path path = std::filesystem::temp_directory_path() / "goo_bench_write.ply";
  for (auto _ : state) goo::io::write_surface_mesh(path, mesh);
  std::filesystem::remove(path);
  state.SetItemsProcessed(state.iterations() * mesh.num_triangles());
}
BENCHMARK(BM_WriteBinaryPly)->Unit(benchmark::kMillisecond);

}  // namespace
