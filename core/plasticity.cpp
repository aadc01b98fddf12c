#include "core/plasticity.h"

#include <algorithm>
#include <cmath>

namespace goo {

bool plastic_flow(const Material& material, const IsotropicEnergy& energy, double dt, Svd3& svd, Eigen::Matrix3d& Fp,
                  double& alpha) {
  const Eigen::Vector3d& sigma = svd.sigma;
  if (!(sigma[2] > kPlasticMinSingularValue)) return false;
  const Eigen::Vector3d P_hat = energy.dpsi(sigma);
  const double s = (P_hat.array() - P_hat.mean()).matrix().norm();
  const double threshold = material.yield_stress + material.hardening * alpha;
  if (!(s > threshold)) return false;
  const double gamma = std::min(material.flow_rate * dt * (s - threshold) / s, 1.0);
  if (gamma <= 0.0) return false;
  // (Σ*)^γ = (J^(−1/3) Σ)^γ, then renormalised so its determinant is 1 to
  // round-off: plastic flow never changes volume.
  Eigen::Vector3d d = (sigma.array().log() - sigma.array().log().mean()).matrix();  // ln Σ*
  d = (gamma * d).array().exp().matrix();
  d /= std::cbrt(d.prod());
  Fp = svd.V * d.asDiagonal() * svd.V.transpose() * Fp;
  svd.sigma = sigma.cwiseQuotient(d);
  alpha += gamma * s;
  return true;
}

}  // namespace goo
