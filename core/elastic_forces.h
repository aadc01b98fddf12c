#pragma once
// Elastic forces of a tetrahedral body: per element in parallel into
// per-element buffers, then gathered to nodes in a fixed order, so results
// are bitwise identical for any number of threads (architecture.md).
#include <vector>

#include "core/body.h"
#include "core/damping_batch.h"
#include "core/element_elasticity.h"
#include "core/svd3_batch.h"

namespace goo {

/// Sums per-element corner values into nodes through the incidence order:
/// out.row(n) = Σ per_element[e].col(k) over the corners (e, k) of node n.
void gather_to_nodes(const NodeIncidence& incidence, const std::vector<Matrix34>& per_element, Points& out);

class ElasticForces {
 public:
  /// f (#N×3, N) = elastic forces at positions x. If plastic_dt > 0, each
  /// element first flows plastically for a step of that length (reusing its
  /// SVD), updating body.Fp and body.alpha. Records each element's Fe, and
  /// what the damping freezes with it (damping_blocks), and its explicit
  /// time-step bound. Element e's nodal forces are element_forces
  /// (core/element_elasticity.h).
  void evaluate(Body& body, const Points& x, double plastic_dt, Points& f);

  /// The last evaluation's elements (after plastic flow) as the damping
  /// freezes them, eight a block (element 8 b + lane at block b, lane; lanes
  /// past the last element zero): G = Fe, A = Dm⁻¹ Fp⁻¹ and 2β W det Fp,
  /// β the body's viscosity, the bits Damping::freeze(body, Fe, Fp⁻¹) would
  /// compute. Damping::freeze(body, forces) keeps them by reference.
  [[nodiscard]] const std::vector<DampingBlock>& damping_blocks() const { return damping_blocks_; }
  /// Elements of the body at the last evaluation.
  [[nodiscard]] Index evaluated_elements() const { return evaluated_elements_; }
  /// Fe of element e at the last evaluation.
  [[nodiscard]] Eigen::Matrix3d elastic_deformation(Index e) const {
    const DampingBlock& block = damping_blocks_[at(e / kDampingLanes)];
    Eigen::Matrix3d Fe;
    for (int k = 0; k < 9; ++k) Fe.data()[k] = block.G[k][e % kDampingLanes];
    return Fe;
  }
  /// min over elements of √(m_min / k_e) at the last evaluation, with
  /// k_e = (λ + 2μ) W det(Fp) Σ_i |∇λ_i|² (∇λ_i: gradients of the
  /// barycentric coordinates, rows of Dm⁻¹ and minus their sum) and m_min the
  /// element's lightest node. Multiply by a CFL number ≤ 1.
  [[nodiscard]] double critical_time_step() const { return critical_dt_; }
  /// m_min / k_e of each element at the last evaluation (the square of its
  /// own bound; critical_time_step is the root of the least).
  [[nodiscard]] const std::vector<double>& element_critical_dt_squared() const { return element_dt_squared_; }
  /// Elements that flowed at the last evaluation.
  [[nodiscard]] Index plastic_elements() const { return plastic_count_; }

  /// The vector instructions evaluate uses (default: active_simd_level();
  /// the results are the same bits at every level this processor supports).
  void set_simd_level(SimdLevel level) { simd_level_ = level; }

 private:
  /// Each corner's force, at its place in the incidence (NodeIncidence::slots).
  std::vector<Eigen::Vector3d> corner_forces_;
  std::vector<DampingBlock> damping_blocks_;
  Index evaluated_elements_ = 0;
  std::vector<double> element_dt_squared_;  ///< m_min / k_e per element
  std::vector<unsigned char> flowed_;
  double critical_dt_ = 0.0;
  Index plastic_count_ = 0;
  SimdLevel simd_level_ = active_simd_level();
};

/// Σ_e element_energy at positions x (compensated sum), J.
double elastic_energy(const Body& body, const Points& x);

/// Deformation gradient F = Ds Dm⁻¹ of element e at positions x.
Eigen::Matrix3d deformation_gradient(const Body& body, const Points& x, Index e);

}  // namespace goo
