#pragma once
// What every integrator's step and advance_to share.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>

namespace goo {

/// Wall seconds of one step by stage (the profile of docs/benchmarks.md).
struct StepTimes {
  double forces = 0.0;        ///< elastic forces with plastic flow; Newton's gradients and energies
  double damping = 0.0;       ///< Newmark's implicit damping solves
  double hessian = 0.0;       ///< backward Euler: element and surface Hessians, assembly
  double linear_solve = 0.0;  ///< backward Euler: factorisations, solves, conjugate gradients
  double collisions = 0.0;    ///< the ground and the obstacles
  double self_collisions = 0.0;  ///< the embedded surface against itself
  double volume = 0.0;        ///< the incompressibility projection
  double surface = 0.0;       ///< surface tension forces, smoothing and re-embedding
  double other = 0.0;         ///< the time-step choice, updates

  StepTimes& operator+=(const StepTimes& o) {
    forces += o.forces, damping += o.damping, hessian += o.hessian, linear_solve += o.linear_solve;
    collisions += o.collisions, self_collisions += o.self_collisions, volume += o.volume, surface += o.surface;
    other += o.other;
    return *this;
  }
};

/// What Newmark's damping solves, (M + Δt/2 C) v = rhs by conjugate
/// gradients, did.
struct DampingSolveStats {
  std::int64_t solves = 0;
  std::int64_t iterations = 0;  ///< all solves together
  int max_iterations = 0;       ///< the most any one solve took
  double max_residual = 0.0;    ///< the largest final ‖r‖ / ‖rhs‖
  std::int64_t unconverged = 0;  ///< solves stopped by cg_max_iterations
  std::int64_t preconditioners = 0;  ///< solves that computed the preconditioner's blocks anew

  DampingSolveStats& operator+=(const DampingSolveStats& o) {
    solves += o.solves, iterations += o.iterations, unconverged += o.unconverged;
    preconditioners += o.preconditioners;
    max_iterations = std::max(max_iterations, o.max_iterations);
    max_residual = std::max(max_residual, o.max_residual);
    return *this;
  }
};

/// Laps of a steady clock: lap() is the seconds since the last lap.
class StageTimer {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

struct NeverStop {
  bool operator()() const { return false; }
};

/// Calls step(t_end − time) until `time` (the integrator's clock, advanced
/// by each step) reaches t_end, landing on it exactly despite round-off in
/// the sum of steps, or until stop() (asked after each step) says so.
/// Returns the steps taken.
template <class Step, class Stop = NeverStop>
int step_until(double& time, double t_end, Step&& step, Stop&& stop = Stop{}) {
  int steps = 0;
  while (time < t_end) {
    step(t_end - time);
    ++steps;
    if (t_end - time < 1e-12 * std::max(1.0, std::abs(t_end))) time = t_end;
    if (stop()) break;
  }
  return steps;
}

}  // namespace goo
