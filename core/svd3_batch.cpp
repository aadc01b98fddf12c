#include "core/svd3_batch.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "core/damping_lanes.h"
#include "core/error.h"
#include "core/force_lanes.h"
#include "core/simd_kernels.h"
#include "core/svd3_lanes.h"

namespace goo {

namespace lanes {
#if GOO_SIMD_X86
const SimdKernels& kernels_sse2();
const SimdKernels& kernels_avx2();
const SimdKernels& kernels_avx512();
#endif

namespace {

void svd3_batch_scalar(Svd3Batch& batch) {
  for (int lane = 0; lane < kSvdLanes; ++lane) {
    Mat3<double> F, U, V;
    double sigma[3];
    for (int k = 0; k < 9; ++k) F.m[k] = batch.F[k][lane];
    svd3_lanes<ScalarOps>(F, U, sigma, V);
    for (int k = 0; k < 9; ++k) {
      batch.U[k][lane] = U.m[k];
      batch.V[k][lane] = V.m[k];
    }
    for (int k = 0; k < 3; ++k) batch.sigma[k][lane] = sigma[k];
  }
}

void damping_gather_scalar(const DampingSources& sources, int first, int count, DampingLanes& lanes) {
  damping_gather_lanes<ScalarOps>(sources, first, count, lanes);
}

void damping_block_scalar(const DampingBlock& block, DampingLanes& batch) {
  for (int lane = 0; lane < kDampingLanes; ++lane) {
    Mat3<double> G, A;
    double v[4][3], f[4][3];
    for (int k = 0; k < 9; ++k) {
      G.m[k] = block.G[k][lane];
      A.m[k] = block.A[k][lane];
    }
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) v[c][i] = batch.v[c][i][lane];
    damping_lanes<ScalarOps>(G, A, block.scale[lane], v, f);
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) batch.f[c][i][lane] = f[c][i];
  }
}

void damping_diagonal_scalar(const DampingBlock& block, DampingDiagonal& out) {
  for (int lane = 0; lane < kDampingLanes; ++lane) {
    Mat3<double> G, A;
    double d[4][9];
    for (int k = 0; k < 9; ++k) {
      G.m[k] = block.G[k][lane];
      A.m[k] = block.A[k][lane];
    }
    damping_diagonal_lanes<ScalarOps>(G, A, block.scale[lane], d);
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 9; ++k) out.d[c][k][lane] = d[c][k];
  }
}

void force_batch_gather_scalar(const ForceSources& sources, int first, int count, ForceBatch& batch) {
  force_batch_gather_lanes<ScalarOps>(sources, first, count, batch);
}

void force_batch_deform_scalar(ForceBatch& batch) {
  force_batch_deform_lanes<ScalarOps>(batch);
  svd3_batch_scalar(batch.svd);
}

void force_batch_forces_scalar(ForceBatch& batch) {
  force_batch_forces_lanes<ScalarOps>(batch);
}

constexpr SimdKernels kScalarKernels = {svd3_batch_scalar,        damping_gather_scalar,     damping_block_scalar,
                                        damping_diagonal_scalar,  force_batch_gather_scalar, force_batch_deform_scalar,
                                        force_batch_forces_scalar};

SimdLevel widest_supported() {
  for (const SimdLevel level : {SimdLevel::avx512, SimdLevel::avx2, SimdLevel::sse2})
    if (simd_level_supported(level)) return level;
  return SimdLevel::scalar;
}

SimdLevel level_from_environment() {
  const SimdLevel widest = widest_supported();
  const char* const requested = std::getenv("GOO_SIMD");  // NOLINT(concurrency-mt-unsafe): read once, at first use
  if (requested == nullptr || *requested == '\0') return widest;
  for (const SimdLevel named : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512})
    if (simd_level_name(named) == requested) return std::min(named, widest);
  // A misspelt cap would otherwise run at full width unnoticed: a speed
  // comparison would then compare nothing.
  throw Error(fmt::format("environment variable GOO_SIMD: unknown vector width \"{}\" (scalar, sse2, avx2 or avx512)",
                          requested));
}

}  // namespace
}  // namespace lanes

std::string_view simd_level_name(SimdLevel level) {
  switch (level) {
    case SimdLevel::scalar:
      return "scalar";
    case SimdLevel::sse2:
      return "sse2";
    case SimdLevel::avx2:
      return "avx2";
    case SimdLevel::avx512:
      return "avx512";
  }
  return "unknown";
}

bool simd_level_supported(SimdLevel level) {
#if GOO_SIMD_X86
  switch (level) {
    case SimdLevel::scalar:
    case SimdLevel::sse2:
      return true;  // every x86-64 processor
    case SimdLevel::avx2:
      return __builtin_cpu_supports("avx2") != 0;
    case SimdLevel::avx512:
      return __builtin_cpu_supports("avx512f") != 0;
  }
  return false;
#else
  return level == SimdLevel::scalar;
#endif
}

SimdLevel active_simd_level() {
  static const SimdLevel level = lanes::level_from_environment();
  return level;
}

const SimdKernels& simd_kernels(SimdLevel level) {
  switch (level) {
#if GOO_SIMD_X86
    case SimdLevel::sse2:
      return lanes::kernels_sse2();
    case SimdLevel::avx2:
      return lanes::kernels_avx2();
    case SimdLevel::avx512:
      return lanes::kernels_avx512();
#endif
    default:
      return lanes::kScalarKernels;
  }
}

void svd3_batch(Svd3Batch& batch, SimdLevel level) {
  simd_kernels(level).svd3_batch(batch);
}

void damping_gather(const DampingSources& sources, int first, int count, DampingLanes& lanes, SimdLevel level) {
  simd_kernels(level).damping_gather(sources, first, count, lanes);
}

void damping_block(const DampingBlock& block, DampingLanes& lanes, SimdLevel level) {
  simd_kernels(level).damping_block(block, lanes);
}

void damping_diagonal(const DampingBlock& block, DampingDiagonal& out, SimdLevel level) {
  simd_kernels(level).damping_diagonal(block, out);
}

void force_batch_gather(const ForceSources& sources, int first, int count, ForceBatch& batch, SimdLevel level) {
  simd_kernels(level).force_batch_gather(sources, first, count, batch);
}

void force_batch_deform(ForceBatch& batch, SimdLevel level) {
  simd_kernels(level).force_batch_deform(batch);
}

void force_batch_forces(ForceBatch& batch, SimdLevel level) {
  simd_kernels(level).force_batch_forces(batch);
}

void svd3_batch(Svd3Batch& batch) {
  svd3_batch(batch, active_simd_level());
}

}  // namespace goo
