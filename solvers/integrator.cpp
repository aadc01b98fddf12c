#include "solvers/integrator.h"

namespace goo {

StepReport& StepReport::operator+=(const StepReport& next) {
  dt += next.dt;
  steps += next.steps;
  plastic_elements = next.plastic_elements;
  collisions += next.collisions;
  self_collisions += next.self_collisions;
  volume += next.volume;
  times += next.times;
  damping += next.damping;
  iterations += next.iterations;
  line_search_steps += next.line_search_steps;
  halvings += next.halvings;
  factorisations += next.factorisations;
  pcg_iterations += next.pcg_iterations;
  residual = next.residual;
  residuals.insert(residuals.end(), next.residuals.begin(), next.residuals.end());
  return *this;
}

int Integrator::advance_to(Body& body, double t_end) {
  double t = time();
  const int steps = step_until(t, t_end, [&](double max_dt) {
    step(body, max_dt);
    t = time();
  });
  set_time(t);  // exactly t_end, as step_until landed it
  return steps;
}

}  // namespace goo
