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

/// One lane of force_batch_gather: element e's, or (e < 0) the unit
/// tetrahedron at rest, of no volume.
inline void force_gather_lane(const ForceSources& s, int e, ForceBatch& b, int lane) {
  if (e < 0) {
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) b.x[c][i][lane] = c == i + 1 ? 1.0 : 0.0;
    for (int k = 0; k < 9; ++k) b.Dm_inv[k][lane] = b.Fp[k][lane] = k % 4 == 0 ? 1.0 : 0.0;
    for (int k = 0; k < 3; ++k) b.dpsi[k][lane] = 0.0;
    b.rest_volume[lane] = 0.0;
    b.least_mass[lane] = 1.0;
    return;
  }
  double least = s.masses[s.tets[4 * e]];
  for (int c = 0; c < 4; ++c) {
    const int node = s.tets[4 * e + c];
    for (int i = 0; i < 3; ++i) b.x[c][i][lane] = s.x[3 * node + i];
    if (s.masses[node] < least) least = s.masses[node];  // std::min's choice
  }
  for (int k = 0; k < 9; ++k) {
    b.Dm_inv[k][lane] = s.Dm_inv[9 * e + k];
    b.Fp[k][lane] = s.Fp[9 * e + k];
  }
  b.rest_volume[lane] = s.rest_volumes[e];
  b.least_mass[lane] = least;
}

