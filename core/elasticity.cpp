#include "core/elasticity.h"

#include <algorithm>
#include <cmath>

namespace goo {
namespace {

constexpr double kC = IsotropicEnergy::kNeoHookeanThreshold;

/// ln s, continued below kC by its second-order Taylor expansion at kC: C²,
/// finite for every s, and its slope stays positive up to s = 2kC, so the
/// energy pushes a collapsing or inverted element back.
struct ContinuedLog {
  double value, first, second;
  explicit ContinuedLog(double s) {
    if (s >= kC) {
      value = std::log(s);
      first = 1.0 / s;
      second = -1.0 / (s * s);
    } else {
      const double d = s - kC;
      value = std::log(kC) + d / kC - d * d / (2.0 * kC * kC);
      first = 1.0 / kC - d / (kC * kC);
      second = -1.0 / (kC * kC);
    }
  }
};

/// Products of the other two singular values: ∂J/∂σ_i.
Eigen::Vector3d cofactors(const Eigen::Vector3d& s) {
  return {s[1] * s[2], s[0] * s[2], s[0] * s[1]};
}

}  // namespace

IsotropicEnergy::IsotropicEnergy(ElasticModel model, double mu, double lambda)
    : model_(model), mu_(mu), lambda_(model == ElasticModel::stable_neo_hookean ? lambda + mu : lambda) {}

double IsotropicEnergy::psi(const Eigen::Vector3d& s) const {
  const double J = s.prod();
  switch (model_) {
    case ElasticModel::fixed_corotated:
      // Stomakhin et al. 2012: μ Σ(σ_i − 1)² + λ/2 (J − 1)².
      return mu_ * (s.array() - 1.0).square().sum() + 0.5 * lambda_ * (J - 1.0) * (J - 1.0);
    case ElasticModel::stable_neo_hookean:
      // Smith et al. 2018, eq. 13, shifted so that ψ(I) = 0:
      // μ/2 (I_C − 3) − μ (J − 1) + λ̃/2 (J − 1)², λ̃ = λ + μ.
      return 0.5 * mu_ * (s.squaredNorm() - 3.0) - mu_ * (J - 1.0) + 0.5 * lambda_ * (J - 1.0) * (J - 1.0);
    case ElasticModel::neo_hookean: {
      // Irving et al. 2004: μ/2 (I_C − 3) − μ ln J + λ/2 (ln J)², ln J = Σ ln σ_i continued.
      const double L = ContinuedLog(s[0]).value + ContinuedLog(s[1]).value + ContinuedLog(s[2]).value;
      return 0.5 * mu_ * (s.squaredNorm() - 3.0) - mu_ * L + 0.5 * lambda_ * L * L;
    }
  }
  return 0.0;
}

Eigen::Vector3d IsotropicEnergy::dpsi(const Eigen::Vector3d& s) const {
  const double J = s.prod();
  const Eigen::Vector3d dJ = cofactors(s);
  switch (model_) {
    case ElasticModel::fixed_corotated:
      return 2.0 * mu_ * (s.array() - 1.0).matrix() + lambda_ * (J - 1.0) * dJ;
    case ElasticModel::stable_neo_hookean:
      return mu_ * s + (lambda_ * (J - 1.0) - mu_) * dJ;
    case ElasticModel::neo_hookean: {
      const ContinuedLog g[3] = {ContinuedLog(s[0]), ContinuedLog(s[1]), ContinuedLog(s[2])};
      const double L = g[0].value + g[1].value + g[2].value;
      const Eigen::Vector3d dL(g[0].first, g[1].first, g[2].first);
      return mu_ * s + (lambda_ * L - mu_) * dL;
    }
  }
  return Eigen::Vector3d::Zero();
}

Eigen::Matrix3d IsotropicEnergy::d2psi(const Eigen::Vector3d& s) const {
  const double J = s.prod();
  const Eigen::Vector3d dJ = cofactors(s);
  // ∂²J/∂σ_i∂σ_j = σ_k (k the third index), 0 on the diagonal.
  Eigen::Matrix3d d2J;
  d2J << 0.0, s[2], s[1], s[2], 0.0, s[0], s[1], s[0], 0.0;
  switch (model_) {
    case ElasticModel::fixed_corotated:
      return 2.0 * mu_ * Eigen::Matrix3d::Identity() + lambda_ * (dJ * dJ.transpose() + (J - 1.0) * d2J);
    case ElasticModel::stable_neo_hookean:
      return mu_ * Eigen::Matrix3d::Identity() + lambda_ * dJ * dJ.transpose() + (lambda_ * (J - 1.0) - mu_) * d2J;
    case ElasticModel::neo_hookean: {
      const ContinuedLog g[3] = {ContinuedLog(s[0]), ContinuedLog(s[1]), ContinuedLog(s[2])};
      const double L = g[0].value + g[1].value + g[2].value;
      const Eigen::Vector3d dL(g[0].first, g[1].first, g[2].first);
      const Eigen::Vector3d d2L(g[0].second, g[1].second, g[2].second);
      Eigen::Matrix3d H = lambda_ * dL * dL.transpose();
      H.diagonal() += (mu_ * Eigen::Vector3d::Ones() + (lambda_ * L - mu_) * d2L);
      return H;
    }
  }
  return Eigen::Matrix3d::Zero();
}

double energy_density(const IsotropicEnergy& energy, const Eigen::Matrix3d& F) {
  return energy.psi(svd3(F).sigma);
}

Eigen::Matrix3d first_piola(const IsotropicEnergy& energy, const Svd3& svd) {
  return svd.U * energy.dpsi(svd.sigma).asDiagonal() * svd.V.transpose();
}

Matrix9d first_piola_derivative(const IsotropicEnergy& energy, const Svd3& svd) {
  const Eigen::Vector3d& s = svd.sigma;
  const Eigen::Vector3d g = energy.dpsi(s);
  const Eigen::Matrix3d H = energy.d2psi(s);
  // The 2×2 blocks of the pairs (0,1), (0,2), (1,2).
  double a[3][3] = {}, b[3][3] = {};
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const double scale = std::max({1.0, std::abs(s[i]), std::abs(s[j])});
      const double diff = s[i] - s[j];
      // (ψ_i − ψ_j)/(σ_i − σ_j); its limit for σ_i → σ_j is ψ_ii − ψ_ij. Near
      // the switch, cancellation and truncation errors are both ≈ 1e-6.
      const double q_minus = std::abs(diff) > 1e-6 * scale ? (g[i] - g[j]) / diff : 0.5 * (H(i, i) + H(j, j)) - H(i, j);
      double sum = s[i] + s[j];  // ≥ 0 because σ_i ≥ |σ_j| for i < j
      sum = std::max(sum, 1e-6 * scale);
      const double q_plus = (g[i] + g[j]) / sum;
      a[i][j] = 0.5 * (q_minus + q_plus);
      b[i][j] = 0.5 * (q_minus - q_plus);
    }
  Matrix9d dPdF;
  for (int l = 0; l < 3; ++l)
    for (int k = 0; k < 3; ++k) {
      // δF = e_k e_lᵀ in the world frame; in the SVD frame δF̂ = Uᵀ δF V.
      const Eigen::Matrix3d dF_hat = svd.U.row(k).transpose() * svd.V.row(l);
      Eigen::Matrix3d dP_hat = Eigen::Matrix3d::Zero();
      dP_hat.diagonal() = H * dF_hat.diagonal();
      for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) {
          dP_hat(i, j) = a[i][j] * dF_hat(i, j) + b[i][j] * dF_hat(j, i);
          dP_hat(j, i) = b[i][j] * dF_hat(i, j) + a[i][j] * dF_hat(j, i);
        }
      const Eigen::Matrix3d dP = svd.U * dP_hat * svd.V.transpose();
      dPdF.col(k + 3 * l) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(dP.data());
    }
  return dPdF;
}

}  // namespace goo
