// The finite-element kernels: the SVD, the elastic force pass, the damping
// operator and the incompressibility projection.
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <chrono>
#include <random>

#include "core/body.h"
#include "core/damping.h"
#include "core/elastic_forces.h"
#include "core/parallel.h"
#include "core/svd3.h"
#include "core/svd3_batch.h"
#include "core/volume_projection.h"

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

/// The same SVDs kSvdLanes at a time at one instruction-set level (arg:
/// goo::SimdLevel, 0 scalar, 1 SSE2, 2 AVX2, 3 AVX-512), the batches filled
/// and emptied as the force kernel does. SVDs per second on one thread.
void BM_Svd3Batch(benchmark::State& state) {
  const auto level = static_cast<goo::SimdLevel>(state.range(0));
  if (!goo::simd_level_supported(level)) {
    state.SkipWithError("this processor lacks the instruction set");
    return;
  }
  state.SetLabel(std::string(goo::simd_level_name(level)));
  const auto batch = random_deformations(4096);
  goo::Svd3Batch lanes{};
  for (auto _ : state)
    for (std::size_t first = 0; first < batch.size(); first += goo::kSvdLanes) {
      for (int lane = 0; lane < goo::kSvdLanes; ++lane)
        for (int k = 0; k < 9; ++k) lanes.F[k][lane] = batch[first + static_cast<std::size_t>(lane)].data()[k];
      goo::svd3_batch(lanes, level);
      benchmark::DoNotOptimize(lanes.sigma[0][0]);
    }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(batch.size()));
}
BENCHMARK(BM_Svd3Batch)->DenseRange(0, 3);

/// One elastic force evaluation (fixed corotated, with SVD) of a deformed box
/// of 6 c³ tets; args: cells per side c, threads. Elements per second. The
/// evaluation writes what the damping freezes too (since session 42: the
/// integrator's whole force stage, the freeze a reference to it).
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

/// A box of 6 c³ tets (c cells per side) whose nodes moved at random by up
/// to `amplitude` of a cell.
goo::Body moved_box(int cells, double amplitude, bool incompressible) {
  goo::Material material;
  material.model = goo::ElasticModel::fixed_corotated;
  material.incompressible = incompressible;
  material.viscosity = 100.0;
  goo::Body body =
      goo::make_body(goo::make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Constant(cells)), material);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-amplitude / cells, amplitude / cells);
  for (goo::Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) body.positions(n, k) += u(rng);
  return body;
}

/// A moved box's damping operator frozen as a force evaluation leaves it
/// (Fe and Fp⁻¹ of that evaluation; the operator reads them in place).
struct FrozenDamping {
  goo::Body body;
  goo::ElasticForces forces;
  goo::Damping damping;
  explicit FrozenDamping(int cells) : body(moved_box(cells, 0.2, false)) {
    goo::Points f;
    forces.evaluate(body, body.positions, 0.0, f);
    damping.freeze(body, forces);
  }
  FrozenDamping(const FrozenDamping&) = delete;
  FrozenDamping& operator=(const FrozenDamping&) = delete;
};

