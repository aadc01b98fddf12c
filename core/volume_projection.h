#pragma once
// Incompressibility by projection (Irving, Schroeder & Fedkiw 2007,
// "Volume conserving finite element simulations of deformable models",
// sec. 4; docs/physics.md, "Incompressible materials"). Each node owns a
// quarter of its elements' volumes,
//   V_i(x) = ¼ Σ_{e∋i} V_e(x),  V_e = det(Ds) / 6,
// and must keep its stress-free share V̄_i = ¼ Σ_{e∋i} W_e det Fp_e (plastic
// flow is isochoric, so V̄ never changes between re-meshes). After a step's
// positions x are known, they move by
//   Δx = −M⁻¹ Gᵀ λ,  (G M⁻¹ Gᵀ) λ = V(x) − V̄,  G = ∂V/∂x at xⁿ,
// (a pressure impulse λ / Δt on each node; Δv = Δx / Δt), solved by
// Jacobi-preconditioned conjugate gradients (A never formed: G's 3-vector
// blocks G_ij, one per pair of nodes sharing an element), repeated while the
// non-linear constraint is not met (a chord method: G stays the one at the
// step's start, about which each element's impulses exert no torque, so the
// projection conserves linear and angular momentum exactly). One constraint
// per node rather than per element keeps linear tetrahedra from locking.
// The targets are the rest volumes themselves, not the last step's, scaled
// so that the embedded surface encloses the material's own volume (mass
// over density): errors never accumulate.
#include <cstdint>
#include <vector>

#include "core/body.h"
#include "core/collisions.h"
#include "core/elastic_forces.h"
#include "core/settings.h"
#include "core/types.h"

namespace goo {

struct VolumeProjectionSettings {
  /// A node is done when |V_i − V̄_i| ≤ tolerance × ¼ Σ_{e∋i} W_e det Fp_e
  /// (its whole elements' share, filled or not), V_i = ¼ Σ_{e∋i} φ_e V_e the
  /// material's share (φ_e the fraction of e it fills).
  double tolerance = kVolumeTolerance;
  int max_newton_iterations = 10;
  int max_cg_iterations = 500;
};

/// What one projection did.
struct VolumeProjectionStats {
  int newton_iterations = 0;
  int cg_iterations = 0;
  double error_before = 0.0;  ///< max_i |V_i − V̄_i| / V̄_i at the positions given
  double error = 0.0;         ///< the same after the projection
  int waited = 0;             ///< projections skipped while an element was inverted

  VolumeProjectionStats& operator+=(const VolumeProjectionStats& o);
};

/// Nodes held against obstacles: each may move only in the directions its
/// contacts leave free, P = I − Σ q qᵀ over the orthonormalised outward
/// normals q of the contacts of its elements (Irving, Schroeder & Fedkiw
/// 2007 hold collision nodes in the projection; here only along the
/// normals, so the material slides along the obstacle).
struct SlidingNodes {
  std::vector<std::uint8_t> sliding;  ///< per node
  std::vector<Eigen::Matrix3d> free;  ///< per node, P (the identity where not sliding)
  /// From the position stage's corrections, in their order: a normal within
  /// a degree of the span of a node's earlier ones adds nothing.
  static SlidingNodes from_contacts(const Body& body, const std::vector<ElementContact>& contacts);
};

class VolumeProjection {
 public:
  explicit VolumeProjection(VolumeProjectionSettings settings = {});

  /// forces −= Gᵀ(x) π: the force of the nodal pressures π carried from
  /// the last steps (nothing after reset() or for another mesh). G at the
  /// current x: the force exerts no net force or torque.
  void add_pressure_forces(const Body& body, const Points& x, Points& forces);

  /// The carried nodal pressures π, Pa (empty after reset() and before the
  /// first projection that carries).
  [[nodiscard]] const Eigen::VectorXd& pressures() const { return pressure_; }

  /// Forget the carried pressures: after this the results depend on the
  /// body's state alone (a restart point).
  void reset() {
    pressure_.resize(0);
    restore_start_.resize(0);
    prepared_.valid = false;
    gradient_at_.valid = false;
    surface_age_ = 0;
  }

  /// body.positions are the end of a step of length dt taken from `start`
  /// (xⁿ) with body.velocities: both are corrected (x += Δx, v += Δx / dt)
  /// so that every node keeps its volume. The correction's impulse −Gᵀλ/Δt,
  /// read as a force acting over `span` (the integrator's kick: Δt/2 for
  /// Newmark, Δt for backward Euler), joins the carried pressures π += λ /
  /// (Δt span), which the next steps apply (add_pressure_forces) as a
  /// prediction: under a steady load they balance the load, the projection
  /// only corrects what changed, and viscosity never acts on the motion the
  /// projection takes away. What the nodes had lost or gained before the
  /// step (x at `start` off its targets: contacts, a re-mesh, elements
  /// turning back from inversion) is corrected in the positions alone, at
  /// most a tenth of a node's volume per step, and is not carried.
  /// Nodes with `fixed` set do not move, and nodes all of whose neighbours
  /// are fixed have no constraint. While an element is inverted at `start`
  /// nothing is done (stats.waited): the elasticity turns it back first. The impulses of each element sum to zero
  /// and exert no torque about xⁿ (V_e is invariant under translation and
  /// rotation): with xⁿ⁺¹ = xⁿ + Δt v, linear and angular momentum are
  /// unchanged.
  VolumeProjectionStats project(Body& body, const Points& start, const std::vector<std::uint8_t>& fixed, double dt,
                                double span);