/// force_batch_gather, Ops::kWidth lanes at a time (a group the count ends
/// in one lane at a time): each corner's node, its position and mass (the
/// least of the four kept as std::min keeps it), the element's Dm⁻¹, Fp
/// and W.
template <class Ops>
inline void force_batch_gather_lanes(const ForceSources& s, int first, int count, ForceBatch& b) {
  using R = typename Ops::R;
  constexpr int width = Ops::kWidth;
  for (int lane = 0; lane < kSvdLanes; lane += width) {
    const int e = first + lane;
    if (lane + width > count) {
      for (int k = lane; k < lane + width; ++k) force_gather_lane(s, k < count ? first + k : -1, b, k);
      continue;
    }
    int node[4][sizeof(R) / sizeof(double)], row[sizeof(R) / sizeof(double)];  // width each
    for (int c = 0; c < 4; ++c)
      for (int k = 0; k < width; ++k) node[c][k] = s.tets[4 * (e + k) + c];
    R least = Ops::gather(s.masses, node[0]);
    for (int c = 1; c < 4; ++c) {
      const R mass = Ops::gather(s.masses, node[c]);
      least = Ops::select(mass < least, mass, least);
    }
    R x[3];
    for (int c = 0; c < 4; ++c) {
      Ops::gather_rows3(s.x, node[c], x);
      for (int i = 0; i < 3; ++i) Ops::store(&b.x[c][i][lane], x[i]);
    }
    Ops::store(&b.least_mass[lane], least);
    // An element's 3×3 matrix (column-major, 9 e + 3 j + i) as three rows
    // of three: row 3 e + j holds column j.
    for (int j = 0; j < 3; ++j) {
      for (int k = 0; k < width; ++k) row[k] = 3 * (e + k) + j;
      Ops::gather_rows3(s.Dm_inv, row, x);
      for (int i = 0; i < 3; ++i) Ops::store(&b.Dm_inv[3 * j + i][lane], x[i]);
      Ops::gather_rows3(s.Fp, row, x);
      for (int i = 0; i < 3; ++i) Ops::store(&b.Fp[3 * j + i][lane], x[i]);
    }
    Ops::store(&b.rest_volume[lane], Ops::load(&s.rest_volumes[e]));
  }
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

/// det M in Eigen's order (its 3×3 determinant: expansion along the first row).
template <class R>
inline R determinant(const Mat3<R>& M) {
  const auto minor = [&M](int a, int b, int c) { return M(0, a) * (M(1, b) * M(2, c) - M(1, c) * M(2, b)); };
  return (minor(0, 1, 2) - minor(1, 0, 2)) + minor(2, 0, 1);
}

/// ∂ψ/∂σ of the polynomial models, IsotropicEnergy::dpsi's formulas in its
/// order: J = σ₀σ₁σ₂, ∂J/∂σ_i the product of the other two;
/// fixed corotated 2μ(σ_i − 1) + λ(J − 1) ∂J/∂σ_i, stable neo-Hookean
/// μσ_i + (λ(J − 1) − μ) ∂J/∂σ_i.
template <class R>
inline void polynomial_dpsi(const ForceModel& model, const R sigma[3], R dpsi[3]) {
  const R J = (sigma[0] * sigma[1]) * sigma[2];
  const R dJ[3] = {sigma[1] * sigma[2], sigma[0] * sigma[2], sigma[0] * sigma[1]};
  const R volumetric = model.lambda * (J - 1.0);
  if (model.stress == LaneStress::fixed_corotated) {
    const double two_mu = 2.0 * model.mu;
    for (int i = 0; i < 3; ++i) dpsi[i] = two_mu * (sigma[i] - 1.0) + volumetric * dJ[i];
  } else {
    const R scale = volumetric - model.mu;
    for (int i = 0; i < 3; ++i) dpsi[i] = model.mu * sigma[i] + scale * dJ[i];
  }
}

/// Σ_i |∇λ_i|² of the barycentric gradients: the rows of Dm⁻¹ and minus
/// their sum, as Eigen sums Dm⁻¹.squaredNorm() + Dm⁻¹.colwise().sum().squaredNorm()
/// (the first over pairs of lanes, entries k and k + 2 together).
template <class R>
inline R gradients_squared(const Mat3<R>& D) {
  R q[9];
  for (int k = 0; k < 9; ++k) q[k] = D.m[k] * D.m[k];
  const R entries = (((q[0] + q[2]) + (q[4] + q[6])) + ((q[1] + q[3]) + (q[5] + q[7]))) + q[8];
  R c[3];
  for (int j = 0; j < 3; ++j) c[j] = (D(0, j) + D(1, j)) + D(2, j);
  return entries + (c[0] * c[0] + (c[1] * c[1] + c[2] * c[2]));
}

/// force_batch_forces, Ops::kWidth lanes at a time.
template <class Ops>
inline void force_batch_forces_lanes(ForceBatch& b) {
  using R = typename Ops::R;
  const ForceModel& model = b.model;
  for (int first = 0; first < kSvdLanes; first += Ops::kWidth) {
    Mat3<R> U, V, Fp, Fp_inv, Dm_inv, Fe;
    R sigma[3], dpsi[3], f[4][3];
    for (int k = 0; k < 9; ++k) {
      U.m[k] = Ops::load(&b.svd.U[k][first]);
      V.m[k] = Ops::load(&b.svd.V[k][first]);
      Fp.m[k] = Ops::load(&b.Fp[k][first]);
      Fp_inv.m[k] = Ops::load(&b.Fp_inv[k][first]);
      Dm_inv.m[k] = Ops::load(&b.Dm_inv[k][first]);
    }
    for (int k = 0; k < 3; ++k) sigma[k] = Ops::load(&b.svd.sigma[k][first]);
    if (model.stress == LaneStress::given) {
      for (int k = 0; k < 3; ++k) dpsi[k] = Ops::load(&b.dpsi[k][first]);
    } else {
      polynomial_dpsi(model, sigma, dpsi);
    }
    const R rest_volume = Ops::load(&b.rest_volume[first]);
    const R volume = rest_volume * determinant(Fp);
    element_forces(U, sigma, V, dpsi, Fp_inv, Dm_inv, volume, f, Fe);
    for (int c = 0; c < 4; ++c)
      for (int i = 0; i < 3; ++i) Ops::store(&b.f[c][i][first], f[c][i]);
    for (int k = 0; k < 9; ++k) Ops::store(&b.Fe[k][first], Fe.m[k]);
    // Explicit stability bound (algorithms.md, "Time integration").
    const R stiffness = (model.modulus * volume) * gradients_squared(Dm_inv);
    Ops::store(&b.dt_squared[first], Ops::load(&b.least_mass[first]) / stiffness);
    // What the damping freezes (Damping::freeze(body, Fe, Fp⁻¹) in its order).
    const Mat3<R> A = product(Dm_inv, Fp_inv);
    for (int k = 0; k < 9; ++k) Ops::store(&b.A[k][first], A.m[k]);
    Ops::store(&b.damping_scale[first], ((2.0 * model.viscosity) * rest_volume) / determinant(Fp_inv));
  }
}

}  // namespace
}  // namespace goo::lanes
