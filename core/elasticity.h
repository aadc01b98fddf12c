#pragma once
// Isotropic hyperelastic energy densities as functions of the singular
// values σ of the elastic deformation gradient, and from them the first
// Piola–Kirchhoff stress P and its derivative dP/dF (algorithms.md,
// "Invertible elasticity").
#include <Eigen/Core>

#include "core/material.h"
#include "core/svd3.h"

namespace goo {

using Matrix9d = Eigen::Matrix<double, 9, 9>;

/// ψ(σ) of one model with its Lamé parameters, in Pa (J/m³).
class IsotropicEnergy {
 public:
  /// Threshold below which the neo-Hookean's ln σ is continued by its
  /// second-order Taylor expansion (an energy-consistent form of Irving et
  /// al. 2004's extrapolation): exactly neo-Hookean for every σ_i ≥ 0.2.
  static constexpr double kNeoHookeanThreshold = 0.2;

  IsotropicEnergy(ElasticModel model, double mu, double lambda);
  explicit IsotropicEnergy(const Material& material)
      : IsotropicEnergy(material.model, material.mu(), material.lambda()) {}

  [[nodiscard]] double psi(const Eigen::Vector3d& s) const;
  /// ∂ψ/∂σ_i: the diagonal of P̂.
  [[nodiscard]] Eigen::Vector3d dpsi(const Eigen::Vector3d& s) const;
  /// ∂²ψ/∂σ_i∂σ_j.
  [[nodiscard]] Eigen::Matrix3d d2psi(const Eigen::Vector3d& s) const;

  [[nodiscard]] ElasticModel model() const { return model_; }
  [[nodiscard]] double mu() const { return mu_; }
  [[nodiscard]] double lambda() const { return lambda_; }

 private:
  ElasticModel model_;
  double mu_;
  double lambda_;  // for stable neo-Hookean: λ + μ, so its linearisation is that of (μ, λ)
};

/// ψ(F) through the rotation-variant SVD.
double energy_density(const IsotropicEnergy& energy, const Eigen::Matrix3d& F);

/// P = U diag(∂ψ/∂σ) Vᵀ (Irving et al. 2004, eq. 2).
Eigen::Matrix3d first_piola(const IsotropicEnergy& energy, const Svd3& svd);

/// dP/dF as a 9×9 matrix acting on column-major vec(δF): in the SVD frame,
/// δP̂_ii = Σ_j ψ_ij δF̂_jj, and each pair i < j couples (δF̂_ij, δF̂_ji)
/// through [[a, b], [b, a]] with a = (σ_iψ_i − σ_jψ_j)/(σ_i² − σ_j²),
/// b = (σ_jψ_i − σ_iψ_j)/(σ_i² − σ_j²) (Teran et al. 2005, sec. 5), written as
/// ½[(ψ_i − ψ_j)/(σ_i − σ_j) ± (ψ_i + ψ_j)/(σ_i + σ_j)] and evaluated by the
/// limit ψ_ii − ψ_ij where σ_i ≈ σ_j, with |σ_i + σ_j| clamped away from 0.
Matrix9d first_piola_derivative(const IsotropicEnergy& energy, const Svd3& svd);

}  // namespace goo
