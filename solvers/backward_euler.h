#pragma once
// Backward Euler (ours; algorithms.md, "Time integration"): each step
// minimises the incremental potential
//   E(x) = ½ Δt⁻² ‖x − x̂‖²_M + Ψ(x) + Δt D((x − xⁿ)/Δt),  x̂ = xⁿ + Δt vⁿ + Δt² g,
// (Ψ the elastic energy of Fe plus the surface energy σ A(W x) of the
// embedded surface, D = ½ vᵀ C v the viscous dissipation with Fe frozen at
// the start of the step) by Newton's method with per-element
// Hessians projected to positive semi-definite, a backtracking line search
// on E, and CHOLMOD's supernodal Cholesky whose symbolic analysis is kept
// until the mesh topology changes. vⁿ⁺¹ = (xⁿ⁺¹ − xⁿ)/Δt; plastic flow after
// convergence; then the surface collisions. With settings.statics the same
// Newton solves the static equilibrium instead: Π(x) = Ψ(x) − Σ m γ g·x
// without inertia or damping, in load steps (docs/implicit.md, "Static
// equilibrium").
#include <memory>

#include "core/body.h"
#include "core/collisions.h"
#include "core/contact/self_collisions.h"
#include "core/constraints.h"
#include "core/elastic_forces.h"
#include "core/settings.h"
#include "core/volume_projection.h"
#include "solvers/embedded_tension.h"
#include "solvers/integrator.h"
#include "solvers/potential_terms.h"
#include "solvers/sparse_cholesky.h"
#include "solvers/sparse_hessian.h"
#include "solvers/stepping.h"

namespace goo {

class BackwardEulerIntegrator final : public Integrator {
 public:
  /// `gravity` in m/s² and `tension` from the scene (Scene::gravity,
  /// Scene::surface_tension; goo::Error for the paper form, which is not
  /// the gradient of an energy).
  BackwardEulerIntegrator(BackwardEulerSettings settings, Constraints constraints,
                          const Eigen::Vector3d& gravity = standard_gravity(), SurfaceTensionSettings tension = {});
  ~BackwardEulerIntegrator();

  /// One step of at most min(settings.time_step, max_dt). goo::Error if it
  /// does not converge even after max_halvings halvings.
  StepReport step(Body& body, double max_dt) override;
  /// min(settings.time_step, max_dt).
  double next_time_step(Body& body, double max_dt) override;
  /// Steps to time() + dt (several steps when Newton makes it halve); the
  /// report of them all comes from finish_step, which has nothing left to do.
  void begin_step(Body& body, double dt) override;
  StepReport finish_step(Body& body) override;

  [[nodiscard]] double time() const override { return time_; }
  /// Sets the clock; a static solve takes the body to be in equilibrium
  /// at the loads of time t (none at t = 0).
  void set_time(double t) override;
  /// Forget the lagged factor, so that the next solve refactors: after this
  /// the integrator's results depend on the body's state alone (a restart point).
  void invalidate() override;
  /// settings.time_step (a halved step responds at half the displacement);
  /// a static step is its own reference.
  [[nodiscard]] double reference_step() const override;
  [[nodiscard]] std::string_view failure_advice() const override;
  /// Symbolic factorisations so far (one per mesh topology).
  [[nodiscard]] int symbolic_factorisations() const;
  /// The incremental potential at x for the current step (exposed for tests).
  [[nodiscard]] const SparseHessian& hessian() const { return hessian_; }

 private:
  struct Potential;
  bool try_step(Body& body, double dt, StepReport& status);
  /// Newton with a line search on `potential` from the first guess x;
  /// on convergence the body takes x (and its velocities).
  bool newton(Body& body, Potential& potential, Points& x, StageTimer& timer, StepReport& status);
  /// Static: the equilibrium at the loads of time_ + dt, in load steps.
  void solve_static(Body& body, double dt, StepReport& status);
  /// Static: the gravity's load factor at time t (settings.gravity_ramp).
  [[nodiscard]] double gravity_factor(double t) const;
  /// The Newton direction dx of H dx = rhs at x (H assembled there; its
  /// element and triangle Hessians projected to positive semi-definite once
  /// `project` is set, which an indefinite H or a non-descent direction
  /// sets); false when there is none.
  bool newton_direction(const Body& body, Potential& potential, const Points& x, bool& project,
                        const Eigen::VectorXd& rhs, Eigen::VectorXd& dx, StepReport& status, StageTimer& timer);

  BackwardEulerSettings settings_;
  Eigen::Vector3d gravity_;
  SurfaceTensionSettings tension_settings_;
  Constraints constraints_;
  ElasticForces elastic_;
  SparseHessian hessian_;
  SurfaceCollisions collisions_;
  SelfCollisions self_collisions_;
  VolumeProjection volume_;
  EmbeddedTension tension_;
  SparseCholesky cholesky_;  // its analysis kept per Hessian pattern, its factor lagged
  std::vector<std::uint8_t> fixed_;
  std::vector<Matrix12> blocks_;         // the element Hessians, kept across iterations
  std::vector<Matrix9d> surface_blocks_;  // the surface triangles'
  double time_ = 0.0;
  double loaded_ = 0.0;   // static: the gravity factor the body is in equilibrium with
  double last_dt_ = 0.0;  // the last step's Δt
  StepReport pending_;    // begin_step's steps, until finish_step
  StepTimes times_;  // this step's, by stage
};

}  // namespace goo
