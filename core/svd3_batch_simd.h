#pragma once
// The vector lanes of svd3_lanes.h as GCC vectors of one register's doubles, for
// the instruction set the including translation unit is compiled for
// (svd3_batch_sse2.cpp, svd3_batch_avx2.cpp, svd3_batch_avx512.cpp). Like
// svd3_lanes.h, internal linkage only.
#include <immintrin.h>

#include "core/svd3_batch.h"
#include "core/svd3_lanes.h"

namespace goo::svd3_detail {
namespace {  // NOLINT(cert-dcl59-cpp, google-build-namespaces): see svd3_lanes.h

/// Doubles per register of the instruction set: GCC splits a wider vector
/// into pieces through memory, which would forfeit most of the gain.
#if defined(__AVX512F__)
constexpr int kWidth = 8;
#elif defined(__AVX__)
constexpr int kWidth = 4;
#else
constexpr int kWidth = 2;
#endif
static_assert(kSvdLanes % kWidth == 0);

using Lanes = double __attribute__((vector_size(8 * kWidth)));
using LaneMask = long long __attribute__((vector_size(8 * kWidth)));  // NOLINT(google-runtime-int)

struct VectorOps {
  using R = Lanes;
  using M = LaneMask;
  static R splat(double x) { return R{} + x; }
  static R sqrt(R x) {
#if defined(__AVX512F__)
    // The all-lanes mask of the zeroing form: GCC 12's _mm512_sqrt_pd warns
    // of its own undefined pass-through operand.
    return reinterpret_cast<R>(_mm512_maskz_sqrt_pd(0xff, reinterpret_cast<__m512d>(x)));
#elif defined(__AVX__)
    return reinterpret_cast<R>(_mm256_sqrt_pd(reinterpret_cast<__m256d>(x)));
#else
    return reinterpret_cast<R>(_mm_sqrt_pd(reinterpret_cast<__m128d>(x)));
#endif
  }
  /// Clears the sign bit, as fabs does.
  static R abs(R x) {
    return reinterpret_cast<R>(reinterpret_cast<M>(x) & (M{} + 0x7fffffffffffffffLL));
  }
  static R max(R a, R b) {
    return a < b ? b : a;
  }
  static R select(M m, R a, R b) {
    return m ? a : b;
  }
  static M both(M a, M b) {
    return a & b;
  }
  static bool any(M m) {
    long long bits = 0;  // NOLINT(google-runtime-int)
    for (int k = 0; k < kWidth; ++k) bits |= m[k];
    return bits != 0;
  }
  static bool all(M m) {
    long long bits = -1;  // NOLINT(google-runtime-int)
    for (int k = 0; k < kWidth; ++k) bits &= m[k];
    return bits != 0;
  }
};

/// The batch kWidth lanes at a time.
inline void svd3_batch_vector(Svd3Batch& batch) {
  constexpr auto bytes = sizeof(Lanes);
  for (int first = 0; first < kSvdLanes; first += kWidth) {
    Mat3<Lanes> F, U, V;
    Lanes sigma[3];
    for (int k = 0; k < 9; ++k) __builtin_memcpy(&F.m[k], &batch.F[k][first], bytes);
    svd3_lanes<VectorOps>(F, U, sigma, V);
    for (int k = 0; k < 9; ++k) {
      __builtin_memcpy(&batch.U[k][first], &U.m[k], bytes);
      __builtin_memcpy(&batch.V[k][first], &V.m[k], bytes);
    }
    for (int k = 0; k < 3; ++k) __builtin_memcpy(&batch.sigma[k][first], &sigma[k], bytes);
  }
}

}  // namespace
}  // namespace goo::svd3_detail
