// The finite-element kernels: the SVD and the elastic force pass.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <random>

#include "core/body.h"
#include "core/elastic_forces.h"
#include "core/svd3.h"

namespace {

std::vector<Eigen::Matrix3d> random_deformations(std::size_t count) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::vector<Eigen::Matrix3d> out(count);
  for (auto& F : out) {
    F = Eigen::Matrix3d::Identity();
    for (int k = 0; k < 9; ++k) F(k % 3, k / 3) += u(rng);
  }
  return out;
}

/// SVDs per second on one thread, over a batch larger than L1.
void BM_Svd3(benchmark::State& state) {
  const auto batch = random_deformations(4096);
  for (auto _ : state)
    for (const auto& F : batch) benchmark::DoNotOptimize(goo::svd3(F));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(batch.size()));
}
BENCHMARK(BM_Svd3);

void BM_Svd3Reference(benchmark::State& state) {
  const auto batch = random_deformations(4096);
  for (auto _ : state)
    for (const auto& F : batch) benchmark::DoNotOptimize(goo::svd3_reference(F));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(batch.size()));
}
BENCHMARK(BM_Svd3Reference);

/// One elastic force evaluation (fixed corotated, with SVD) of a deformed box
/// of 6 c³ tets; args: cells per side c, threads. Elements per second.
void BM_ElasticForces(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const auto threads = static_cast<std::size_t>(state.range(1));
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  goo::Material material;
  material.model = goo::ElasticModel::fixed_corotated;
  goo::Body body =
      goo::make_body(goo::make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Constant(cells)), material);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-0.2 / cells, 0.2 / cells);
  goo::Points x = body.rest_positions;
  for (goo::Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) x(n, k) += u(rng);
  goo::ElasticForces forces;
  goo::Points f;
  forces.evaluate(body, x, 0.0, f);  // allocate and touch the buffers once
  for (auto _ : state) {
    forces.evaluate(body, x, 0.0, f);
    benchmark::DoNotOptimize(f.data());
  }
  state.SetItemsProcessed(state.iterations() * body.num_elements());
  state.counters["tets"] = body.num_elements();
  state.counters["threads"] = static_cast<double>(threads);
}
// 6·12³ = 10,368 and 6·26³ = 105,456 tets.
BENCHMARK(BM_ElasticForces)
    ->Args({12, 1})
    ->Args({12, 2})
    ->Args({26, 1})
    ->Args({26, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
