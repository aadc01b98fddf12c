#include "solvers/backward_euler.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

#include "core/error.h"
#include "solvers/stepping.h"
#include "core/log.h"
#include "core/parallel.h"

namespace goo {

BackwardEulerIntegrator::BackwardEulerIntegrator(BackwardEulerSettings settings, Constraints constraints,
                                                 const Eigen::Vector3d& gravity, SurfaceTensionSettings tension)
    : settings_(std::move(settings)), gravity_(gravity), tension_settings_(tension),
      constraints_(std::move(constraints)) {
  if (tension_settings_.form != SurfaceTensionForm::area_gradient)
    throw Error("surface_tension.form: backward Euler minimises an energy, and only the area_gradient form is the "
                "gradient of one");
  if (!(settings_.volume_tolerance > 0.0 && settings_.volume_tolerance < 0.1)) {
    throw Error(
        fmt::format("backward_euler.volume_tolerance must be in (0, 0.1), got {}", settings_.volume_tolerance));
  }
  volume_ = VolumeProjection(VolumeProjectionSettings{settings_.volume_tolerance});
  if (!(settings_.time_step > 0.0) || !std::isfinite(settings_.time_step))
    throw Error(fmt::format("backward_euler.time_step must be positive, got {}", settings_.time_step));
}

BackwardEulerIntegrator::~BackwardEulerIntegrator() = default;

void BackwardEulerIntegrator::invalidate() {
  cholesky_.forget_factor();
  volume_.reset();
}

int BackwardEulerIntegrator::symbolic_factorisations() const { return cholesky_.analyses(); }

namespace {

double max_abs_free(const Points& g, const std::vector<std::uint8_t>& fixed) {
  double m = 0.0;
  for (Index n = 0; n < g.rows(); ++n)
    if (!fixed[at(n)]) m = std::max(m, g.row(n).cwiseAbs().maxCoeff());
  return m;
}

}  // namespace

/// The incremental potential of one step and its gradient (algorithms.md,
/// "Time integration"): E(y) = ½‖y − x̂‖²_M/Δt² + Ψ(y) + σA(Wy) + Δt/2 vᵀCv,
/// v = (y − xⁿ)/Δt, C_e with Fe frozen at xⁿ; an incompressible material's
/// carried pressure force joins gravity in x̂ as a load constant over the step.
/// Static (settings.statics): the potential energy Π(y) = Ψ(y) + σA(Wy) −
/// Σ m_n γ g·y_n alone, γ the gravity's load factor (docs/implicit.md,
/// "Static equilibrium"). The sum of the terms of solvers/potential_terms.h,
/// the elastic and surface terms first (their forces are what the scale of
/// the residual is measured against).
struct BackwardEulerIntegrator::Potential {
  Potential(BackwardEulerIntegrator& integrator, Body& body_, double dt_, double gravity_factor = 1.0)
      : body(body_), fixed(integrator.fixed_), dt(dt_), xn(body_.positions), statics(integrator.settings_.statics),
        with_tension(EmbeddedTension::active(body_)), elasticity(body_, integrator.elastic_),
        tension(body_, integrator.tension_) {
    const Index nn = body.num_nodes();
    const Eigen::VectorXd& m = body.masses;
    gradient.resize(nn, 3);
    // Surface tension (W&T sec. 7) as the energy σ A(W x) (algorithms.md,
    // "Surface tension"): its Hessian couples the nodes of each triangle's
    // corners' parents, which the pattern (surface_nodes) includes.
    if (with_tension) surface_nodes = SurfaceNodes::of(body);
    terms.push_back(&elasticity);
    if (with_tension) terms.push_back(&tension);
    conservative = terms.size();
    if (statics) {
      load.emplace(body, gravity_factor * integrator.gravity_);
      terms.push_back(&*load);
      return;
    }
    Points target = xn + dt * body.velocities;
    target.rowwise() += dt * dt * integrator.gravity_.transpose();
    if (body.material.incompressible) {
      Points pressure = Points::Zero(nn, 3);
      integrator.volume_.add_pressure_forces(body, xn, pressure);
      for (Index n = 0; n < nn; ++n)
        if (m[n] > 0.0) target.row(n) += (dt * dt / m[n]) * pressure.row(n);
    }
    inertia.emplace(body, std::move(target), dt);
    terms.push_back(&*inertia);
    if (body.material.viscosity > 0.0) {
      damping.emplace(body, xn, dt);
      terms.push_back(&*damping);
    }
  }