/// One application of the damping operator (−C v, Newmark's damping solves
/// apply it once per CG iteration) to random velocities; args: cells per
/// side, threads. Elements per second.
void BM_DampingApply(benchmark::State& state) {
  const auto threads = static_cast<std::size_t>(state.range(1));
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  FrozenDamping frozen(static_cast<int>(state.range(0)));
  const goo::Body& body = frozen.body;
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const goo::Points v = goo::Points::NullaryExpr(body.num_nodes(), 3, [&] { return u(rng); });
  goo::Points out;
  frozen.damping.apply(body, v, out);
  for (auto _ : state) {
    frozen.damping.apply(body, v, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * body.num_elements());
  state.counters["tets"] = body.num_elements();
  state.counters["threads"] = static_cast<double>(threads);
}
BENCHMARK(BM_DampingApply)->Args({12, 1})->Args({12, 2})->Args({26, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

/// Newmark's block-Jacobi preconditioner: the 3×3 diagonal blocks of the
/// damping operator C at every node, taken once per force evaluation; args:
/// cells per side, threads. Elements per second.
void BM_DampingDiagonalBlocks(benchmark::State& state) {
  const auto threads = static_cast<std::size_t>(state.range(1));
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  FrozenDamping frozen(static_cast<int>(state.range(0)));
  std::vector<Eigen::Matrix3d> blocks;
  frozen.damping.diagonal_blocks(frozen.body, blocks);
  for (auto _ : state) {
    frozen.damping.diagonal_blocks(frozen.body, blocks);
    benchmark::DoNotOptimize(blocks.data());
  }
  state.SetItemsProcessed(state.iterations() * frozen.body.num_elements());
  state.counters["tets"] = frozen.body.num_elements();
  state.counters["threads"] = static_cast<double>(threads);
}
BENCHMARK(BM_DampingDiagonalBlocks)->Args({14, 1})->Args({14, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

/// The incompressibility projection as a Newmark step uses it: the velocity
/// projection at a step's end, then the next step's position projection
/// from there (its nodes off by up to 2% of a cell); args: cells per side,
/// threads. Reports the conjugate-gradient iterations of the pair.
void BM_VolumeProjection(benchmark::State& state) {
  const int cells = static_cast<int>(state.range(0));
  const auto threads = static_cast<std::size_t>(state.range(1));
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  goo::Body start = moved_box(cells, 0.0, true);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (goo::Index n = 0; n < start.num_nodes(); ++n) start.velocities.row(n) << u(rng), u(rng), u(rng);
  const double dt = 1e-3;
  goo::Points offsets(start.num_nodes(), 3);
  for (goo::Index n = 0; n < start.num_nodes(); ++n) offsets.row(n) << u(rng), u(rng), u(rng);
  offsets *= 0.02 / cells;
  goo::VolumeProjection projection;
  int iterations = 0;
  for (auto _ : state) {
    goo::Body body = start;
    goo::Points forces = goo::Points::Zero(body.num_nodes(), 3);
    iterations = projection.project_velocities(body, {}, dt, 0.5 * dt, forces).cg_iterations;
    const goo::Points x = body.positions;
    body.positions = x + dt * body.velocities + offsets;
    iterations += projection.project(body, x, {}, dt, 0.5 * dt).cg_iterations;
    benchmark::DoNotOptimize(body.positions.data());
  }
  state.counters["tets"] = start.num_elements();
  state.counters["cg_iterations"] = iterations;
  state.counters["threads"] = static_cast<double>(threads);
}
BENCHMARK(BM_VolumeProjection)
    ->Args({12, 1})
    ->Args({12, 2})
    ->Args({20, 1})
    ->Args({20, 2})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// A pass of the projection's size (per element of a 12-cell box, 10,368
/// tets: the sum of its four nodes' values) right after `gap` µs of serial
/// work on the calling thread; only the pass is timed. args: gap (µs),
/// threads. A worker left idle for more than about 200 µs sleeps, and
/// waking it costs more than such a pass: after a longer serial stretch
/// the pass runs slower on two threads than on one (docs/benchmarks.md,
/// session 34).
void BM_LoopAfterSerialGap(benchmark::State& state) {
  const auto gap = std::chrono::microseconds(state.range(0));
  const auto threads = static_cast<std::size_t>(state.range(1));
  const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
  const goo::Body body = moved_box(12, 0.0, true);
  const Eigen::VectorXd values = Eigen::VectorXd::LinSpaced(body.num_nodes(), 0.0, 1.0);
  Eigen::VectorXd sums(body.num_elements());
  auto pass = [&] {
    goo::for_each_index(body.num_elements(), [&](goo::Index e) {
      double s = 0.0;
      for (int k = 0; k < 4; ++k) s += values[body.tets(e, k)];
      sums[e] = 0.25 * s;
    });
  };
  for (int k = 0; k < 10; ++k) pass();
  for (auto _ : state) {
    const auto until = std::chrono::steady_clock::now() + gap;
    while (std::chrono::steady_clock::now() < until) benchmark::DoNotOptimize(sums.data());
    const auto start = std::chrono::steady_clock::now();
    pass();
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    benchmark::DoNotOptimize(sums.data());
  }
  state.counters["tets"] = static_cast<double>(body.num_elements());
  state.counters["threads"] = static_cast<double>(threads);
}
BENCHMARK(BM_LoopAfterSerialGap)
    ->ArgsProduct({{0, 100, 300, 1000}, {1, 2}})
    ->Iterations(1000)  // the gaps are not timed: a count set from the passes' time alone would take minutes
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond);

}  // namespace
