#pragma once
// One tetrahedron's elasticity as pure functions: its energy, nodal forces
// (3×4), Hessian (12×12) and damping matrix, from the element's rest data
// (Dm⁻¹, Fp, W), its four corner positions and the energy model. Every
// solver gets these from here: ElasticForces (Newmark, the backward-Euler
// gradient), the backward-Euler Hessian and damping, elastic_energy. The
// kinematics are in docs/algorithms.md, "Kinematics" and "Invertible
// elasticity".
#include <Eigen/Core>

#include "core/body.h"
#include "core/elasticity.h"
#include "core/parallel.h"
#include "core/svd3.h"

namespace goo {

using Matrix34 = Eigen::Matrix<double, 3, 4>;
using Matrix12 = Eigen::Matrix<double, 12, 12>;

/// What an element's response depends on besides its corners: Dm⁻¹ (1/m),
/// the plastic deformation Fp and the rest volume W (m³). References into
/// a body's arrays (`ElementRest::of`), or into a test's own values.
struct ElementRest {
  const Eigen::Matrix3d& Dm_inv;
  const Eigen::Matrix3d& Fp;
  double rest_volume;

  static ElementRest of(const Body& body, Index e) { return {body.Dm_inv[at(e)], body.Fp[at(e)], body.rest_volumes[e]}; }
  /// W det Fp: the volume of the element's material without stress, m³.
  [[nodiscard]] double stress_free_volume() const { return rest_volume * Fp.determinant(); }
};

/// Element e's four corners at positions x, as columns.
Matrix34 element_corners(const Body& body, const Points& x, Index e);

/// F = Ds Dm⁻¹, Ds = [x1 − x0, x2 − x0, x3 − x0] (algorithms.md, "Kinematics").
Eigen::Matrix3d deformation_gradient(const Eigen::Matrix3d& Dm_inv, const Matrix34& corners);

/// W det(Fp) ψ(Fe), Fe = F Fp⁻¹, J.
double element_energy(const IsotropicEnergy& energy, const ElementRest& rest, const Matrix34& corners);

/// The nodal forces of an element whose elastic deformation has the SVD
/// `svd` (taken after any plastic flow): H = −V P(Fe) Fp⁻ᵀ Dm⁻ᵀ with
/// V = W det Fp and P = U diag(∂ψ/∂σ) Vᵀ (Irving et al. 2004, eq. 2), on
/// corners 1–3, and minus their sum on corner 0, N.
Matrix34 element_forces(const IsotropicEnergy& energy, const Svd3& svd, const Eigen::Matrix3d& Fp_inv,
                        const Eigen::Matrix3d& Dm_inv, double stress_free_volume);
/// The same from the element's rest data and corners: −∂(element_energy)/∂x.
Matrix34 element_forces(const IsotropicEnergy& energy, const ElementRest& rest, const Matrix34& corners);

/// The 12×12 Hessian of element_energy (corner-major: entry 3k + i is
/// corner k's coordinate i): V Gᵀ (dP/dF) G with G = ∂vec(Fe)/∂x. With
/// `project`, dP/dF's negative eigenvalues are clamped to zero first, so
/// the block is positive semi-definite.
Matrix12 element_hessian(const IsotropicEnergy& energy, const ElementRest& rest, const Matrix34& corners,
                         bool project);

/// The 12×12 damping matrix C_e = 2 V β (L G)ᵀ (L G) with Fe frozen
/// (L: δFe ↦ sym(Feᵀ δFe), β the viscosity in Pa·s): the dissipation is
/// ½ vᵀ C_e v and the viscous force −C_e v (core/damping.h). Positive
/// semi-definite.
Matrix12 element_damping_matrix(double viscosity, const ElementRest& rest, const Eigen::Matrix3d& Fe);

}  // namespace goo
