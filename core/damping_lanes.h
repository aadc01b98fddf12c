#pragma once
// One application of the frozen damping operator (core/damping.h) to
// kDampingLanes elements at once, written once for any lane type (lanes.h):
// every lane performs the operations of the element loop Damping::apply ran
// before, in Eigen's order, so each lane gives that loop's bits.
//
// Internal to damping.cpp and the per-instruction-set translation units
// (simd_kernels_*.cpp), with internal linkage only (lanes.h says why).
#include "core/damping_batch.h"
#include "core/lanes.h"

namespace goo::lanes {
namespace {  // NOLINT(cert-dcl59-cpp, google-build-namespaces): see lanes.h

/// damping_gather, Ops::kWidth lanes at a time (a group the count ends in
/// one lane at a time).
template <class Ops>
inline void damping_gather_lanes(const DampingSources& s, int first, int count, DampingLanes& out) {
  using R = typename Ops::R;
  constexpr int width = Ops::kWidth;
  for (int lane = 0; lane < kDampingLanes; lane += width) {
    if (lane + width > count) {
      for (int k = lane; k < lane + width; ++k)
        for (int c = 0; c < 4; ++c) {
          const int node = k < count ? s.tets[4 * (first + k) + c] : 0;
          for (int i = 0; i < 3; ++i) {
            double v = 0.0;
            if (k < count) {
              v = s.v[3 * node + i];
              if (s.p != nullptr) v = v + s.beta * s.p[3 * node + i];
            }
            out.v[c][i][k] = v;
          }
        }
      continue;
    }
    int node[4][sizeof(R) / sizeof(double)];  // width each
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < width; ++k) node[c][k] = s.tets[4 * (first + lane + k) + c];
    for (int c = 0; c < 4; ++c) {
      R v[3];
      Ops::gather_rows3(s.v, node[c], v);
      if (s.p != nullptr) {
        R p[3];
        Ops::gather_rows3(s.p, node[c], p);
        for (int i = 0; i < 3; ++i) v[i] = v[i] + s.beta * p[i];
      }
      for (int i = 0; i < 3; ++i) Ops::store(&out.v[c][i][lane], v[i]);
    }
  }
}

/// The damping forces of one group of lanes: Ḟe = Vs A, S = sym(Feᵀ Ḟe),
/// H = (−2βW det Fp) Fe S Aᵀ; node 0 takes −Σ of H's columns.
template <class Ops>
inline void damping_lanes(const Mat3<typename Ops::R>& G, const Mat3<typename Ops::R>& A, const typename Ops::R& scale,
                          const typename Ops::R v[4][3], typename Ops::R f[4][3]) {
  using R = typename Ops::R;
  Mat3<R> Vs;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i) Vs(i, k) = v[k + 1][i] - v[0][i];
  const Mat3<R> VA = product(Vs, A);
  const Mat3<R> E = transposed_product(G, VA);  // Feᵀ Ḟe
  Mat3<R> S;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) S(i, j) = 0.5 * (E(i, j) + E(j, i));
  // Eigen evaluates (s G S) as (s G) S.
  const R minus_scale = -scale;
  corner_forces(product_transposed(product(scaled(minus_scale, G), S), A), f);
}

/// The corner blocks of one group of lanes (Damping::diagonal_blocks): with
/// w_k = Fp⁻ᵀ ∇N_k, the columns of Aᵀ (w_0 = −Σ), corner k's block is
/// βW det Fp (|w_k|² Fe Feᵀ + (Fe w_k)(Fe w_k)ᵀ), in Eigen's order of that
/// formula (Fe Feᵀ into a local matrix, |w|² as a dot product, the rows of
/// Aᵀ summed as w₁ + (w₂ + w₃)).
template <class Ops>
inline void damping_diagonal_lanes(const Mat3<typename Ops::R>& G, const Mat3<typename Ops::R>& A,
                                   const typename Ops::R& scale, typename Ops::R out[4][9]) {
  using R = typename Ops::R;
  const R half_scale = 0.5 * scale;  // βW det Fp (halving: exact)
  const Mat3<R> GGt = product_transposed(G, G);
  for (int k = 0; k < 4; ++k) {
    R w[3];
    for (int i = 0; i < 3; ++i) w[i] = k == 0 ? -(A(0, i) + (A(1, i) + A(2, i))) : A(k - 1, i);
    R Gw[3];
    for (int i = 0; i < 3; ++i) Gw[i] = eigen_row_sum(i, G(i, 0), G(i, 1), G(i, 2), w[0], w[1], w[2]);
    const R norm2 = dot3(w[0], w[1], w[2], w[0], w[1], w[2]);
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) out[k][i + 3 * j] = half_scale * (norm2 * GGt(i, j) + Gw[i] * Gw[j]);
  }
}

}  // namespace
}  // namespace goo::lanes
