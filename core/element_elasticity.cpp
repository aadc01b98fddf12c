#include "core/element_elasticity.h"

#include <Eigen/Eigenvalues>

namespace goo {
namespace {

/// G = ∂vec(Fe)/∂x (9×12, vec column-major) for Fe = Ds B, B = Dm⁻¹ Fp⁻¹:
/// ∂Fe_il/∂x_ji = b_j(l) with b_j = row j−1 of B (j ≥ 1), b_0 = −Σ rows.
Eigen::Matrix<double, 9, 12> fe_gradient(const Eigen::Matrix3d& B) {
  Eigen::Matrix<double, 9, 12> G = Eigen::Matrix<double, 9, 12>::Zero();
  for (int j = 0; j < 4; ++j) {
    const Eigen::RowVector3d b = j == 0 ? Eigen::RowVector3d(-B.colwise().sum()) : Eigen::RowVector3d(B.row(j - 1));
    for (int l = 0; l < 3; ++l)
      for (int i = 0; i < 3; ++i) G(3 * l + i, 3 * j + i) = b[l];
  }
  return G;
}

}  // namespace

Matrix34 element_corners(const Body& body, const Points& x, Index e) {
  Matrix34 corners;
  for (int k = 0; k < 4; ++k) corners.col(k) = x.row(body.tets(e, k)).transpose();
  return corners;
}

Eigen::Matrix3d deformation_gradient(const Eigen::Matrix3d& Dm_inv, const Matrix34& corners) {
  Eigen::Matrix3d Ds;
  Ds.col(0) = corners.col(1) - corners.col(0);
  Ds.col(1) = corners.col(2) - corners.col(0);
  Ds.col(2) = corners.col(3) - corners.col(0);
  return Ds * Dm_inv;
}

double element_energy(const IsotropicEnergy& energy, const ElementRest& rest, const Matrix34& corners) {
  const Eigen::Matrix3d Fe = deformation_gradient(rest.Dm_inv, corners) * rest.Fp.inverse();
  return rest.stress_free_volume() * energy.psi(svd3(Fe).sigma);
}

Matrix34 element_forces(const IsotropicEnergy& energy, const Svd3& svd, const Eigen::Matrix3d& Fp_inv,
                        const Eigen::Matrix3d& Dm_inv, double stress_free_volume) {
  const Eigen::Matrix3d H = -stress_free_volume * first_piola(energy, svd) * Fp_inv.transpose() * Dm_inv.transpose();
  Matrix34 forces;
  forces.col(0) = -H.rowwise().sum();
  forces.rightCols<3>() = H;
  return forces;
}

Matrix34 element_forces(const IsotropicEnergy& energy, const ElementRest& rest, const Matrix34& corners) {
  const Eigen::Matrix3d Fp_inv = rest.Fp.inverse();
  const Svd3 svd = svd3(deformation_gradient(rest.Dm_inv, corners) * Fp_inv);
  return element_forces(energy, svd, Fp_inv, rest.Dm_inv, rest.stress_free_volume());
}

Matrix12 element_hessian(const IsotropicEnergy& energy, const ElementRest& rest, const Matrix34& corners,
                         bool project) {
  const Eigen::Matrix3d Fp_inv = rest.Fp.inverse();
  const Eigen::Matrix3d Fe = deformation_gradient(rest.Dm_inv, corners) * Fp_inv;
  Matrix9d A = first_piola_derivative(energy, svd3(Fe));
  A = 0.5 * (A + A.transpose());
  if (project) {
    const Eigen::SelfAdjointEigenSolver<Matrix9d> eig(A);
    A = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  }
  const Eigen::Matrix<double, 9, 12> G = fe_gradient(rest.Dm_inv * Fp_inv);
  return rest.stress_free_volume() * G.transpose() * A * G;
}

Matrix12 element_damping_matrix(double viscosity, const ElementRest& rest, const Eigen::Matrix3d& Fe) {
  const Eigen::Matrix<double, 9, 12> G = fe_gradient(rest.Dm_inv * rest.Fp.inverse());
  // L vec(X) = vec(sym(Feᵀ X)).
  Matrix9d L = Matrix9d::Zero();
  for (int c = 0; c < 9; ++c) {
    Eigen::Matrix3d X = Eigen::Matrix3d::Zero();
    X(c % 3, c / 3) = 1.0;
    const Eigen::Matrix3d M = Fe.transpose() * X;
    const Eigen::Matrix3d S = 0.5 * (M + M.transpose());
    L.col(c) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(S.data());
  }
  const Eigen::Matrix<double, 9, 12> LG = L * G;
  return 2.0 * rest.stress_free_volume() * viscosity * LG.transpose() * LG;
}

}  // namespace goo
