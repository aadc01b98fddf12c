#pragma once
// The paper's time integrator (Wojtan & Turk 2008, sec. 3; Bridson et al.
// 2003): elastic forces explicit, damping implicit, one elastic force
// evaluation per step, variable time step (algorithms.md, "Time integration").
#include <array>
#include <limits>

#include "core/body.h"
#include "core/collisions.h"
#include "core/contact/self_collisions.h"
#include "core/constraints.h"
#include "core/damping.h"
#include "core/elastic_forces.h"
#include "core/settings.h"
#include "core/surface_tension.h"
#include "core/volume_projection.h"
#include "solvers/embedded_tension.h"
#include "solvers/integrator.h"
#include "solvers/stepping.h"

namespace goo {

class NewmarkIntegrator final : public Integrator {
 public:
  /// `gravity` in m/s² and `tension` from the scene (Scene::gravity, Scene::surface_tension).
  NewmarkIntegrator(NewmarkSettings settings, Constraints constraints,
                    const Eigen::Vector3d& gravity = standard_gravity(), SurfaceTensionSettings tension = {});

  /// One step of at most `max_dt`, chosen as the minimum of the CFL bound,
  /// the strain-rate bound and max_time_step: next_time_step, begin_step
  /// (to xⁿ⁺¹ with v½, contacts and self-collisions included) and
  /// finish_step (the forces at xⁿ⁺¹, vⁿ⁺¹) in a row.
  StepReport step(Body& body, double max_dt) override;
  double next_time_step(Body& body, double max_dt) override;
  void begin_step(Body& body, double dt) override;
  StepReport finish_step(Body& body) override;

  [[nodiscard]] double time() const override { return time_; }
  void set_time(double t) override { time_ = t; }
  /// Forget cached forces (after the body's mesh or state changed outside).
  void invalidate() override {
    have_forces_ = false;
    blocks_fresh_ = false;
    volume_.reset();
    for (Points& last : last_solutions_) last.resize(0, 3);  // no warm start: the next steps depend on the body's state alone
  }

  /// The time step the next step would take if unlimited by max_dt.
  double stable_time_step(Body& body);
  /// The last stable_time_step without its strain-rate bound (the elastic
  /// and capillary bounds and max_time_step): the step at which collision
  /// responses reach their full size.
  [[nodiscard]] double reference_step() const override { return reference_step_; }

 private:
  void ensure_forces(Body& body);
  /// Elastic forces at x (with plastic flow over plastic_dt), plus surface
  /// tension mapped to the nodes with the barycentric weights.
  void evaluate_forces(Body& body, double plastic_dt);
  void apply_gravity_and_forces(const Body& body, const Points& v, double half_dt, Points& rhs) const;
  /// Solves (M + h C) v = rhs for the free nodes, v fixed at constrained
  /// ones; `half` is the step's first (0, v½) or second (1, vⁿ⁺¹) solve.
  void solve_damped(const Body& body, double h, const Points& rhs, Points& v, StepReport& status, int half);
  /// solve_damped's CG on a right-hand side scaled to about unit size.
  void remove_net_residual(const Body& body, const Points& r, Points& v) const;
  void solve_scaled(const Body& body, double h, const Points& rhs, const Points* guess, Points& v, StepReport& status);
  void impose_velocities(const Body& body, double t_next, double dt, Points& v) const;

  NewmarkSettings settings_;
  Eigen::Vector3d gravity_;
  SurfaceTensionSettings tension_settings_;
  Constraints constraints_;
  ElasticForces elastic_;
  Damping damping_;
  SurfaceCollisions collisions_;
  SelfCollisions self_collisions_;
  VolumeProjection volume_;
  EmbeddedTension tension_;
  Points forces_;  // f_e at the current positions
  StepTimes times_;  // this step's, by stage
  StepReport pending_;  // the step begun, until finished
  double step_dt_ = 0.0;
  double reference_step_ = 0.0;
  bool have_forces_ = false;
  double time_ = 0.0;
  std::vector<unsigned char> constrained_;
  // CG work arrays, kept across steps.
  Points r_, z_, p_, Ap_, trial_, r_trial_, z_trial_;
  Points scaled_rhs_, scaled_guess_;    // solve_damped's right-hand side and warm start, scaled
  static constexpr Index kCgRun = 256;  // nodes a run of the CG's passes
  std::vector<double> run_sums_;        // per run, its share of a pass's sums
  /// Each half step's last damping solution, m/s (the next step's warm start for that half).
  std::array<Points, 2> last_solutions_;
  std::vector<Eigen::Matrix3d> blocks_;          // C's diagonal blocks at an Fe since which strain_since_blocks_
  std::vector<Eigen::Matrix3d> inverse_blocks_;  // the solve's preconditioner (m I + h C_nn)⁻¹
  double inverse_h_ = std::numeric_limits<double>::quiet_NaN();  // the h of inverse_blocks_ (of blocks_ as they are)
  bool blocks_fresh_ = false;                    // false: blocks_ are of another body (or none)
  double strain_since_blocks_ = 0.0;             // Σ ‖Ḟ‖ Δt over the steps since blocks_ were computed
  int evaluations_since_blocks_ = 0;             // force evaluations since blocks_ were computed
  double step_strain_ = 0.0;                     // ‖Ḟ‖ Δt of the step begun, until its force evaluation
  double strain_rate_ = 0.0;                     // max ‖Ḟ‖ at the step's start, 1/s
  bool have_strain_rate_ = false;                // strain_rate_ measured by stable_time_step for this step
};

}  // namespace goo
