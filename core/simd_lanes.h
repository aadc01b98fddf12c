#pragma once
// The lanes of lanes.h as GCC vectors of one register's doubles, for the
// instruction set the including translation unit is compiled for
// (simd_kernels_sse2.cpp, simd_kernels_avx2.cpp, simd_kernels_avx512.cpp),
// and the kernels' batches run through them. Internal linkage only
// (lanes.h says why).
#include <immintrin.h>

#include "core/damping_lanes.h"
#include "core/force_lanes.h"
#include "core/simd_kernels.h"
#include "core/svd3_batch.h"
#include "core/svd3_lanes.h"

namespace goo::lanes {
namespace {  // NOLINT(cert-dcl59-cpp, google-build-namespaces): see lanes.h

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
using LaneMask = decltype(Lanes{} < Lanes{});  // what a comparison of lanes gives

struct VectorOps {
  using R = Lanes;
  using M = LaneMask;
  static constexpr int kWidth = goo::lanes::kWidth;
  static R load(const double* p) {
    R out;
    __builtin_memcpy(&out, p, sizeof(R));
    return out;
  }
  static void store(double* p, R x) { __builtin_memcpy(p, &x, sizeof(R)); }
  /// Lane k: base[index[k]]. (The masked forms with every lane on and a
  /// zero pass-through: GCC 12's unmasked ones warn of their own undefined
  /// operand.)
  static R gather(const double* base, const int* index) {
#if defined(__AVX512F__)
    const __m256i lanes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(index));
    return reinterpret_cast<R>(_mm512_mask_i32gather_pd(_mm512_setzero_pd(), 0xff, lanes, base, 8));
#elif defined(__AVX2__)
    const __m128i lanes = _mm_loadu_si128(reinterpret_cast<const __m128i*>(index));
    const __m256d all = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    return reinterpret_cast<R>(_mm256_mask_i32gather_pd(_mm256_setzero_pd(), base, lanes, all, 8));
#else
    R out;
    for (int k = 0; k < kWidth; ++k) out[k] = base[index[k]];
    return out;
#endif
  }
  /// Lane k of out[i]: base[3 row[k] + i], the rows of a #N×3 row-major
  /// array. With AVX2 and no AVX-512, each row's three entries are read by
  /// one masked load (the fourth neither read nor able to fault) and the
  /// four rows transposed in registers: a gather instruction reads one entry
  /// a lane, and Zen 3 issues the 24 gathers of four elements' next
  /// direction in a damping solve at about one per nine cycles
  /// (docs/benchmarks.md, session 45). The same values either way.
  static void gather_rows3(const double* base, const int* row, R out[3]) {
#if defined(__AVX2__) && !defined(__AVX512F__)
    const __m256i first_three = _mm256_set_epi64x(0, -1, -1, -1);
    const __m256d r0 = _mm256_maskload_pd(base + 3 * row[0], first_three);  // x0 y0 z0 0
    const __m256d r1 = _mm256_maskload_pd(base + 3 * row[1], first_three);
    const __m256d r2 = _mm256_maskload_pd(base + 3 * row[2], first_three);
    const __m256d r3 = _mm256_maskload_pd(base + 3 * row[3], first_three);
    const __m256d xz01 = _mm256_unpacklo_pd(r0, r1);  // x0 x1 z0 z1
    const __m256d y01 = _mm256_unpackhi_pd(r0, r1);   // y0 y1 0 0
    const __m256d xz23 = _mm256_unpacklo_pd(r2, r3);
    const __m256d y23 = _mm256_unpackhi_pd(r2, r3);
    out[0] = reinterpret_cast<R>(_mm256_permute2f128_pd(xz01, xz23, 0x20));
    out[1] = reinterpret_cast<R>(_mm256_permute2f128_pd(y01, y23, 0x20));
    out[2] = reinterpret_cast<R>(_mm256_permute2f128_pd(xz01, xz23, 0x31));
#else
    int index[kWidth];
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < kWidth; ++k) index[k] = 3 * row[k] + i;
      out[i] = gather(base, index);
    }
#endif
  }
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
  /// ScalarOps::binade in every lane.
  static R binade(R x) {
    return reinterpret_cast<R>(reinterpret_cast<M>(x) & (M{} + 0x7ff0000000000000LL));
  }
};