  /// Moves the positions alone so that every node's volume is back within
  /// the tolerance (at most kMaxDrift of a node's volume a call), G at the
  /// current positions, the `sliding` nodes along their free directions
  /// only; velocities and carried pressures unchanged. For the volume the
  /// obstacles' position corrections take after the projection
  /// (resolve_positions_keeping_volume).
  /// Only when some node is off by more than `from` (relative, as the
  /// tolerance); nothing moves otherwise (the errors reported are then
  /// those of every node with a rest volume: a bound on the constrained
  /// nodes'). The first solve starts from the
  /// last restore's first multipliers (since reset()): the contacts take
  /// much the same volume step after step, so it starts near its answer.
  VolumeProjectionStats restore(Body& body, const std::vector<std::uint8_t>& fixed, const SlidingNodes& sliding,
                                double from = 0.0);
  [[nodiscard]] double tolerance() const { return settings_.tolerance; }

  /// The second half of RATTLE (Andersen 1983) for a kick–drift–kick step:
  /// the end-of-step velocities lose their component that changes any nodal
  /// volume, v ← v − M⁻¹ Gᵀ μ / Δt with (G M⁻¹ Gᵀ) μ = Δt G v, G at the
  /// current positions; μ / (Δt span) joins the carried pressures and its
  /// force −Gᵀμ / (Δt span) `forces` (those the next kick applies).
  VolumeProjectionStats project_velocities(Body& body, const std::vector<std::uint8_t>& fixed, double dt, double span,
                                           Points& forces);

 private:
  /// G at `at_positions`, the inverse masses, the elements that can move,
  /// the nodes' rest volumes, which nodes are constrained, the preconditioner.
  void prepare(const Body& body, const Points& at_positions, const std::vector<std::uint8_t>& fixed);
  void prepare_anew(const Body& body, const Points& at_positions, const std::vector<std::uint8_t>& fixed);
  /// prepare_anew's first half: G, the inverse masses, the elements that
  /// can move, the nodes' rest volumes.
  void prepare_constraints(const Body& body, const Points& at_positions, const std::vector<std::uint8_t>& fixed);
  /// Its second half: G's rows and columns, which nodes are constrained,
  /// the preconditioner (from the first half's results).
  void prepare_rows(const Body& body);
  /// Preconditioned CG on A λ = rhs from λ's value; returns the iterations.
  int solve(const Body& body, const Eigen::VectorXd& rhs, double target, Eigen::VectorXd& lambda);
  /// s with which every target V̄_i is scaled so that the embedded surface
  /// encloses the material's own volume (Body::rest_material_volume, mass
  /// over density) after the projection: s = (V_material − V_s(x) + Σ φ_e
  /// V_e(x)) / Σ φ_e V̄_e, V_s − Σ φ_e V_e measured every few steps (it
  /// changes with the shape, slowly). 1 for a body without a surface or
  /// fractions.
  double surface_target_scale(const Body& body);
  void gradients(const Body& body, const Points& start);
  void volumes(const Body& body, const Points& positions);
  /// out = Gᵀ λ (#N×3): Σ_e (¼ Σ_k λ_{n_k}) ∂V_e/∂x, in the incidence order.
  void transpose_product(const Body& body, const Eigen::VectorXd& lambda, Points& out);
  /// element_lambda_ = Λ_e = ¼ Σ_k λ_{n_k}.
  void element_lambdas(const Body& body, const Eigen::VectorXd& lambda);
  /// out = (G M⁻¹ Gᵀ) λ over the constrained nodes (0 elsewhere); leaves
  /// direction_ = M⁻¹ Gᵀ λ, as move().
  void apply(const Body& body, const Eigen::VectorXd& lambda, Eigen::VectorXd& out);
  void move(const Eigen::VectorXd& lambda);
  /// The carried pressures += scale × λ (sized to the body first).
  void carry(const Body& body, const Eigen::VectorXd& lambda, double scale);

