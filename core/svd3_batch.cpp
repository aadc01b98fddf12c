#include "core/svd3_batch.h"

#include <cstdlib>
#include <string>

#include "core/svd3_lanes.h"

namespace goo {

namespace lanes {
#if GOO_SIMD_X86
void svd3_batch_sse2(Svd3Batch& batch);
void svd3_batch_avx2(Svd3Batch& batch);
void svd3_batch_avx512(Svd3Batch& batch);
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

SimdLevel widest_supported() {
  for (const SimdLevel level : {SimdLevel::avx512, SimdLevel::avx2, SimdLevel::sse2})
    if (simd_level_supported(level)) return level;
  return SimdLevel::scalar;
}

SimdLevel level_from_environment() {
  SimdLevel level = widest_supported();
  const char* const requested = std::getenv("GOO_SIMD");  // NOLINT(concurrency-mt-unsafe): read once, at first use
  if (requested == nullptr) return level;
  for (const SimdLevel narrower : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512})
    if (simd_level_name(narrower) == requested && static_cast<int>(narrower) < static_cast<int>(level))
      level = narrower;
  return level;
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

void svd3_batch(Svd3Batch& batch, SimdLevel level) {
  switch (level) {
#if GOO_SIMD_X86
    case SimdLevel::sse2:
      lanes::svd3_batch_sse2(batch);
      return;
    case SimdLevel::avx2:
      lanes::svd3_batch_avx2(batch);
      return;
    case SimdLevel::avx512:
      lanes::svd3_batch_avx512(batch);
      return;
#endif
    default:
      lanes::svd3_batch_scalar(batch);
      return;
  }
}

void svd3_batch(Svd3Batch& batch) {
  svd3_batch(batch, active_simd_level());
}

}  // namespace goo
