#include "solvers/backward_euler.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/CholmodSupport>
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "solvers/stepping.h"
#include "core/log.h"
#include "core/parallel.h"
#include "solvers/linear_algebra_threads.h"

namespace goo {

struct BackwardEulerIntegrator::Factor {
  // A factor that fails (not positive definite) comes back as info(), which
  // the Newton loop handles; CHOLMOD's own warnings on stderr are silenced.
  Factor() { llt.cholmod().print = 0; }
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt;
  int symbolic = 0;
  int analysed_for = -1;  // SparseHessian::builds() when last analysed
  int factored_for = -1;  // the same, for the last numerical factor (the lagged preconditioner)
};

bool BackwardEulerIntegrator::lagged_pcg(const Eigen::VectorXd& b, Eigen::VectorXd& x, NewtonStatus& status) {
  // CG on the lower-triangle-stored symmetric H, preconditioned by the last
  // factor: x₀ = L⁻ᵀL⁻¹ b, stop at relative residual 1e-10 (Newton needs no more).
  const auto H = hessian_.matrix().selfadjointView<Eigen::Lower>();
  x = factor_->llt.solve(b);
  Eigen::VectorXd r = b - H * x;
  const double b_norm = b.norm();
  if (b_norm == 0.0) return true;
  Eigen::VectorXd z = factor_->llt.solve(r), p = z, Ap;
  double rz = r.dot(z);
  for (int k = 0; k < settings_.pcg_max_iterations; ++k) {
    if (r.norm() <= 1e-10 * b_norm) return true;
    Ap = H * p;
    const double curvature = p.dot(Ap);
    if (!(curvature > 0.0)) return false;  // H is not positive definite along p
    const double alpha = rz / curvature;
    x += alpha * p;
    r -= alpha * Ap;
    ++status.pcg_iterations;
    z = factor_->llt.solve(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return r.norm() <= 1e-10 * b_norm;
}

BackwardEulerIntegrator::BackwardEulerIntegrator(BackwardEulerSettings settings, Constraints constraints)
    : settings_(std::move(settings)), constraints_(std::move(constraints)), factor_(std::make_unique<Factor>()) {
  if (!(settings_.volume_tolerance > 0.0 && settings_.volume_tolerance < 0.1)) {
    throw Error(
        fmt::format("backward_euler.volume_tolerance must be in (0, 0.1), got {}", settings_.volume_tolerance));
  }
  volume_ = VolumeProjection(VolumeProjectionSettings{settings_.volume_tolerance});
  // One BLAS thread: TBB already runs the assembly on every core, and BLAS
  // threads spinning next to TBB's workers cost more than they bring.
  static const bool configured = [] {
    set_linear_algebra_threads(1);
    return true;
  }();
  (void)configured;
  if (!(settings_.time_step > 0.0) || !std::isfinite(settings_.time_step))
    throw Error(fmt::format("backward_euler.time_step must be positive, got {}", settings_.time_step));
}

BackwardEulerIntegrator::~BackwardEulerIntegrator() = default;

void BackwardEulerIntegrator::invalidate() {
  factor_->factored_for = -1;
  volume_.reset();
}

int BackwardEulerIntegrator::symbolic_factorisations() const { return factor_->symbolic; }

namespace {

double max_abs_free(const Points& g, const std::vector<std::uint8_t>& fixed) {
  double m = 0.0;
  for (Index n = 0; n < g.rows(); ++n)
    if (!fixed[at(n)]) m = std::max(m, g.row(n).cwiseAbs().maxCoeff());
  return m;
}

/// out = Σ_e C_e v_e, gathered in element order.
void apply_blocks(const Body& body, const std::vector<Matrix12>& C, const Points& v, Points& out) {
  out.setZero(body.num_nodes(), 3);
  for (Index e = 0; e < body.num_elements(); ++e) {
    Eigen::Matrix<double, 12, 1> ve;
    for (int k = 0; k < 4; ++k) ve.segment<3>(3 * k) = v.row(body.tets(e, k)).transpose();
    const Eigen::Matrix<double, 12, 1> f = C[at(e)] * ve;
    for (int k = 0; k < 4; ++k) out.row(body.tets(e, k)) += f.segment<3>(3 * k).transpose();
  }
}

}  // namespace

bool BackwardEulerIntegrator::try_step(Body& body, double dt, NewtonStatus& status) {
  StageTimer timer;
  const Index nn = body.num_nodes(), ne = body.num_elements();
  const Eigen::VectorXd& m = body.masses;
  const Points xn = body.positions, vn = body.velocities;
  const double t_next = time_ + dt;

  // Inertia target and the constrained nodes' positions at t_next; an
  // incompressible material's carried pressure force joins gravity as a
  // load constant over the step.
  Points target = xn + dt * vn;
  target.rowwise() += dt * dt * settings_.gravity.transpose();
  if (body.material.incompressible) {
    Points pressure = Points::Zero(nn, 3);
    volume_.add_pressure_forces(body, xn, pressure);
    for (Index n = 0; n < nn; ++n)
      if (m[n] > 0.0) target.row(n) += (dt * dt / m[n]) * pressure.row(n);
  }
  Points x = target;
  for (const Index n : constraints_.pinned) x.row(n) = xn.row(n);
  for (const auto& motion : constraints_.prescribed)
    for (const Index n : motion.nodes)
      x.row(n) = motion.position(n, body.rest_positions.row(n).transpose(), t_next).transpose();

  // Viscosity: C_e with Fe frozen at xⁿ (damping is linear in v: one matrix a step).
  const bool viscous = body.material.viscosity > 0.0;
  std::vector<Matrix12> damping(viscous ? at(ne) : 0);
  if (viscous) {
    tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
      for (Index e = r.begin(); e != r.end(); ++e) {
        const Eigen::Matrix3d Fe = deformation_gradient(body, xn, e) * body.Fp[at(e)].inverse();
        damping[at(e)] = element_damping_matrix(body, Fe, e);
      }
    });
  }
  // Surface tension (W&T sec. 7) as the energy σ A(W x) (algorithms.md,
  // "Surface tension"): its Hessian couples the nodes of each triangle's
  // corners' parents, which the pattern includes.
  const bool tension = EmbeddedTension::active(body);
  const SurfaceNodes surface_nodes = tension ? SurfaceNodes::of(body) : SurfaceNodes{};
  std::vector<Matrix9d> surface_blocks;
  auto forces = [&](const Points& y, Points& out) {
    elastic_.evaluate(body, y, 0.0, out);
    if (tension) tension_.add_forces(body, y, SurfaceTensionForm::area_gradient, out);
  };
  Points scratch;
  auto energy = [&](const Points& y) {
    double inertia = 0.0;
    for (Index n = 0; n < nn; ++n) inertia += m[n] * (y.row(n) - target.row(n)).squaredNorm();
    double dissipation = 0.0;
    if (viscous) {
      const Points v = (y - xn) / dt;
      apply_blocks(body, damping, v, scratch);
      dissipation = 0.5 * dt * (v.array() * scratch.array()).sum();
    }
    const double surface = tension ? EmbeddedTension::energy(body, y) : 0.0;
    return 0.5 * inertia / (dt * dt) + elastic_energy(body, y) + surface + dissipation;
  };
  Points f, gradient(nn, 3), damping_force;
  auto evaluate_gradient = [&](const Points& y) {
    forces(y, f);
    for (Index n = 0; n < nn; ++n) gradient.row(n) = m[n] * (y.row(n) - target.row(n)) / (dt * dt) - f.row(n);
    if (viscous) {
      apply_blocks(body, damping, (y - xn) / dt, damping_force);
      gradient += damping_force;
    }
    for (Index n = 0; n < nn; ++n)
      if (fixed_[at(n)]) gradient.row(n).setZero();
  };

  // Force scale of the scene: gravity on the heaviest node, elastic and
  // surface forces at xⁿ, and the inertial force m|v|/Δt (the only one for
  // a stress-free body thrown without gravity).
  forces(xn, f);
  double inertia = 0.0;
  for (Index n = 0; n < nn; ++n)
    if (!fixed_[at(n)]) inertia = std::max(inertia, m[n] * body.velocities.row(n).norm() / dt);
  double driven = 0.0;
  if (!constraints_.prescribed.empty()) {
    // Nodes moved along a path load the body at the first guess: a body at
    // rest without gravity, pulled by its faces, has no other force.
    forces(x, scratch);
    driven = max_abs_free(scratch, fixed_);
  }
  const double scale =
      std::max({m.maxCoeff() * settings_.gravity.norm(), max_abs_free(f, fixed_), inertia, driven, 1e-300});

  times_.forces += timer.lap();
  if (!hessian_.matches(body.tets, nn, surface_nodes.nodes)) hessian_.build(body.tets, nn, surface_nodes.nodes);
  if (factor_->analysed_for != hessian_.builds()) factor_->analysed_for = -1;
  std::vector<Matrix12> blocks(at(ne));
  Eigen::VectorXd diagonal(3 * nn);
  for (Index n = 0; n < nn; ++n) diagonal.segment<3>(3 * n).setConstant(m[n] / (dt * dt));

  status = NewtonStatus{};
  status.dt = dt;
  double E = energy(x);
  bool project = false;
  times_.hessian += timer.lap();
  for (int iteration = 0; iteration < settings_.max_newton_iterations; ++iteration) {
    evaluate_gradient(x);
    times_.forces += timer.lap();
    const double residual = max_abs_free(gradient, fixed_) / scale;
    if (!std::isfinite(residual) || !std::isfinite(E)) return false;
    status.residual = residual;
    status.residuals.push_back(residual);
    if (residual <= settings_.tolerance) {
      status.iterations = iteration;
      body.velocities = (x - xn) / dt;
      body.positions = x;
      return true;
    }
    // H = M/Δt² + Σ K_e + Σ C_e/Δt + Σ_t Wₜᵀ σ∂²Aₜ Wₜ. The element and
    // triangle Hessians are first taken as they are: M/Δt² usually keeps the sum positive definite, and then
    // Newton converges quadratically. Only if the factorisation finds H
    // indefinite, or the step is not a descent direction, are they projected
    // to positive semi-definite (K_e⁺) for the rest of the step. (Projecting
    // always slows Newton to a linear rate, 0.77 per iteration measured on a
    // stiff cube resting on the floor: compressed elements have slightly
    // indefinite fixed-corotated Hessians.)
    const Eigen::VectorXd rhs = -Eigen::Map<const Eigen::VectorXd>(gradient.data(), 3 * nn);
    Eigen::VectorXd dx;
    bool solved = false;
    for (int attempt = 0; attempt < 2 && !solved; ++attempt) {
      if (attempt > 0) {
        if (project) break;
        project = true;
      }
      timer.lap();
      tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
        for (Index e = r.begin(); e != r.end(); ++e) {
          blocks[at(e)] = element_elastic_hessian(body, x, e, project);
          if (viscous) blocks[at(e)] += damping[at(e)] / dt;
        }
      });
      hessian_.assemble(blocks, diagonal);
      if (tension) {
        EmbeddedTension::triangle_hessians(body, x, project, surface_blocks);
        hessian_.add_surface(surface_nodes, surface_blocks);
      }
      hessian_.fix_nodes(fixed_);
      times_.hessian += timer.lap();
      if (factor_->analysed_for < 0) {
        factor_->llt.analyzePattern(hessian_.matrix());
        ++factor_->symbolic;
        factor_->analysed_for = hessian_.builds();
      }
      const bool lagged = settings_.linear_solver == LinearSolver::lagged_pcg ||
                          (settings_.linear_solver == LinearSolver::automatic && 3L * nn > kLaggedPcgUnknowns);
      bool have = lagged && factor_->factored_for == hessian_.builds() && lagged_pcg(rhs, dx, status);
      if (!have) {
        factor_->llt.factorize(hessian_.matrix());
        ++status.factorisations;
        if (factor_->llt.info() != Eigen::Success) {
          factor_->factored_for = -1;
          continue;  // indefinite: project
        }
        factor_->factored_for = hessian_.builds();
        dx = factor_->llt.solve(rhs);
        have = factor_->llt.info() == Eigen::Success;
      }
      solved = have && dx.allFinite() && rhs.dot(dx) > 0.0;  // a descent direction
      times_.linear_solve += timer.lap();
    }
    if (!solved) return false;
    const Eigen::Map<const Points> step(dx.data(), nn, 3);
    // Backtracking (Armijo) on E along the Newton direction. Once the
    // predicted decrease is below what E resolves (its terms carry relative
    // round-off near 1e-13: ψ of F ≈ I loses digits to σ − 1), the energy
    // cannot judge a step any more and the full Newton step is taken: the
    // system is positive definite and the step already tiny.
    const double slope = -rhs.dot(dx);
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
    times_.forces += timer.lap();  // the line search's energies
  }
  // The iterations ran out: accept a residual below acceptable_tolerance.
  evaluate_gradient(x);
  const double residual = max_abs_free(gradient, fixed_) / scale;
  if (std::isfinite(residual) && residual <= settings_.acceptable_tolerance) {
    log().debug("backward_euler: accepted Δt = {} s at residual {:.3g} after {} iterations", dt, residual,
                settings_.max_newton_iterations);
    status.residual = residual;
    status.residuals.push_back(residual);
    status.iterations = settings_.max_newton_iterations;
    body.velocities = (x - xn) / dt;
    body.positions = x;
    return true;
  }
  return false;
}