/// Two lane types as one: every operation is issued for both halves, two
/// independent chains the processor overlaps. The SVD's Jacobi rotations
/// are a chain of divisions and square roots, each waiting for the last:
/// one register's chain left the dividers idle most of the time. (A GCC
/// vector two registers wide is split through memory.)
template <class L>
struct Two {
  L lo, hi;
};
template <class L> inline Two<L> operator+(Two<L> a, Two<L> b) { return {a.lo + b.lo, a.hi + b.hi}; }
template <class L> inline Two<L> operator-(Two<L> a, Two<L> b) { return {a.lo - b.lo, a.hi - b.hi}; }
template <class L> inline Two<L> operator*(Two<L> a, Two<L> b) { return {a.lo * b.lo, a.hi * b.hi}; }
template <class L> inline Two<L> operator/(Two<L> a, Two<L> b) { return {a.lo / b.lo, a.hi / b.hi}; }
template <class L> inline Two<L> operator-(Two<L> a) { return {-a.lo, -a.hi}; }
template <class L> inline Two<L> operator+(double a, Two<L> b) { return {a + b.lo, a + b.hi}; }
template <class L> inline Two<L> operator*(double a, Two<L> b) { return {a * b.lo, a * b.hi}; }
template <class L> inline Two<L> operator/(double a, Two<L> b) { return {a / b.lo, a / b.hi}; }
template <class L> inline Two<L> operator+(Two<L> a, double b) { return {a.lo + b, a.hi + b}; }
template <class L> inline Two<L> operator*(Two<L> a, double b) { return {a.lo * b, a.hi * b}; }
template <class L> inline Two<L> operator/(Two<L> a, double b) { return {a.lo / b, a.hi / b}; }
template <class L> inline Two<L> operator&(Two<L> a, Two<L> b) { return {a.lo & b.lo, a.hi & b.hi}; }
template <class L> inline Two<L> operator|(Two<L> a, Two<L> b) { return {a.lo | b.lo, a.hi | b.hi}; }
template <class L> inline auto operator<(Two<L> a, Two<L> b) { return Two<decltype(a.lo < b.lo)>{a.lo < b.lo, a.hi < b.hi}; }
template <class L> inline auto operator>(Two<L> a, Two<L> b) { return Two<decltype(a.lo > b.lo)>{a.lo > b.lo, a.hi > b.hi}; }
template <class L> inline auto operator<(Two<L> a, double b) { return Two<decltype(a.lo < b)>{a.lo < b, a.hi < b}; }
template <class L> inline auto operator>(Two<L> a, double b) { return Two<decltype(a.lo > b)>{a.lo > b, a.hi > b}; }
template <class L> inline auto operator>=(Two<L> a, double b) { return Two<decltype(a.lo >= b)>{a.lo >= b, a.hi >= b}; }
template <class L> inline auto operator!=(Two<L> a, double b) { return Two<decltype(a.lo != b)>{a.lo != b, a.hi != b}; }
template <class L>
inline auto operator!=(Two<L> a, Two<L> b) {
  return Two<decltype(a.lo != b.lo)>{a.lo != b.lo, a.hi != b.hi};
}
template <class L>
inline auto operator==(Two<L> a, Two<L> b) {
  return Two<decltype(a.lo == b.lo)>{a.lo == b.lo, a.hi == b.hi};
}

/// The lane operations of Ops on Two of its lane types.
template <class Ops>
struct TwoOps {
  using R = Two<typename Ops::R>;
  using M = decltype(R{} < R{});  // Two of the halves' comparison results
  static constexpr int kWidth = 2 * Ops::kWidth;
  static R splat(double x) { return {Ops::splat(x), Ops::splat(x)}; }
  static R sqrt(R x) { return {Ops::sqrt(x.lo), Ops::sqrt(x.hi)}; }
  static R abs(R x) { return {Ops::abs(x.lo), Ops::abs(x.hi)}; }
  static R max(R a, R b) { return {Ops::max(a.lo, b.lo), Ops::max(a.hi, b.hi)}; }
  static R select(M m, R a, R b) { return {Ops::select(m.lo, a.lo, b.lo), Ops::select(m.hi, a.hi, b.hi)}; }
  static M both(M a, M b) { return a & b; }
  static bool any(M m) { return Ops::any(m.lo) || Ops::any(m.hi); }
  static bool all(M m) { return Ops::all(m.lo) && Ops::all(m.hi); }
  static R binade(R x) { return {Ops::binade(x.lo), Ops::binade(x.hi)}; }
};

