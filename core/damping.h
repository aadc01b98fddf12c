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
#include "core/damping_batch.h"
#include "core/elastic_forces.h"

namespace goo {

class Damping {
 public:
  /// Freezes C at the elastic deformation Fe and Fp⁻¹ of each element:
  /// keeps per element, eight a block, Fe and what every application would
  /// compute: A = Dm⁻¹ Fp⁻¹ (Ḟe = Vs A, Vs the velocity differences) and
  /// 2β W det Fp.
  void freeze(const Body& body, const std::vector<Eigen::Matrix3d>& Fe, const std::vector<Eigen::Matrix3d>& Fp_inv);
  /// The same from the force pass that computed them with the forces
  /// (ElasticForces::damping_blocks, the same bits), kept by reference: the
  /// operator of its last evaluation, while it lasts. Throws unless that
  /// evaluation was of this body's elements.
  void freeze(const Body& body, const ElasticForces& forces);

  /// out (#N×3) = −C v for nodal velocities v, C as last frozen: per
  /// element, with S = sym(Feᵀ Vs A), the forces on corners 1–3 are the
  /// columns of −2β W det(Fp) Fe S Aᵀ and corner 0's minus their sum.
  /// Eight elements at a time in the processor's vector lanes
  /// (core/damping_batch.h): the same bits at every width.
  void apply(const Body& body, const Points& v, Points& out);
  /// apply's pass over the elements alone: each corner's force, element by
  /// element (corner 4 e + k), into corner_forces(); summed over each
  /// node's corners in the incidence order, they are apply's out. The
  /// elements are split evenly between the threads in order (a static
  /// partition), so that a caller's node passes, split the same way, read
  /// mostly what the same thread wrote.
  /// With `corner_blocks`, each corner's own 3×3 block of C too, from the
  /// same read of the element's frozen values (into corner_blocks()).
  void element_pass(const Body& body, const Points& v, bool corner_blocks = false);
  /// The same pass for two velocity fields at once, each element's frozen
  /// values read once for both: v's forces into corner_forces(), w's into
  /// second_corner_forces(), each the same bits as a pass of its own.
  void element_pass(const Body& body, const Points& v, const Points& w, bool corner_blocks = false);
  /// The pass for v = z + β p, each node's formed as it is read (the
  /// conjugate gradients' next direction, before it is stored): the same
  /// bits as a pass for z + β p computed first.
  void element_pass(const Body& body, const Points& z, const Points& p, double beta);
  [[nodiscard]] const std::vector<Eigen::Vector3d>& corner_forces() const { return corner_forces_; }
  [[nodiscard]] const std::vector<Eigen::Vector3d>& second_corner_forces() const { return second_corner_forces_; }
  /// Each corner's block of C (element e's four at [e]), as the last
  /// diagonal_blocks or element pass with corner_blocks computed them:
  /// summed over a node's corners in the incidence order from zero, they
  /// are diagonal_blocks' block of that node.
  [[nodiscard]] const std::vector<std::array<Eigen::Matrix3d, 4>>& corner_blocks() const { return element_blocks_; }
  /// Node n's own block of C from corner_blocks(): its corners' blocks
  /// summed from zero in the incidence order (diagonal_blocks' sum).
  [[nodiscard]] Eigen::Matrix3d node_block(const NodeIncidence& incidence, Index n) const {
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    for (Index i = incidence.offsets[at(n)]; i < incidence.offsets[at(n) + 1]; ++i) {
      const Index corner = incidence.corners[at(i)];
      sum += element_blocks_[at(corner / 4)][static_cast<std::size_t>(corner % 4)];
    }
    return sum;
  }

  /// freeze(body, Fe, Fp_inv), then apply(body, v, out).
  void apply(const Body& body, const std::vector<Eigen::Matrix3d>& Fe, const std::vector<Eigen::Matrix3d>& Fp_inv,
             const Points& v, Points& out);

  /// out[n] = node n's own 3×3 block of C (f = −C v), summed over its
  /// elements in the incidence order: C_nn = Σ_e W det(Fp) β (|w|² Fe Feᵀ
  /// + (Fe w)(Fe w)ᵀ), w = Fp⁻ᵀ ∇N_n. The damping solve's block-Jacobi
  /// preconditioner is (m_n I + h C_nn)⁻¹.
  void diagonal_blocks(const Body& body, std::vector<Eigen::Matrix3d>& out);
  /// freeze(body, Fe, Fp_inv), then diagonal_blocks(body, out).
  void diagonal_blocks(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                       const std::vector<Eigen::Matrix3d>& Fp_inv, std::vector<Eigen::Matrix3d>& out);

 private:
  /// The element loop of apply and element_pass. (apply keeps TBB's
  /// default split: BM_DampingApply/12/2 took 0.17 ms with the static one,
  /// 0.11 ms without, its calling thread left waiting for a late worker.)
  /// `velocity.sources(tets)` says where damping_gather reads the
  /// corners' velocities (core/damping_batch.h); with
  /// `second`, a second field's forces too (into second_corner_forces_);
  /// with `corner_blocks`, the corners' blocks of C (into element_blocks_).
  template <class Partitioner, class Velocity, class Second>
  void element_loop(const Body& body, const Velocity& velocity, const Second* second, bool corner_blocks,
                    const Partitioner& partitioner);
  /// Block b's corner blocks into element_blocks_.
  void store_corner_blocks(Index b, Index num_elements, SimdLevel level, DampingDiagonal& diagonal);
  /// Throws unless frozen for a body of this many elements.
  void check_frozen(const Body& body) const;
  /// Each corner's force, element by element (4 e + k).
  std::vector<Eigen::Vector3d> corner_forces_, second_corner_forces_;
  std::size_t frozen_elements_ = 0;  ///< elements of the body frozen for
  /// Fe, A = Dm⁻¹ Fp⁻¹ and the scale 2β W det Fp as frozen, eight elements a
  /// block: a force pass's (forces_blocks_, when frozen from one) or
  /// own_blocks_ (the one copy: diagonal_blocks reads A and the scale from
  /// here too).
  [[nodiscard]] const std::vector<DampingBlock>& frozen_blocks() const {
    return forces_blocks_ != nullptr ? *forces_blocks_ : own_blocks_;
  }
  const std::vector<DampingBlock>* forces_blocks_ = nullptr;
  std::vector<DampingBlock> own_blocks_;
  bool frozen_ = false;
  std::vector<std::array<Eigen::Matrix3d, 4>> element_blocks_;
};

/// max over elements of ‖Ḟ‖_F for velocities v, 1/s.
double max_strain_rate(const Body& body, const Points& v);

}  // namespace goo
