#pragma once
// What every time integrator of a body offers (Newmark, backward Euler, the
// static solve; docs/architecture.md, "One time step"), and the one report
// of what a step did.
#include <string_view>
#include <vector>

#include "core/body.h"
#include "core/contact/self_collisions.h"
#include "core/volume_projection.h"
#include "solvers/stepping.h"

namespace goo {

/// What one step did (or several, summed: see Integrator::begin_step).
struct StepReport {
  double dt = 0.0;  ///< the step taken, s
  int steps = 1;    ///< integrator steps this report covers
  Index plastic_elements = 0;  ///< elements that flowed plastically in the (last) step
  Index collisions = 0;  ///< element corrections of the embedded surface, positions and velocities
  SelfCollisionStats self_collisions;  ///< the surface against itself
  VolumeProjectionStats volume;        ///< incompressible materials
  StepTimes times;                     ///< wall seconds by stage
  // Newmark: its two damping solves together.
  DampingSolveStats damping;
  // Backward Euler and the static solve: Newton.
  int iterations = 0;         ///< Newton iterations of the accepted attempt (all load steps)
  int line_search_steps = 0;  ///< halvings of the Newton step, all iterations
  int halvings = 0;           ///< retries at half Δt before it converged (static: halvings of the load increment)
  int factorisations = 0;     ///< numerical factorisations, all attempts
  int pcg_iterations = 0;     ///< lagged_pcg: CG iterations, all attempts
  double residual = 0.0;      ///< final ‖∇E‖∞ / force scale
  std::vector<double> residuals;  ///< after each iteration (convergence history)

  /// Adds the report of the step that followed: counts and times summed,
  /// the last residual and plastic count kept, histories joined.
  StepReport& operator+=(const StepReport& next);
};

/// A body's time integrator: its clock, its steps, and what it keeps
/// between steps. A scene's integrator key chooses the implementation.
class Integrator {
 public:
  virtual ~Integrator() = default;

  /// Advances `body` by one step of at most `max_dt` (the time left to the
  /// next frame, say): the step the integrator chooses.
  virtual StepReport step(Body& body, double max_dt) = 0;

  /// The same step in two halves, for bodies stepped together (collisions
  /// between bodies act between them): next_time_step gives the step this
  /// body would take (at most max_dt); begin_step moves the body to the
  /// positions at time() + dt, with contacts and its own self-collisions
  /// (an implicit integrator that must halve takes several steps there);
  /// finish_step completes the velocities and returns the report of all of
  /// it, the clock at time() + dt exactly.
  virtual double next_time_step(Body& body, double max_dt) = 0;
  virtual void begin_step(Body& body, double dt) = 0;
  virtual StepReport finish_step(Body& body) = 0;

  /// Steps until the time reaches t_end exactly; returns the steps taken.
  int advance_to(Body& body, double t_end);

  [[nodiscard]] virtual double time() const = 0;
  virtual void set_time(double t) = 0;
  /// Forgets what is carried from step to step (cached forces, a lagged
  /// factor, a warm start), so that what follows depends on the body's
  /// state alone (a restart point, or after the body changed outside).
  virtual void invalidate() = 0;
  /// The step at which collision responses reach their full size, s
  /// (SelfCollisionParameters::reference_step).
  [[nodiscard]] virtual double reference_step() const = 0;
  /// What a user can change when goo::Error escapes a step (a solve that
  /// found no answer); empty when such an error is not a numerical failure.
  [[nodiscard]] virtual std::string_view failure_advice() const { return {}; }
};

}  // namespace goo
