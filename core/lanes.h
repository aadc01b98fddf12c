#pragma once
// What the kernels written for lanes share (svd3_lanes.h, damping_lanes.h):
// a lane type is a double, or a GCC vector of doubles (simd_lanes.h), with
// `Ops` supplying its mask and sqrt, abs, max, select, both, any and all.
// Every lane performs the same IEEE operations in the same order whatever
// the lane type, so a kernel's vector and scalar forms agree bit for bit.
//
// Internal to the kernels' translation units: everything here has internal
// linkage, so that code compiled for AVX-512 is never shared with a
// translation unit that runs on a processor without it. It therefore uses
// no Eigen and no inline function of the standard library.

namespace goo::lanes {
namespace {  // NOLINT(cert-dcl59-cpp, google-build-namespaces): see above

/// A 3×3 matrix of lanes, column-major: m[i + 3 j] is row i, column j.
template <class R>
struct Mat3 {
  R m[9];
  R& operator()(int i, int j) { return m[i + 3 * j]; }
  const R& operator()(int i, int j) const { return m[i + 3 * j]; }
};

/// ((a0 b0 + a1 b1) + a2 b2): the order of the sums in every dot product.
template <class R>
inline R dot3(const R& a0, const R& a1, const R& a2, const R& b0, const R& b1, const R& b2) {
  return (a0 * b0 + a1 * b1) + a2 * b2;
}

/// The products of 3×3 matrices in the order of Eigen's (svd3, the force
/// pass and the damping operator were written with Eigen before they were
/// written for lanes, and their results were kept to the bit): into a
/// local matrix, Eigen sums rows 0 and 1 as (a0 b0 + a1 b1) + a2 b2, two rows
/// at a time in a register, and row 2 as a0 b0 + (a1 b1 + a2 b2).
template <class R>
inline R eigen_row_sum(int row, const R& a0, const R& a1, const R& a2, const R& b0, const R& b1, const R& b2) {
  return row < 2 ? dot3(a0, a1, a2, b0, b1, b2) : a0 * b0 + (a1 * b1 + a2 * b2);
}

/// X Y.
template <class R>
inline Mat3<R> product(const Mat3<R>& X, const Mat3<R>& Y) {
  Mat3<R> out;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) out(i, j) = eigen_row_sum(i, X(i, 0), X(i, 1), X(i, 2), Y(0, j), Y(1, j), Y(2, j));
  return out;
}

/// Xᵀ Y (every entry a dot product of two columns).
template <class R>
inline Mat3<R> transposed_product(const Mat3<R>& X, const Mat3<R>& Y) {
  Mat3<R> out;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) out(i, j) = dot3(X(0, i), X(1, i), X(2, i), Y(0, j), Y(1, j), Y(2, j));
  return out;
}

/// X Yᵀ as Eigen computes it into a matrix kept in a std::vector, whose
/// alignment it does not know: every entry a0 b0 + (a1 b1 + a2 b2).
template <class R>
inline Mat3<R> product_transposed_into_memory(const Mat3<R>& X, const Mat3<R>& Y) {
  Mat3<R> out;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) out(i, j) = X(i, 0) * Y(j, 0) + (X(i, 1) * Y(j, 1) + X(i, 2) * Y(j, 2));
  return out;
}

/// X Yᵀ.
template <class R>
inline Mat3<R> product_transposed(const Mat3<R>& X, const Mat3<R>& Y) {
  Mat3<R> out;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) out(i, j) = eigen_row_sum(i, X(i, 0), X(i, 1), X(i, 2), Y(j, 0), Y(j, 1), Y(j, 2));
  return out;
}

/// s X, entry by entry.
template <class R>
inline Mat3<R> scaled(const R& s, const Mat3<R>& X) {
  Mat3<R> out;
  for (int k = 0; k < 9; ++k) out.m[k] = s * X.m[k];
  return out;
}

/// An element's corner forces from H (W&T eq. 2, Eigen's sum order):
/// corners 1–3 take H's columns, corner 0 minus their sum.
template <class R>
inline void corner_forces(const Mat3<R>& H, R f[4][3]) {
  for (int i = 0; i < 3; ++i) {
    f[0][i] = -(H(i, 0) + (H(i, 1) + H(i, 2)));
    for (int k = 0; k < 3; ++k) f[k + 1][i] = H(i, k);
  }
}

/// The lane type `double`.
struct ScalarOps {
  using R = double;
  using M = bool;
  static constexpr int kWidth = 1;
  static double load(const double* p) { return *p; }
  /// base[index[0]] (the lanes' gather).
  static double gather(const double* base, const int* index) { return base[index[0]]; }
  /// out[i] = base[3 row[0] + i] (the lanes' gather of rows of three).
  static void gather_rows3(const double* base, const int* row, double out[3]) {
    for (int i = 0; i < 3; ++i) out[i] = base[3 * row[0] + i];
  }
  static void store(double* p, double x) { *p = x; }
  static double splat(double x) { return x; }
  static double sqrt(double x) { return __builtin_sqrt(x); }
  static double abs(double x) { return __builtin_fabs(x); }
  /// std::max's choice: b only where a < b.
  static double max(double a, double b) { return a < b ? b : a; }
  static double select(bool m, double a, double b) { return m ? a : b; }
  static bool both(bool a, bool b) { return a && b; }
  static bool any(bool m) { return m; }
  static bool all(bool m) { return m; }
  /// x with its significand's bits cleared: the power of two ≤ |x| for a
  /// normal x (0 for a subnormal, ∞ for ∞ and NaN).
  static double binade(double x) {
    return __builtin_bit_cast(
        double, __builtin_bit_cast(unsigned long long, x) & 0x7ff0000000000000ULL);  // NOLINT(google-runtime-int)
  }
};

}  // namespace
}  // namespace goo::lanes
