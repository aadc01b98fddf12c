#pragma once
// The 3×3 SVD of core/svd3.h written once for any number of lanes: `Ops`
// supplies the lane type (a double, or a GCC vector of doubles), its mask,
// and sqrt, abs, max, select and any. Every lane performs the same IEEE
// operations in the same order whatever the lane type, so the vectorised
// batch and the scalar svd3 agree bit for bit (tests/core/test_svd3.cpp).
//
// Internal to svd3.cpp, svd3_batch.cpp and the per-instruction-set
// translation units (simd_kernels_*.cpp), with internal linkage only
// (lanes.h says why).
#include "core/lanes.h"

namespace goo::lanes {
namespace {  // NOLINT(cert-dcl59-cpp, google-build-namespaces): see above

constexpr double kEpsilon = 2.220446049250313080847e-16;  // DBL_EPSILON
constexpr double kTiny = 2.2250738585072013830903e-308;   // DBL_MIN

/// One Jacobi rotation zeroing A(p, q) of the symmetric A, accumulated in V
/// (Golub & Van Loan, Matrix Computations, alg. 8.4.1), in the lanes of
/// `rotate` only.
template <class Ops, int p, int q>
inline void jacobi_rotate(Mat3<typename Ops::R>& A, Mat3<typename Ops::R>& V, typename Ops::M rotate) {
  using R = typename Ops::R;
  constexpr int r = 3 - p - q;
  const R apq = A(p, q);
  // t = tan θ = sign(τ) / (|τ| + √(1 + τ²)), τ = d / e, d = a_qq − a_pp,
  // e = 2 a_pq: the smaller root of t² + 2τt − 1 = 0. With h = √(d² + e²),
  // D = |d| + h and z = √(D² + e²) = √(2hD): t = sign(τ) |e| / D,
  // c = 1/√(1 + t²) = D / z, s = t c = sign(τ) |e| / z, all three from the
  // one reciprocal v = 1 / (D z) (t = sign(τ)|e| z v, c = D² v, s =
  // sign(τ)|e| D v): two square roots and a division where the τ form
  // takes three divisions and two roots, each waiting for the last. Every
  // quantity is homogeneous of degree 0 in (d, e): a pair too small to
  // square is scaled up by a power of two first, which changes no bit.
  R d = A(q, q) - A(p, p), e = 2.0 * apq;
  const R up = Ops::select(Ops::max(Ops::abs(d), Ops::abs(e)) < 0x1p-400, Ops::splat(0x1p600), Ops::splat(1.0));
  d = d * up;
  e = e * up;
  const R h = Ops::sqrt(d * d + e * e);
  const R D = Ops::abs(d) + h;
  const R z = Ops::sqrt(2.0 * h * D);
  const R v = 1.0 / (D * z);
  // sign(τ): −1 where d and e have opposite signs, +1 where d = 0 (τ = ±0).
  const R sign = Ops::select(Ops::both(d != 0.0, (d < 0.0) != (e < 0.0)), Ops::splat(-1.0), Ops::splat(1.0));
  const R ae = sign * Ops::abs(e);
  const R t = ae * z * v;
  const R c = D * D * v;
  const R s = ae * D * v;
  const R arp = A(r, p), arq = A(r, q);
  A(p, p) = Ops::select(rotate, A(p, p) - t * apq, A(p, p));
  A(q, q) = Ops::select(rotate, A(q, q) + t * apq, A(q, q));
  A(p, q) = A(q, p) = Ops::select(rotate, Ops::splat(0.0), apq);
  A(r, p) = A(p, r) = Ops::select(rotate, c * arp - s * arq, arp);
  A(r, q) = A(q, r) = Ops::select(rotate, s * arp + c * arq, arq);
  for (int i = 0; i < 3; ++i) {
    const R vip = V(i, p), viq = V(i, q);
    V(i, p) = Ops::select(rotate, c * vip - s * viq, vip);
    V(i, q) = Ops::select(rotate, s * vip + c * viq, viq);
  }
}

/// Whether A(p, q) is still to be rotated away: not negligible next to
/// √(a_pp a_qq) (relative convergence, which keeps small eigenvalues
/// accurate), compared squared (no square roots).
template <class Ops, int p, int q>
inline typename Ops::M off_diagonal_left(const Mat3<typename Ops::R>& A) {
  const auto apq = A(p, q);
  return Ops::both(apq * apq > (kEpsilon * kEpsilon) * Ops::abs(A(p, p) * A(q, q)), apq != 0.0);
}

template <class Ops, int p, int q>
inline bool sweep_pair(Mat3<typename Ops::R>& A, Mat3<typename Ops::R>& V) {
  const typename Ops::M rotate = off_diagonal_left<Ops, p, q>(A);
  if (!Ops::any(rotate)) return false;
  jacobi_rotate<Ops, p, q>(A, V, rotate);
  return true;
}

/// a × b.
template <class R>
inline void cross3(const R a[3], const R b[3], R out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/// F = U diag(σ) Vᵀ for every lane (core/svd3.h's contract): cyclic Jacobi
/// on FᵀF for V and σ², U from F V by Gram–Schmidt, u3 = u1 × u2,
/// σ_i = u_iᵀ F v_i.
template <class Ops>
inline void svd3_lanes(const Mat3<typename Ops::R>& F_in, Mat3<typename Ops::R>& U, typename Ops::R sigma[3],
                       Mat3<typename Ops::R>& V) {
  using R = typename Ops::R;
  // Work on F / 2^k, 2^k the power of two at or below max|F_ij| (at least
  // the least normal double), so that FᵀF neither overflows nor underflows
  // for any finite F: a multiplication by 2^−k, exact; σ is scaled back at
  // the end. A NaN entry makes the lane NaN, an infinite one its finite
  // entries 0, as a division by max|F_ij| did.
  R largest = Ops::abs(F_in.m[0]);
  for (int k = 1; k < 9; ++k) largest = Ops::max(largest, Ops::abs(F_in.m[k]));
  const typename Ops::M nonzero = largest > 0.0;
  const R scale = Ops::max(Ops::binade(largest), Ops::splat(kTiny));
  const R inverse = Ops::select(largest == largest, 1.0 / scale, largest);
  Mat3<R> F;
  for (int k = 0; k < 9; ++k) F.m[k] = F_in.m[k] * inverse;
  Mat3<R> A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A(i, j) = dot3(F(0, i), F(1, i), F(2, i), F(0, j), F(1, j), F(2, j));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) V(i, j) = Ops::splat(i == j ? 1.0 : 0.0);
  // Quadratic convergence: ≤ 5 sweeps in practice; the cap only guards
  // against NaN input. A lane whose sweep rotated nothing is converged: its
  // later sweeps find the same negligible entries and change nothing.
  for (int sweep = 0; sweep < 12; ++sweep) {
    bool rotated = sweep_pair<Ops, 0, 1>(A, V);
    rotated = sweep_pair<Ops, 0, 2>(A, V) || rotated;
    rotated = sweep_pair<Ops, 1, 2>(A, V) || rotated;
    if (!rotated) break;
  }
  // Order the eigenvalues (σ²) descending; each swap flips det V.
  R lambda[3] = {A(0, 0), A(1, 1), A(2, 2)};
  const auto swap = [&](int i, int j) {
    const typename Ops::M m = lambda[i] < lambda[j];
    const R li = lambda[i];
    lambda[i] = Ops::select(m, lambda[j], li);
    lambda[j] = Ops::select(m, li, lambda[j]);
    for (int k = 0; k < 3; ++k) {
      const R vi = V(k, i);
      V(k, i) = Ops::select(m, V(k, j), vi);
      V(k, j) = Ops::select(m, vi, V(k, j));
    }
  };
  swap(0, 1);
  swap(0, 2);
  swap(1, 2);
  // det V by its first row's cofactors.
  const R det = V(0, 0) * (V(1, 1) * V(2, 2) - V(1, 2) * V(2, 1)) - V(0, 1) * (V(1, 0) * V(2, 2) - V(1, 2) * V(2, 0)) +
                V(0, 2) * (V(1, 0) * V(2, 1) - V(1, 1) * V(2, 0));
  const typename Ops::M reflection = det < 0.0;
  for (int k = 0; k < 3; ++k) V(k, 2) = Ops::select(reflection, -V(k, 2), V(k, 2));

  // F V: columns σ_i u_i. The third row sums a0 b0 + (a1 b1 + a2 b2), as
  // Eigen's product of two 3×3 matrices does (svd3 was written with Eigen
  // before it was written for lanes; its results were kept to the bit).
  Mat3<R> B;
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 2; ++i) B(i, j) = dot3(F(i, 0), F(i, 1), F(i, 2), V(0, j), V(1, j), V(2, j));
    B(2, j) = F(2, 0) * V(0, j) + (F(2, 1) * V(1, j) + F(2, 2) * V(2, j));
  }
  R u1[3], u2[3], u3[3];
  const R n1 = Ops::sqrt(dot3(B(0, 0), B(1, 0), B(2, 0), B(0, 0), B(1, 0), B(2, 0)));
  const typename Ops::M u1_defined = n1 > kTiny;
  const R r1 = 1.0 / n1;
  for (int k = 0; k < 3; ++k) u1[k] = Ops::select(u1_defined, B(k, 0) * r1, Ops::splat(k == 0 ? 1.0 : 0.0));
  const R d12 = dot3(u1[0], u1[1], u1[2], B(0, 1), B(1, 1), B(2, 1));
  for (int k = 0; k < 3; ++k) u2[k] = B(k, 1) - d12 * u1[k];
  const R n2 = Ops::sqrt(dot3(u2[0], u2[1], u2[2], u2[0], u2[1], u2[2]));
  const typename Ops::M u2_defined = n2 > kTiny;
  const R r2 = 1.0 / n2;
  if (Ops::all(u2_defined)) {
    for (auto& c : u2) c = c * r2;
  } else {
    // A unit vector orthogonal to u1: u1 × e_k with k the axis of u1's
    // smallest component (the first of equals), normalised.
    const R a[3] = {Ops::abs(u1[0]), Ops::abs(u1[1]), Ops::abs(u1[2])};
    const typename Ops::M second = a[1] < a[0];
    const R smallest = Ops::select(second, a[1], a[0]);
    const typename Ops::M third = a[2] < smallest;
    R e[3];
    e[2] = Ops::select(third, Ops::splat(1.0), Ops::splat(0.0));
    e[1] = Ops::select(third, Ops::splat(0.0), Ops::select(second, Ops::splat(1.0), Ops::splat(0.0)));
    e[0] = Ops::select(third, Ops::splat(0.0), Ops::select(second, Ops::splat(0.0), Ops::splat(1.0)));
    R w[3];
    cross3(u1, e, w);
    const R z = dot3(w[0], w[1], w[2], w[0], w[1], w[2]);
    const R nz = Ops::sqrt(z);
    for (int k = 0; k < 3; ++k) {
      const R orthogonal = Ops::select(z > 0.0, w[k] / nz, w[k]);
      u2[k] = Ops::select(u2_defined, u2[k] * r2, orthogonal);
    }
  }
  cross3(u1, u2, u3);
  for (int k = 0; k < 3; ++k) {
    U(k, 0) = u1[k];
    U(k, 1) = u2[k];
    U(k, 2) = u3[k];
  }
  sigma[0] = dot3(u1[0], u1[1], u1[2], B(0, 0), B(1, 0), B(2, 0));
  sigma[1] = dot3(u2[0], u2[1], u2[2], B(0, 1), B(1, 1), B(2, 1));
  sigma[2] = dot3(u3[0], u3[1], u3[2], B(0, 2), B(1, 2), B(2, 2));
  // The eigenvalue order makes σ1 ≥ σ2 ≥ |σ3| up to round-off; ties can come
  // out an ulp apart in either direction, so make the order exact (a change
  // within the reconstruction error).
  sigma[1] = Ops::max(sigma[1], Ops::abs(sigma[2]));
  sigma[0] = Ops::max(sigma[0], sigma[1]);
  for (int k = 0; k < 3; ++k) sigma[k] = Ops::select(nonzero, sigma[k] * scale, Ops::splat(0.0));
  // F = 0 (and NaN): U = V = I, σ = 0.
  if (!Ops::all(nonzero)) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        U(i, j) = Ops::select(nonzero, U(i, j), Ops::splat(i == j ? 1.0 : 0.0));
        V(i, j) = Ops::select(nonzero, V(i, j), Ops::splat(i == j ? 1.0 : 0.0));
      }
  }
}

}  // namespace
}  // namespace goo::lanes
