#pragma once
// Viscosity β: Rayleigh dissipation of the elastic Green-strain rate,
// D = W det(Fp) β ‖sym(Feᵀ Ḟe)‖², Ḟe = Ḟ Fp⁻¹, with Fe frozen at the start of a
// solve. Its force, from P_d = ∂D/∂Ḟ / (W det Fp) = 2β Fe sym(Feᵀ Ḟe) Fp⁻ᵀ, is
// linear in the velocities (the Newmark damping solve is SPD), exactly zero
// for every rigid motion of a deformed element (Ḟ = Ω F makes Feᵀ Ḟe skew),
// and torque-free (P_d Fᵀ is symmetric), so it conserves angular momentum.
// At rest it equals the corotated damping of algorithms.md; that form,
// 2β R sym(Rᵀ Ḟ), resists rigid rotation of a deformed element and spins
// bodies up, which is why goo does not use it (docs/physics.md).
#include <array>
#include <vector>

#include "core/body.h"
#include "core/elastic_forces.h"

namespace goo {

class Damping {
 public:
  /// out (#N×3) = −C v: the viscous forces for nodal velocities v, with the
  /// elastic deformation Fe and Fp⁻¹ of each element frozen (ElasticForces
  /// records both at each evaluation).
  void apply(const Body& body, const std::vector<Eigen::Matrix3d>& Fe, const std::vector<Eigen::Matrix3d>& Fp_inv,
             const Points& v, Points& out);

  /// out[n] = node n's own 3×3 block of C (f = −C v), summed over its
  /// elements in the incidence order: C_nn = Σ_e W det(Fp) β (|w|² Fe Feᵀ
  /// + (Fe w)(Fe w)ᵀ), w = Fp⁻ᵀ ∇N_n. The damping solve's block-Jacobi
  /// preconditioner is (m_n I + h C_nn)⁻¹.
  void diagonal_blocks(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                       const std::vector<Eigen::Matrix3d>& Fp_inv, std::vector<Eigen::Matrix3d>& out);

 private:
  std::vector<Matrix34> element_forces_;
  std::vector<std::array<Eigen::Matrix3d, 4>> element_blocks_;
};

/// max over elements of ‖Ḟ‖_F for velocities v, 1/s.
double max_strain_rate(const Body& body, const Points& v);

}  // namespace goo