using SvdOps = TwoOps<VectorOps>;  // (four registers measured slower: AVX2 spills)
using SvdLanes = SvdOps::R;

/// The batch SvdOps::kWidth lanes at a time.
inline void svd3_batch_vector(Svd3Batch& batch) {
  constexpr int width = SvdOps::kWidth;
  static_assert(kSvdLanes % width == 0 && sizeof(SvdLanes) == sizeof(double) * width);
  for (int first = 0; first < kSvdLanes; first += width) {
    Mat3<SvdLanes> F, U, V;
    SvdLanes sigma[3];
    for (int k = 0; k < 9; ++k) __builtin_memcpy(&F.m[k], &batch.F[k][first], sizeof(SvdLanes));
    svd3_lanes<SvdOps>(F, U, sigma, V);
    for (int k = 0; k < 9; ++k) {
      __builtin_memcpy(&batch.U[k][first], &U.m[k], sizeof(SvdLanes));
      __builtin_memcpy(&batch.V[k][first], &V.m[k], sizeof(SvdLanes));
    }
    for (int k = 0; k < 3; ++k) __builtin_memcpy(&batch.sigma[k][first], &sigma[k], sizeof(SvdLanes));
  }
}

inline void damping_gather_vector(const DampingSources& sources, int first, int count, DampingLanes& lanes) {
  damping_gather_lanes<VectorOps>(sources, first, count, lanes);
}

/// A frozen damping block's G, A and scale at lanes [first, first + kWidth).
inline void load_damping_block(const DampingBlock& block, int first, Mat3<Lanes>& G, Mat3<Lanes>& A, Lanes& scale) {
  for (int k = 0; k < 9; ++k) {
    G.m[k] = VectorOps::load(&block.G[k][first]);
    A.m[k] = VectorOps::load(&block.A[k][first]);
  }
  scale = VectorOps::load(&block.scale[first]);
}

/// The damping block kWidth lanes at a time. The block and the lanes are read
/// and written with whole-register loads and stores: copied into local
/// registers by memcpy, GCC spilled them through the stack in halves, and each
/// register read back from two half-width stores waited for the store
/// forwarding to fail (about 40% of the block's samples on an AMD Zen 3;
/// docs/benchmarks.md, session 45).
inline void damping_block_vector(const DampingBlock& block, DampingLanes& lanes) {
  static_assert(kDampingLanes % kWidth == 0);
  for (int first = 0; first < kDampingLanes; first += kWidth) {
    Mat3<Lanes> G, A;
    Lanes scale, v[4][3], f[4][3];
    load_damping_block(block, first, G, A, scale);
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) v[c][i] = VectorOps::load(&lanes.v[c][i][first]);
    damping_lanes<VectorOps>(G, A, scale, v, f);
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) VectorOps::store(&lanes.f[c][i][first], f[c][i]);
  }
}

/// The damping block's corner blocks kWidth lanes at a time (read and
/// written as damping_block_vector does).
inline void damping_diagonal_vector(const DampingBlock& block, DampingDiagonal& out) {
  for (int first = 0; first < kDampingLanes; first += kWidth) {
    Mat3<Lanes> G, A;
    Lanes scale, d[4][9];
    load_damping_block(block, first, G, A, scale);
    damping_diagonal_lanes<VectorOps>(G, A, scale, d);
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < 9; ++k) VectorOps::store(&out.d[c][k][first], d[c][k]);
  }
}

inline void force_batch_gather_vector(const ForceSources& sources, int first, int count, ForceBatch& batch) {
  force_batch_gather_lanes<VectorOps>(sources, first, count, batch);
}

inline void force_batch_deform_vector(ForceBatch& batch) {
  force_batch_deform_lanes<VectorOps>(batch);
  svd3_batch_vector(batch.svd);
}

inline void force_batch_forces_vector(ForceBatch& batch) {
  force_batch_forces_lanes<VectorOps>(batch);
}

/// The kernels of the including translation unit's instruction set.
constexpr SimdKernels kVectorKernels = {svd3_batch_vector,        damping_gather_vector,     damping_block_vector,
                                        damping_diagonal_vector,  force_batch_gather_vector, force_batch_deform_vector,
                                        force_batch_forces_vector};

}  // namespace
}  // namespace goo::lanes
