#pragma once
// The elastic force pass's arithmetic for any lane type (lanes.h), in the
// order of the one-element code it replaced (Eigen's), so each lane gives
// that code's bits (tests/core/test_elastic_forces.cpp).
//
// Internal to elastic_forces.cpp and the per-instruction-set translation
// units (simd_kernels_*.cpp), with internal linkage only (lanes.h says why).
#include "core/force_batch.h"
#include "core/lanes.h"

namespace goo::lanes {
namespace {  // NOLINT(cert-dcl59-cpp, google-build-namespaces): see lanes.h

/// Cofactor (i, j) of M with the cyclic indices that carry its sign.
template <class R>
inline R cyclic_cofactor(const Mat3<R>& M, int i, int j) {
  const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
  return M(i1, j1) * M(i2, j2) - M(i1, j2) * M(i2, j1);
}

/// M⁻¹ by cofactors over the determinant along the first column.
template <class R>
inline Mat3<R> inverse(const Mat3<R>& M) {
  const R c0 = cyclic_cofactor(M, 0, 0), c1 = cyclic_cofactor(M, 1, 0), c2 = cyclic_cofactor(M, 2, 0);
  const R inverse_det = 1.0 / dot3(c0, c1, c2, M(0, 0), M(1, 0), M(2, 0));
  Mat3<R> out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out(j, i) = cyclic_cofactor(M, i, j) * inverse_det;
  return out;
}

/// Fe = Ds Dm⁻¹ Fp⁻¹ (Ds the edges from corner 0), and Fp⁻¹.
template <class R>
inline void elastic_deformation(const R x[4][3], const Mat3<R>& Dm_inv, const Mat3<R>& Fp, Mat3<R>& Fp_inv,
                                Mat3<R>& Fe) {
  Fp_inv = inverse(Fp);
  Mat3<R> Ds;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 3; ++i) Ds(i, k) = x[k + 1][i] - x[0][i];
  Fe = product(product(Ds, Dm_inv), Fp_inv);
}

/// U diag(d), whose product with Vᵀ is U diag(d) Vᵀ.
template <class R>
inline Mat3<R> scaled_columns(const Mat3<R>& U, const R d[3]) {
  Mat3<R> Ud;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) Ud(i, j) = U(i, j) * d[j];
  return Ud;
}

/// H = ((−W det Fp) P) Fp⁻ᵀ Dm⁻ᵀ, P = U diag(∂ψ/∂σ) Vᵀ (Irving et al. 2004,
/// eq. 2); corner 0 takes minus the sum of H's columns. And Fe = U Σ Vᵀ.
template <class R>
inline void element_forces(const Mat3<R>& U, const R sigma[3], const Mat3<R>& V, const R dpsi[3], const Mat3<R>& Fp_inv,
                           const Mat3<R>& Dm_inv, const R& volume, R f[4][3], Mat3<R>& Fe) {
  const Mat3<R> P = product_transposed(scaled_columns(U, dpsi), V);
  const R minus_volume = -volume;
  corner_forces(product_transposed(product_transposed(scaled(minus_volume, P), Fp_inv), Dm_inv), f);
  Fe = product_transposed_into_memory(scaled_columns(U, sigma), V);  // kept per element
}

/// force_batch_deform's arithmetic, Ops::kWidth lanes at a time (the SVD is
/// the caller's).
template <class Ops>
inline void force_batch_deform_lanes(ForceBatch& b) {
  using R = typename Ops::R;
  for (int first = 0; first < kSvdLanes; first += Ops::kWidth) {
    R x[4][3];
    Mat3<R> Dm_inv, Fp, Fp_inv, Fe;
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) x[c][i] = Ops::load(&b.x[c][i][first]);
    for (int k = 0; k < 9; ++k) {
      Dm_inv.m[k] = Ops::load(&b.Dm_inv[k][first]);
      Fp.m[k] = Ops::load(&b.Fp[k][first]);
    }
    elastic_deformation(x, Dm_inv, Fp, Fp_inv, Fe);
    for (int k = 0; k < 9; ++k) {
      Ops::store(&b.Fp_inv[k][first], Fp_inv.m[k]);
      Ops::store(&b.svd.F[k][first], Fe.m[k]);
    }
  }
}

/// force_batch_forces, Ops::kWidth lanes at a time.
template <class Ops>
inline void force_batch_forces_lanes(ForceBatch& b) {
  using R = typename Ops::R;
  for (int first = 0; first < kSvdLanes; first += Ops::kWidth) {
    Mat3<R> U, V, Fp_inv, Dm_inv, Fe;
    R sigma[3], dpsi[3], f[4][3];
    for (int k = 0; k < 9; ++k) {
      U.m[k] = Ops::load(&b.svd.U[k][first]);
      V.m[k] = Ops::load(&b.svd.V[k][first]);
      Fp_inv.m[k] = Ops::load(&b.Fp_inv[k][first]);
      Dm_inv.m[k] = Ops::load(&b.Dm_inv[k][first]);
    }
    for (int k = 0; k < 3; ++k) {
      sigma[k] = Ops::load(&b.svd.sigma[k][first]);
      dpsi[k] = Ops::load(&b.dpsi[k][first]);
    }
    element_forces(U, sigma, V, dpsi, Fp_inv, Dm_inv, Ops::load(&b.volume[first]), f, Fe);
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) Ops::store(&b.f[c][i][first], f[c][i]);
    for (int k = 0; k < 9; ++k) Ops::store(&b.Fe[k][first], Fe.m[k]);
  }
}

}  // namespace
}  // namespace goo::lanes