NewtonStatus BackwardEulerIntegrator::step(Body& body, double max_dt) {
  fixed_.assign(at(body.num_nodes()), 0);
  for (const Index n : constraints_.pinned) fixed_[at(n)] = 1;
  for (const auto& motion : constraints_.prescribed)
    for (const Index n : motion.nodes) fixed_[at(n)] = 1;
  times_ = StepTimes{};
  double dt = std::min(settings_.time_step, max_dt);
  if (!(dt > 0.0)) throw Error(fmt::format("backward_euler: non-positive time step {} s", dt));
  const Points x0 = body.positions, v0 = body.velocities;
  NewtonStatus status;
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
  StageTimer timer;
  // Incompressible materials: xⁿ⁺¹ and vⁿ⁺¹ projected so that every node
  // keeps its volume (Irving et al. 2007).
  if (body.material.incompressible) status.volume = volume_.project(body, x0, fixed_, dt, dt);
  times_.volume += timer.lap();
  // Smoothing (W&T sec. 7, as Newmark's), plastic flow after convergence,
  // then the ground and the surface.
  if (settings_.smoothing > 0.0 && EmbeddedTension::active(body))
    tension_.smooth(body, std::min(0.5, settings_.smoothing * body.material.surface_tension * dt));
  times_.surface += timer.lap();
  Points f;
  elastic_.evaluate(body, body.positions, dt, f);
  status.plastic_elements = elastic_.plastic_elements();
  times_.forces += timer.lap();
  const double t_next = time_ + dt;
  if (constraints_.ground) enforce_ground(body, *constraints_.ground, fixed_);
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
  if (constraints_.self_collisions) {
    SelfCollisionParameters parameters = *constraints_.self_collisions;
    parameters.reference_step = settings_.time_step;  // a halved step responds at half the displacement
    status.self_collisions = self_collisions_.resolve_step(body, x0, dt, fixed_, parameters);
  }
  times_.self_collisions += timer.lap();
  time_ = t_next;
  status.times = times_;
  return status;
}

int BackwardEulerIntegrator::advance_to(Body& body, double t_end) {
  return step_until(time_, t_end, [&](double max_dt) { step(body, max_dt); });
}

}  // namespace goo