  /// Whether node n may move along its free directions only (during restore).
  [[nodiscard]] bool sliding(Index n) const {
    return sliding_ && static_cast<std::size_t>(n) < sliding_->sliding.size() &&
           sliding_->sliding[static_cast<std::size_t>(n)];
  }
  const SlidingNodes* sliding_ = nullptr;
  VolumeProjectionSettings settings_;
  // Work arrays, kept across steps.
  std::vector<Matrix34> gradient_;  ///< ∂V_e/∂x of each element's four nodes
  std::vector<Eigen::Vector3d> corner_gradient_;  ///< the same columns in the incidence's order
  /// Where gradient_ and corner_gradient_ were taken: positions, mesh and
  /// the weights they include.
  struct GradientKey {
    bool valid = false;
    Points positions;
    Tets tets;
    Eigen::VectorXd weight;
  } gradient_at_;
  Eigen::VectorXd element_lambda_;  ///< Λ_e = ¼ Σ_k λ_{n_k}
  Eigen::VectorXd volume_, rest_, element_sum_, inverse_mass_, node_rest_, diagonal_;
  Eigen::VectorXd rest_term_;  ///< surface_target_scale's per-element rest volumes
  /// Per element W_e det Fp_e (then × φ_e); per node ¼ Σ_{e∋i} of each:
  /// the material's share of a node is node_material_ / node_whole_.
  Eigen::VectorXd whole_, node_whole_, node_material_;
  double full_node_ = 0.0;  ///< the largest node_whole_: a node whose elements are all there
  Eigen::VectorXd weight_;  ///< per element, the share of it the constraints count (φ_e: its material)
  void weights(const Body& body);
  void weighted_volumes(const Body& body, const Points& positions);
  Eigen::VectorXd error_, r_, z_, p_, Ap_, lambda_, best_;
  std::vector<std::uint8_t> active_, movable_;
  Points direction_, transposed_;
  Eigen::VectorXd pressure_;  ///< π, the carried nodal pressures, Pa
  Eigen::VectorXd restore_start_;  ///< the last restore's first λ
  /// What the last prepare() was given without sliding nodes: a prepare
  /// for the same body, positions and fixed nodes (the next step's
  /// projection after the velocity projection) reuses its results.
  struct Prepared {
    bool valid = false;
    Points positions;
    Eigen::VectorXd masses, fractions;
    std::vector<Eigen::Matrix3d> Fp;
    std::vector<std::uint8_t> fixed;
    Eigen::VectorXd rest;  ///< rest_ as prepared (its users scale it)
    [[nodiscard]] bool same(const Body& body, const Points& at_positions, const std::vector<std::uint8_t>& fixed) const;
  } prepared_;
  /// Each node's distinct neighbours (itself included), in the order its
  /// incidence first meets them (entries offsets[i] … offsets[i + 1] − 1),
  /// and the neighbour slot of every corner k of every incident element:
  /// G's entries gather without a search. Made once per mesh (the tets
  /// they were made for).
  struct Neighbourhoods {
    Tets tets;
    std::vector<Index> offsets, nodes, slots;
  } neighbourhoods_;
  /// At node i's entry for neighbour j, as prepared: G_ij = ¼ Σ_{e∋i,j}
  /// ∂V_e/∂x_j (`rows_`) and G_ji (`columns_`, i's own gradient in the
  /// elements the two share). Gᵀλ and G y are then one pass over the nodes
  /// each, every node summing its own entries in order.
  std::vector<Eigen::Vector3d> rows_, columns_;
  /// direction_ = M⁻¹ P Gᵀ λ from the prepared G (columns_): at each node
  /// along its free directions (P, where sliding), by its inverse mass.
  void directions(const Eigen::VectorXd& lambda);
  /// Rebuilds neighbourhoods_ if the mesh changed; true if it did.
  bool update_neighbourhoods(const Body& body);
  double last_residual_ = 0.0;
  double discrepancy_ = 0.0;  ///< V_s − Σ φ_e V_e when last measured
  int surface_age_ = 0;       ///< projections since it was
};

/// The obstacles' position corrections for an incompressible body
/// (SurfaceCollisions::resolve_positions), and the volume they take given
/// back in the positions (VolumeProjection::restore) with the nodes they
/// moved held against the obstacles; then a second pass of corrections for
/// the few vertices restoring moved into an obstacle. Without it every
/// step's contacts take volume the next step's projection gives back, and
/// a body under a press is short of it in every frame (docs/physics.md,
/// "Incompressible materials"). `restore_seconds` gets the time restoring took.
CollisionStats resolve_positions_keeping_volume(Body& body, SurfaceCollisions& collisions, VolumeProjection& projection,
                                                const std::vector<Obstacle>& obstacles, double t,
                                                const std::vector<std::uint8_t>& fixed, VolumeProjectionStats& stats,
                                                double& restore_seconds);

/// max_i |V_i(x) − V̄_i| / (¼ Σ_{e∋i} W_e det Fp_e) over the nodes of
/// `body` (the measure the projection drives below its tolerance).
double max_nodal_volume_error(const Body& body, const Points& x);

}  // namespace goo