  /// The elastic and surface forces at y.
  void forces(const Points& y, Points& out) {
    out.setZero(body.num_nodes(), 3);
    for (std::size_t k = 0; k < conservative; ++k) terms[k]->add_forces(y, out);
  }

  double energy(const Points& y) {
    double E = 0.0;
    for (PotentialTerm* term : terms) E += term->value(y);
    return E;
  }

  /// ∇E(y) into `gradient`, zero at the fixed nodes.
  void evaluate_gradient(const Points& y) {
    f.setZero(body.num_nodes(), 3);
    for (PotentialTerm* term : terms) term->add_forces(y, f);
    gradient = -f;
    for (Index n = 0; n < body.num_nodes(); ++n)
      if (fixed[at(n)]) gradient.row(n).setZero();
  }

  /// The Hessian's parts at y, every term's added in order.
  void add_hessian(const Points& y, HessianParts& parts) {
    parts.diagonal.setZero(3 * body.num_nodes());
    for (PotentialTerm* term : terms) term->add_hessian(y, parts);
  }

  /// x̂ (dynamics), where Newton starts.
  [[nodiscard]] const Points& target() const { return inertia->target(); }

  /// The force scale residuals are measured against: gravity on the
  /// heaviest node, elastic and surface forces at xⁿ, the inertial force
  /// m|v|/Δt (the only one for a stress-free body thrown without gravity),
  /// and, with nodes moved along a path, their load at the first guess x (a
  /// body at rest without gravity, pulled by its faces, has no other force).
  double force_scale(const Points& x, double gravity, bool driven_nodes) {
    const Eigen::VectorXd& m = body.masses;
    forces(xn, f);
    double inertial = 0.0;  // none in a static solve
    for (Index n = 0; n < body.num_nodes() && !statics; ++n)
      if (!fixed[at(n)]) inertial = std::max(inertial, m[n] * body.velocities.row(n).norm() / dt);
    double driven = 0.0;
    if (driven_nodes) {
      forces(x, scratch);
      driven = max_abs_free(scratch, fixed);
    }
    return std::max({m.maxCoeff() * gravity, max_abs_free(f, fixed), inertial, driven, 1e-300});
  }

