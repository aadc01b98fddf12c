#pragma once
// Plastic flow with creep and work hardening (Wojtan & Turk 2008, eqs. 1–2;
// Bargteil et al. 2007), rate-independent: the flow per step is ν Δt.
#include <Eigen/Core>
#include <Eigen/LU>

#include "core/elasticity.h"
#include "core/svd3.h"

namespace goo {

/// Elements whose smallest singular value is at or below this are nearly
/// inverted and do not flow: their SVD frame says little about shape.
inline constexpr double kPlasticMinSingularValue = 0.05;

/// One element's plastic flow for a step of length dt. `svd` is the SVD of
/// Fe = F Fp⁻¹; if the deviatoric stress norm s = ‖dev P̂‖ exceeds
/// PY + K α, then γ = min(ν Δt (s − PY − Kα) / s, 1),
/// Fp ← V (Σ*)^γ Vᵀ Fp with Σ* = det(Σ)^(−1/3) Σ (renormalised to det 1, so
/// det Fp never changes), α ← α + γ s, and svd.sigma becomes the singular
/// values of the new Fe (U and V are unchanged). Returns true if it flowed.
bool plastic_flow(const Material& material, const IsotropicEnergy& energy, double dt, Svd3& svd, Eigen::Matrix3d& Fp,
                  double& alpha);

}  // namespace goo
