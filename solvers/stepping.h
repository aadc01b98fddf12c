#pragma once
// What every integrator's advance_to shares.
#include <algorithm>
#include <cmath>

namespace goo {

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
