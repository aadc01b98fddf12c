#pragma once
// What every integrator's advance_to shares.
#include <algorithm>
#include <cmath>

namespace goo {

/// Calls step(t_end − time) until `time` (the integrator's clock, advanced
/// by each step) reaches t_end, landing on it exactly despite round-off in
/// the sum of steps. Returns the steps taken.
template <class Step>
int step_until(double& time, double t_end, Step&& step) {
  int steps = 0;
  while (time < t_end) {
    step(t_end - time);
    ++steps;
    if (t_end - time < 1e-12 * std::max(1.0, std::abs(t_end))) time = t_end;
  }
  return steps;
}

}  // namespace goo