  Body& body;
  const std::vector<std::uint8_t>& fixed;
  double dt;
  Points xn;
  bool statics, with_tension;
  ElasticityTerm elasticity;
  TensionTerm tension;
  std::optional<InertiaTerm> inertia;
  std::optional<DampingTerm> damping;
  std::optional<LoadTerm> load;
  std::vector<PotentialTerm*> terms;  // in summation order
  std::size_t conservative = 0;       // terms[0, conservative): the elastic and surface forces
  SurfaceNodes surface_nodes;
  Points f, gradient, scratch;
};

bool BackwardEulerIntegrator::newton_direction(const Body& body, Potential& potential, const Points& x,
                                               bool& project, const Eigen::VectorXd& rhs, Eigen::VectorXd& dx,
                                               StepReport& status, StageTimer& timer) {
  // H = M/Δt² + Σ K_e + Σ C_e/Δt + Σ_t Wₜᵀ σ∂²Aₜ Wₜ. The element and
  // triangle Hessians are first taken as they are: M/Δt² usually keeps the sum positive definite, and then
  // Newton converges quadratically. Only if the factorisation finds H
  // indefinite, or the step is not a descent direction, are they projected
  // to positive semi-definite (K_e⁺) for the rest of the step. (Projecting
  // always slows Newton to a linear rate, 0.77 per iteration measured on a
  // stiff cube resting on the floor: compressed elements have slightly
  // indefinite fixed-corotated Hessians.)
  const Index nn = body.num_nodes();
  Eigen::VectorXd diagonal(3 * nn);
  bool solved = false;
  for (int attempt = 0; attempt < 2 && !solved; ++attempt) {
    if (attempt > 0) {
      if (project) break;
      project = true;
    }
    timer.lap();
    HessianParts parts{blocks_, diagonal, surface_blocks_, project};
    potential.add_hessian(x, parts);
    hessian_.assemble(blocks_, diagonal);
    if (potential.with_tension) hessian_.add_surface(potential.surface_nodes, surface_blocks_);
    hessian_.fix_nodes(fixed_);
    times_.hessian += timer.lap();
    const int pattern = hessian_.builds();
    if (!cholesky_.analysed_for(pattern)) cholesky_.analyse(hessian_.matrix(), pattern);
    const bool lagged = settings_.linear_solver == LinearSolver::lagged_pcg ||
                        (settings_.linear_solver == LinearSolver::automatic && 3L * nn > kLaggedPcgUnknowns);
    // CG preconditioned by the last factor, to relative residual 1e-10 (Newton needs no more).
    bool have = lagged && cholesky_.has_factor_for(pattern) &&
                cholesky_.preconditioned_cg(hessian_.matrix(), rhs, dx, 1e-10, settings_.pcg_max_iterations,
                                            status.pcg_iterations);
    if (!have) {
      ++status.factorisations;
      if (!cholesky_.factor(hessian_.matrix(), pattern)) continue;  // indefinite: project
      have = cholesky_.solve(rhs, dx);
    }
    solved = have && dx.allFinite() && rhs.dot(dx) > 0.0;  // a descent direction
    times_.linear_solve += timer.lap();
  }
  return solved;
}

namespace {

/// Backtracking (Armijo) on E along the Newton direction from x: x and E
/// become the accepted point and its energy. Once the predicted decrease is
/// below what E resolves (its terms carry relative round-off near 1e-13: ψ
/// of F ≈ I loses digits to σ − 1), the energy cannot judge a step any more
/// and the full Newton step is taken: the system is positive definite and
/// the step already tiny. False when twenty halvings do not decrease E.
template <class Energy>
bool line_search(Energy&& energy, const Eigen::Map<const Points>& step, double slope, Points& x, double& E,
                 StepReport& status) {
  double alpha = 1.0;
  Points trial = x + step;
  const bool below_resolution = -slope <= 1e-10 * std::abs(E);
  if (below_resolution) E = energy(trial);
  for (int ls = 0; ls < 20 && !below_resolution; ++ls) {
    trial = x + alpha * step;
    const double trial_E = energy(trial);
    if (std::isfinite(trial_E) && trial_E <= E + 1e-4 * alpha * slope) {
      E = trial_E;
      break;
    }
    alpha *= 0.5;
    ++status.line_search_steps;
    if (ls == 19) return false;
  }
  x = trial;
  return true;
}

}  // namespace

bool BackwardEulerIntegrator::try_step(Body& body, double dt, StepReport& status) {
  StageTimer timer;
  const Points& xn = body.positions;
  const double t_next = time_ + dt;
  Potential potential(*this, body, dt);
  // The first guess: x̂, the constrained nodes at their positions at t_next.
  Points x = potential.target();
  for (const Index n : constraints_.pinned) x.row(n) = xn.row(n);
  for (const auto& motion : constraints_.prescribed)
    for (const Index n : motion.nodes)
      x.row(n) = motion.position(n, body.rest_positions.row(n).transpose(), t_next).transpose();
  return newton(body, potential, x, timer, status);
}

bool BackwardEulerIntegrator::newton(Body& body, Potential& potential, Points& x, StageTimer& timer,
                                     StepReport& status) {
  const Index nn = body.num_nodes();
  const Points& xn = potential.xn;
  const double scale = potential.force_scale(x, gravity_.norm(), !constraints_.prescribed.empty());
  times_.forces += timer.lap();
  if (!hessian_.matches(body.tets, nn, potential.surface_nodes.nodes))
    hessian_.build(body.tets, nn, potential.surface_nodes.nodes);

  status = StepReport{};
  status.dt = potential.dt;
  double E = potential.energy(x);
  bool project = false;
  times_.hessian += timer.lap();
  auto accept = [&](double residual, int iterations) {
    status.residual = residual;
    status.iterations = iterations;
    if (potential.statics)
      body.velocities.setZero(nn, 3);
    else
      body.velocities = (x - xn) / potential.dt;
    body.positions = x;
    return true;
  };
  for (int iteration = 0; iteration < settings_.max_newton_iterations; ++iteration) {
    potential.evaluate_gradient(x);
    times_.forces += timer.lap();
    const double residual = max_abs_free(potential.gradient, fixed_) / scale;
    if (!std::isfinite(residual) || !std::isfinite(E)) return false;
    status.residual = residual;
    status.residuals.push_back(residual);
    if (residual <= settings_.tolerance) return accept(residual, iteration);
    const Eigen::VectorXd rhs = -Eigen::Map<const Eigen::VectorXd>(potential.gradient.data(), 3 * nn);
    Eigen::VectorXd dx;
    if (!newton_direction(body, potential, x, project, rhs, dx, status, timer)) return false;
    const Eigen::Map<const Points> step(dx.data(), nn, 3);
    if (!line_search([&](const Points& y) { return potential.energy(y); }, step, -rhs.dot(dx), x, E, status))
      return false;
    times_.forces += timer.lap();  // the line search's energies
  }
  // The iterations ran out: accept a residual below acceptable_tolerance.
  potential.evaluate_gradient(x);
  const double residual = max_abs_free(potential.gradient, fixed_) / scale;
  if (std::isfinite(residual) && residual <= settings_.acceptable_tolerance) {
    log().debug("backward_euler: accepted Δt = {} s at residual {:.3g} after {} iterations", potential.dt, residual,
                settings_.max_newton_iterations);
    status.residuals.push_back(residual);
    return accept(residual, settings_.max_newton_iterations);
  }
  return false;
}

StepReport BackwardEulerIntegrator::step(Body& body, double max_dt) {
  fixed_.assign(at(body.num_nodes()), 0);
  for (const Index n : constraints_.pinned) fixed_[at(n)] = 1;
  for (const auto& motion : constraints_.prescribed)
    for (const Index n : motion.nodes) fixed_[at(n)] = 1;
  times_ = StepTimes{};
  double dt = std::min(settings_.time_step, max_dt);
  if (!(dt > 0.0)) throw Error(fmt::format("backward_euler: non-positive time step {} s", dt));
  const Points x0 = body.positions, v0 = body.velocities;
  StepReport status;
  if (settings_.statics) {
    solve_static(body, dt, status);
  } else {
    int halvings = 0;
    while (!try_step(body, dt, status)) {
      body.positions = x0;
      body.velocities = v0;
      if (++halvings > settings_.max_halvings)
        throw Error(fmt::format("backward_euler: Newton did not converge at t = {} s even with Δt = {} s", time_, dt));
      log().debug("backward_euler: Newton did not converge with Δt = {} s ({} line-search halvings; residuals {:.3g}); halving", dt, status.line_search_steps,
                  fmt::join(status.residuals, ", "));
      dt *= 0.5;
    }
    status.halvings = halvings;
  }
  StageTimer timer;
  // Incompressible materials: xⁿ⁺¹ and vⁿ⁺¹ projected so that every node
  // keeps its volume (Irving et al. 2007).
  if (body.material.incompressible) status.volume = volume_.project(body, x0, fixed_, dt, dt);
  times_.volume += timer.lap();
  // Smoothing (W&T sec. 7, as Newmark's), plastic flow after convergence,
  // then the surface collisions.
  if (tension_settings_.smoothing > 0.0 && EmbeddedTension::active(body))
    tension_.smooth(body, std::min(0.5, tension_settings_.smoothing * body.material.surface_tension * dt));
  times_.surface += timer.lap();
  Points f;
  elastic_.evaluate(body, body.positions, dt, f);
  status.plastic_elements = elastic_.plastic_elements();
  times_.forces += timer.lap();
  const double t_next = time_ + dt;
  double restoring = 0.0;  // incompressible: the volume the contacts take given back at once
  status.collisions += body.material.incompressible
                           ? resolve_positions_keeping_volume(body, collisions_, volume_, constraints_.obstacles, t_next,
                                                              fixed_, status.volume, restoring)
                                 .resolved
                           : collisions_.resolve_positions(body, constraints_.obstacles, t_next, fixed_).resolved;
  status.collisions +=
      collisions_.resolve_velocities(body, body.velocities, constraints_.obstacles, t_next, dt, fixed_).resolved;
  times_.volume += restoring;
  times_.collisions += timer.lap() - restoring;
  last_dt_ = dt;  // reference_step() of a static step is the step itself
  if (constraints_.self_collisions) {
    SelfCollisionParameters parameters = *constraints_.self_collisions;
    parameters.reference_step = reference_step();
    status.self_collisions = self_collisions_.resolve_step(body, x0, dt, fixed_, parameters);
  }
  times_.self_collisions += timer.lap();
  time_ = t_next;
  status.times = times_;
  return status;
}

double BackwardEulerIntegrator::gravity_factor(double t) const {
  return settings_.gravity_ramp > 0.0 ? std::min(1.0, t / settings_.gravity_ramp) : 1.0;
}

void BackwardEulerIntegrator::set_time(double t) {
  time_ = t;
  // A body at t = 0 is at rest in its rest shape: in equilibrium without load.
  loaded_ = t > 0.0 ? gravity_factor(t) : 0.0;
}

void BackwardEulerIntegrator::solve_static(Body& body, double dt, StepReport& status) {
  bool any_fixed = false;
  for (const std::uint8_t f : fixed_) any_fixed = any_fixed || f != 0;
  if (!any_fixed)
    throw Error("static: the body has no pinned or moved nodes, so it has no equilibrium under its loads (pin a "
                "region of it, or use the backward_euler integrator)");
  if (body.material.incompressible)
    throw Error("static: incompressible materials are not supported by the static solve");
  // Load steps (docs/implicit.md, "Static equilibrium"): from the last
  // equilibrium (load factor s = 0) to this step's loads (s = 1), the moved
  // nodes' positions and the gravity factor interpolated linearly; an
  // increment Newton does not converge on is halved.
  const double t_next = time_ + dt;
  const double from = loaded_, to = gravity_factor(t_next);
  const Points x_from = body.positions;
  status = StepReport{};
  status.dt = dt;
  double s = 0.0, ds = 1.0;
  while (s < 1.0) {
    const double s_next = std::min(1.0, s + ds);
    StageTimer timer;
    Potential potential(*this, body, dt, from + s_next * (to - from));
    Points x = body.positions;
    for (const auto& motion : constraints_.prescribed)
      for (const Index n : motion.nodes) {
        const Eigen::Vector3d end = motion.position(n, body.rest_positions.row(n).transpose(), t_next);
        x.row(n) = ((1.0 - s_next) * x_from.row(n).transpose() + s_next * end).transpose();
      }
    StepReport attempt;
    const bool converged = newton(body, potential, x, timer, attempt);
    status.iterations += attempt.iterations;
    status.line_search_steps += attempt.line_search_steps;
    status.factorisations += attempt.factorisations;
    status.pcg_iterations += attempt.pcg_iterations;
    status.residual = attempt.residual;
    status.residuals.insert(status.residuals.end(), attempt.residuals.begin(), attempt.residuals.end());
    if (converged) {
      s = s_next;
      continue;
    }
    if (++status.halvings > settings_.max_halvings)
      throw Error(fmt::format("static: no equilibrium found at t = {} s even in load steps of 1/{} (residuals {:.3g})",
                              t_next, 1L << settings_.max_halvings, fmt::join(attempt.residuals, ", ")));
    log().debug("static: Newton did not converge on the load step {} -> {}; halving it", s, s_next);
    ds *= 0.5;
  }
  loaded_ = to;
}

double BackwardEulerIntegrator::next_time_step(Body& /*body*/, double max_dt) {
  return std::min(settings_.time_step, max_dt);
}

void BackwardEulerIntegrator::begin_step(Body& body, double dt) {
  const double t_end = time_ + dt;
  pending_ = StepReport{};
  pending_.steps = 0;
  double t = time_;
  step_until(t, t_end, [&](double left) {
    pending_ += step(body, left);
    t = time_;
  });
  set_time(t_end);
}

StepReport BackwardEulerIntegrator::finish_step(Body& /*body*/) { return std::exchange(pending_, StepReport{}); }

double BackwardEulerIntegrator::reference_step() const {
  return settings_.statics ? last_dt_ : settings_.time_step;
}

std::string_view BackwardEulerIntegrator::failure_advice() const {
  return settings_.statics ? "a larger max_halvings or more max_newton_iterations"
                           : "a smaller backward_euler.time_step or more max_newton_iterations";
}

}  // namespace goo
