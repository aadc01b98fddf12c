#include "solvers/newmark.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "core/error.h"
#include "core/parallel.h"
#include "solvers/stepping.h"

namespace goo {
namespace {

/// Σ a∘b over all entries, in a fixed order (deterministic).
double dot(const Points& a, const Points& b) {
  return a.cwiseProduct(b).sum();
}

}  // namespace

NewmarkIntegrator::NewmarkIntegrator(NewmarkSettings settings, Constraints constraints, const Eigen::Vector3d& gravity,
                                     SurfaceTensionSettings tension)
    : settings_(std::move(settings)), gravity_(gravity), tension_settings_(tension),
      constraints_(std::move(constraints)) {
  if (!(settings_.volume_tolerance > 0.0 && settings_.volume_tolerance < 0.1)) {
    throw Error(fmt::format("newmark.volume_tolerance must be in (0, 0.1), got {}", settings_.volume_tolerance));
  }
  volume_ = VolumeProjection(VolumeProjectionSettings{settings_.volume_tolerance});
  if (!(settings_.cfl > 0.0 && settings_.cfl <= 1.0)) {
    throw Error(fmt::format("newmark.cfl must be in (0, 1], got {}", settings_.cfl));
  }
  if (!(settings_.max_time_step > 0.0)) {
    throw Error(fmt::format("newmark.max_time_step must be positive, got {}", settings_.max_time_step));
  }
  if (!(settings_.preconditioner_strain >= 0.0) || settings_.preconditioner_steps < 1) {
    throw Error(
        fmt::format("newmark: preconditioner_strain must be non-negative and preconditioner_steps positive, got "
                    "{} and {}",
                    settings_.preconditioner_strain, settings_.preconditioner_steps));
  }
  if (!(settings_.max_strain_per_step > 0.0)) {
    throw Error(fmt::format("newmark.max_strain_per_step must be positive, got {}", settings_.max_strain_per_step));
  }
}

void NewmarkIntegrator::ensure_forces(Body& body) {
  if (have_forces_ && forces_.rows() == body.num_nodes()) return;
  evaluate_forces(body, 0.0);
  constrained_.assign(at(body.num_nodes()), 0);
  for (const Index n : constraints_.pinned) constrained_.at(at(n)) = 1;
  for (const auto& motion : constraints_.prescribed)
    for (const Index n : motion.nodes) constrained_.at(at(n)) = 1;
  have_forces_ = true;
}

static bool has_tension(const Body& body) { return EmbeddedTension::active(body); }

void NewmarkIntegrator::evaluate_forces(Body& body, double plastic_dt) {
  StageTimer timer;
  elastic_.evaluate(body, body.positions, plastic_dt, forces_);
  strain_since_blocks_ += std::exchange(step_strain_, 0.0);
  ++evaluations_since_blocks_;
  damping_.freeze(body, elastic_);
  times_.forces += timer.lap();
  if (body.material.incompressible) volume_.add_pressure_forces(body, body.positions, forces_);
  times_.volume += timer.lap();
  if (!has_tension(body)) return;
  // W&T sec. 7: forces on the fine surface, to the nodes with b_i (a
  // quantity: algorithms.md, "Embedding"). In vertex order: deterministic.
  tension_.add_forces(body, body.positions, tension_settings_.form, forces_);
  times_.surface += timer.lap();
}

double NewmarkIntegrator::stable_time_step(Body& body) {
  ensure_forces(body);
  double dt = std::min(settings_.max_time_step, settings_.cfl * elastic_.critical_time_step());
  if (has_tension(body)) {
    // Capillary bound at the element scale (h from the mean rest volume, h³/12 per BCC element).
    const double h = std::cbrt(12.0 * body.rest_volumes.mean());
    dt = std::min(dt, surface_tension_time_step(body.material.density, h, body.material.surface_tension));
  }
  reference_step_ = dt;  // the step without the strain-rate bound (self-collision targets scale by Δt over it)
  const double rate = max_strain_rate(body, body.velocities);
  strain_rate_ = rate;
  have_strain_rate_ = true;
  if (rate > 0.0) dt = std::min(dt, settings_.max_strain_per_step / rate);
  return dt;
}

void NewmarkIntegrator::apply_gravity_and_forces(const Body& body, const Points& v, double half_dt, Points& rhs) const {
  // rhs = M v + h (f_e + M g)
  rhs.resize(body.num_nodes(), 3);
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const double m = body.masses[n];
    rhs.row(n) = m * v.row(n) + half_dt * (forces_.row(n) + m * gravity_.transpose());
  }
}

void NewmarkIntegrator::impose_velocities(const Body& body, double t_next, double dt, Points& v) const {
  for (const Index n : constraints_.pinned) v.row(n).setZero();
  for (const auto& motion : constraints_.prescribed)
    for (const Index n : motion.nodes) {
      const Eigen::Vector3d target = motion.position(n, body.rest_positions.row(n).transpose(), t_next);
      v.row(n) = (target.transpose() - body.positions.row(n)) / dt;
    }
}

void NewmarkIntegrator::solve_damped(const Body& body, double h, const Points& rhs, Points& v, StepReport& status,
                                     int half) {
  const Index nn = body.num_nodes();
  const Eigen::VectorXd& m = body.masses;
  if (body.material.viscosity == 0.0) {
    for (Index n = 0; n < nn; ++n)
      if (!constrained_[at(n)]) v.row(n) = rhs.row(n) / m[n];
    return;
  }
  // Preconditioned conjugate gradients on (M + h C) v = rhs over the free
  // nodes, from v or from this half step's solution one step ago.
  // The system is solved for v / s, s the power of two nearest the largest
  // free entry of rhs: exact in binary (the same bits as unscaled), and the
  // squared norms stay finite for any representable mass, gravity or load
  // (a density of 1e200 overflowed ‖rhs‖², and the solve was skipped).
  // The largest free entry, per run in parallel.
  const double largest = max_over_runs(nn, kCgRun, [&](Index begin, Index end) {
    double most = 0.0;
    for (Index n = begin; n < end; ++n)
      if (!constrained_[at(n)]) most = std::max(most, rhs.row(n).cwiseAbs().maxCoeff());
    return most;
  });
  if (!std::isfinite(largest)) {
    v.setConstant(std::numeric_limits<double>::quiet_NaN());  // diagnosed as a non-finite state
    return;
  }
  if (largest == 0.0) return;  // at rest and unloaded: v as it is
  int exponent = 0;
  static_cast<void>(std::frexp(largest, &exponent));
  const double scale = std::ldexp(1.0, exponent);
  // Scaled entry by entry in parallel (by a power of two: exact).
  scaled_rhs_.resize(nn, 3);
  for_each_run(nn, kCgRun, [&](Index, Index begin, Index end) {
    scaled_rhs_.middleRows(begin, end - begin) = rhs.middleRows(begin, end - begin) / scale;
    v.middleRows(begin, end - begin) /= scale;
  });
  // The warm start: where a viscous body flows steadily its velocities
  // change little from one step to the next, and the same half step's
  // solution a step ago is near this one's (the armadillo grate, frames
  // 49–50: it leaves a median 0.09 and 0.14 of the residual at v, in the
  // first and second half; the last solve's increment added to v left
  // 0.62 and 0.89; the best combination of both solutions and v, 0.08 and
  // 0.14).
  Points& last = last_solutions_[static_cast<std::size_t>(half)];
  const bool guessed = last.rows() == nn;
  if (guessed) {
    scaled_guess_.resize(nn, 3);
    for_each_run(nn, kCgRun, [&](Index, Index begin, Index end) {
      scaled_guess_.middleRows(begin, end - begin) = last.middleRows(begin, end - begin) / scale;
    });
  }
  solve_scaled(body, h, scaled_rhs_, guessed ? &scaled_guess_ : nullptr, v, status);
  last.resize(nn, 3);
  for_each_run(nn, kCgRun, [&](Index, Index begin, Index end) {
    v.middleRows(begin, end - begin) *= scale;
    last.middleRows(begin, end - begin) = v.middleRows(begin, end - begin);
  });
}

void NewmarkIntegrator::solve_scaled(const Body& body, double h, const Points& rhs, const Points* guess, Points& v,
                                     StepReport& status) {
  const Index nn = body.num_nodes();
  // r₀ = rhs − A v at the velocities given: the impulse of every force of
  // the half step, h (f_e + M g − C v). The solve stops when the residual
  // is cg_tolerance of it, both measured as velocities, |r|_M⁻¹ = √(rᵀM⁻¹r):
  // as A ⪰ M, the velocity error A⁻¹r is at most that in the kinetic-energy
  // norm whatever the condition of A, so the increment is right to that
  // fraction of the explicit one, h M⁻¹ (f_e + M g − C v), whatever the
  // body's speed or viscosity. (|r| relative to |rhs| ≈ |M v| was tighter
  // the faster the body moved, for nothing; the plain |r| relative to |r₀|
  // let a heavily damped body keep an error in its rigid motion, where A =
  // M is small beside hC: a block held by friction slid.)
  // The residuals at v and at the guess from one pass over the elements
  // for both (each the same bits as an application of its own); with
  // them, when the preconditioner is renewed, the corners' blocks of C.
  const bool guessed = guess != nullptr && guess->rows() == nn;
  // C's blocks at the Fe of the last force evaluation, or kept from an
  // earlier one while the deformation since then is at most
  // preconditioner_strain (‖ΔF‖ ≤ Σ ‖Ḟ‖ Δt) and for fewer than
  // preconditioner_steps force evaluations, one a step (plastic flow
  // moves Fe where F stands still). A preconditioner sets how fast CG
  // converges, never where it stops (the stopping rule measures the true
  // residual): blocks of Fe Feᵀ off by at most ε ≈ 2 × 0.05 = 10% (the
  // default) multiply the condition number by at most (1 + ε)/(1 − ε) ≈
  // 1.22, CG's iterations by its square root, 1.1. Measured: the fine drop's frames 25–30 took
  // 2,208 iterations with blocks renewed at every evaluation and with
  // these (65 renewals in 375 steps), the armadillo grate's 49–50 10,664
  // and 10,663 (docs/physics.md).
  const bool new_blocks = !blocks_fresh_ || blocks_.size() != at(nn) ||
                          strain_since_blocks_ > settings_.preconditioner_strain ||
                          evaluations_since_blocks_ >= settings_.preconditioner_steps;
  if (new_blocks) {
    strain_since_blocks_ = 0.0;
    evaluations_since_blocks_ = 0;
  }
  if (guessed) {
    // The guessed velocities: kept if they leave less residual than v.
    trial_.resize(nn, 3);
    for_each_run(nn, kCgRun, [&](Index, Index begin, Index end) {
      for (Index n = begin; n < end; ++n) {
        if (constrained_[at(n)])
          trial_.row(n) = v.row(n);  // imposed values kept
        else
          trial_.row(n) = guess->row(n);
      }
    });
    damping_.element_pass(body, v, trial_, new_blocks);
  } else {
    damping_.element_pass(body, v, new_blocks);
  }
  r_.resize(nn, 3);
  z_.resize(nn, 3);
  if (guessed) {
    r_trial_.resize(nn, 3);
    z_trial_.resize(nn, 3);
  }
  blocks_.resize(at(nn));
  inverse_blocks_.resize(at(nn));
  const NodeIncidence& incidence = body.incidence;
  const Eigen::VectorXd& m = body.masses;
  const std::vector<Eigen::Vector3d>& corners = damping_.corner_forces();
  const std::vector<Eigen::Vector3d>& trial_corners = damping_.second_corner_forces();
  // ((M + hC) x)_n from an element pass's corner forces on x (−C x at n:
  // its corners in the incidence's order).
  auto product_at = [&](Index n, const Points& x, const std::vector<Eigen::Vector3d>& forces) {
    Eigen::Vector3d Cx = Eigen::Vector3d::Zero();
    for (Index i = incidence.offsets[at(n)]; i < incidence.offsets[at(n) + 1]; ++i)
      Cx += forces[at(incidence.corners[at(i)])];
    return Eigen::Vector3d(m[n] * x.row(n).transpose() - h * Cx);
  };
  // r = rhs − (M + hC) x at the free nodes, zero at the others; its
  // rᵀM⁻¹r at n returned.
  auto residual_at = [&](Index n, const Points& x, const std::vector<Eigen::Vector3d>& forces, Points& r) {
    if (constrained_[at(n)]) {
      r.row(n).setZero();
      return 0.0;
    }
    r.row(n) = rhs.row(n) - product_at(n, x, forces).transpose();
    return r.row(n).squaredNorm() / m[n];
  };
  // The iterations' passes run over fixed runs of kCgRun nodes, split
  // evenly between the threads like the damping's element pass
  // (for_each_run); sums per run, then run by run.
  const Index runs = (nn + kCgRun - 1) / kCgRun;
  run_sums_.resize(2 * at(runs));
  auto over_runs = [&](auto&& f) { for_each_run(nn, kCgRun, f); };
  auto total = [&](std::size_t which) {
    double sum = 0.0;
    for (Index run = 0; run < runs; ++run) sum += run_sums_[2 * at(run) + which];
    return sum;
  };
  // The preconditioner, block-Jacobi: each node's own 3×3 block of M + hC
  // inverted. Measured on the armadillo grate, 8 frames, warm started:
  // 24,436 iterations where mass scaling took 37,979. The same blocks and
  // h (a step's two solves, unless the blocks are renewed between them)
  // give the same inverses: kept.
  const bool same_inverses = !new_blocks && h == inverse_h_;
  auto precondition_at = [&](Index n) {
    if (same_inverses) return;
    if (new_blocks) blocks_[at(n)] = damping_.node_block(incidence, n);  // C_nn, as Damping::diagonal_blocks sums it
    // Inverted at unit scale: the cofactors of a block of 1e197 kg overflow.
    const Eigen::Matrix3d block = h * blocks_[at(n)] + m[n] * Eigen::Matrix3d::Identity();
    const double size = block.trace() / 3.0;
    inverse_blocks_[at(n)] = (block / size).inverse() / size;
  };
  // Both residuals, their |r|²_M⁻¹ (the stopping rule's scale) and the
  // preconditioner on each, z = (M + hC)_nn⁻¹ r, in one pass.
  over_runs([&](Index run, Index begin, Index end) {
    double at_v = 0.0, at_trial = 0.0;
    for (Index n = begin; n < end; ++n) {
      precondition_at(n);
      const Eigen::Matrix3d& inverse = inverse_blocks_[at(n)];
      at_v += residual_at(n, v, corners, r_);
      z_.row(n) = (inverse * r_.row(n).transpose()).transpose();
      if (guessed) {
        at_trial += residual_at(n, trial_, trial_corners, r_trial_);
        z_trial_.row(n) = (inverse * r_trial_.row(n).transpose()).transpose();
      }
    }
    run_sums_[2 * at(run)] = at_v;
    run_sums_[2 * at(run) + 1] = at_trial;
  });
  blocks_fresh_ = true;
  inverse_h_ = h;
  const double impulse = std::sqrt(total(0));
  if (impulse == 0.0) return;  // v already solves it
  double residual = 1.0;
  if (guessed) {
    const double at_trial = std::sqrt(total(1));
    if (at_trial < impulse) {
      copy_in_parallel(trial_, v);
      r_.swap(r_trial_);
      z_.swap(z_trial_);
      residual = at_trial / impulse;
    }
  }
  double rz = dot(r_, z_);
  int iteration = 0;
  p_.resize(nn, 3);
  Ap_.resize(nn, 3);
  // The search direction p = z + β p (p = z at first) is formed where it
  // is first read, in the element pass, and stored by the node pass that
  // follows: one pass over the nodes an iteration fewer.
  double beta = 0.0;
  while (residual > settings_.cg_tolerance && iteration < settings_.cg_max_iterations) {
    const bool first = iteration == 0;
    // Ap = (M + hC) p at the free nodes (zero at the others), and pᵀAp.
    if (first)
      damping_.element_pass(body, z_);
    else
      damping_.element_pass(body, z_, p_, beta);
    over_runs([&](Index run, Index begin, Index end) {
      double pAp = 0.0;
      for (Index n = begin; n < end; ++n) {
        if (first)
          p_.row(n) = z_.row(n);
        else
          p_.row(n) = z_.row(n) + beta * p_.row(n);
        if (constrained_[at(n)]) {
          Ap_.row(n).setZero();
          continue;
        }
        const Eigen::Vector3d Ap = product_at(n, p_, corners);
        Ap_.row(n) = Ap.transpose();
        pAp += p_.row(n).dot(Ap.transpose());
      }
      run_sums_[2 * at(run)] = pAp;
    });
    const double alpha = rz / total(0);
    // v += α p, r −= α Ap, z = the preconditioner on r; |r|²_M⁻¹ and rᵀz.
    over_runs([&](Index run, Index begin, Index end) {
      double rr = 0.0, rz_run = 0.0;
      for (Index n = begin; n < end; ++n) {
        v.row(n) += alpha * p_.row(n);
        r_.row(n) -= alpha * Ap_.row(n);
        const Eigen::Vector3d r = r_.row(n).transpose();
        const Eigen::Vector3d z = inverse_blocks_[at(n)] * r;
        z_.row(n) = z.transpose();
        rr += r.squaredNorm() / m[n];
        rz_run += r.dot(z);
      }
      run_sums_[2 * at(run)] = rr;
      run_sums_[2 * at(run) + 1] = rz_run;
    });
    residual = std::sqrt(total(0)) / impulse;
    ++iteration;
    const double rz_next = total(1);
    beta = rz_next / rz;
    rz = rz_next;
  }
  remove_net_residual(body, r_, v);
  DampingSolveStats& stats = status.damping;
  ++stats.solves;
  if (new_blocks) ++stats.preconditioners;
  stats.iterations += iteration;
  stats.max_iterations = std::max(stats.max_iterations, iteration);
  stats.max_residual = std::max(stats.max_residual, residual);
  if (residual > settings_.cg_tolerance) ++stats.unconverged;
}

void NewmarkIntegrator::remove_net_residual(const Body& body, const Points& r, Points& v) const {
  // A rigid velocity u = c + ω × (x − x̄) is in C's null space (damping.h),
  // so v + u leaves the residual r − M u: c and ω chosen to make its net
  // force and torque zero, Σ m u = Σ r and Σ (x − x̄) × m u = Σ (x − x̄) × r.
  // Σ M v and Σ x × M v then take Σ rhs's values to round-off whatever the
  // solve's tolerance (without it they drifted by the residual's net).
  // With a node constrained the body has no such freedom.
  const Index nn = body.num_nodes();
  if (std::find(constrained_.begin(), constrained_.end(), std::uint8_t{1}) != constrained_.end()) return;
  const Eigen::VectorXd& m = body.masses;
  const Points& x = body.positions;
  double mass = 0.0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), force = Eigen::Vector3d::Zero();
  for (Index n = 0; n < nn; ++n) {
    mass += m[n];
    centre += m[n] * x.row(n).transpose();
    force += r.row(n).transpose();
  }
  centre /= mass;
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();
  for (Index n = 0; n < nn; ++n) {
    const Eigen::Vector3d d = x.row(n).transpose() - centre;
    torque += d.cross(r.row(n).transpose());
    inertia += m[n] * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  }
  const Eigen::Vector3d c = force / mass;
  const Eigen::Vector3d omega = inertia.ldlt().solve(torque);
  if (!c.allFinite() || !omega.allFinite()) return;
  for (Index n = 0; n < nn; ++n) {
    const Eigen::Vector3d d = x.row(n).transpose() - centre;
    v.row(n) += (c + omega.cross(d)).transpose();
  }
}

double NewmarkIntegrator::next_time_step(Body& body, double max_dt) {
  ensure_forces(body);
  const double dt = std::min(stable_time_step(body), max_dt);
  if (!(dt > 0.0)) throw Error(fmt::format("newmark: non-positive time step {} s", dt));
  return dt;
}

StepReport NewmarkIntegrator::step(Body& body, double max_dt) {
  begin_step(body, next_time_step(body, max_dt));
  return finish_step(body);
}

void NewmarkIntegrator::begin_step(Body& body, double dt) {
  ensure_forces(body);
  pending_ = StepReport{};
  StepReport& status = pending_;
  step_dt_ = dt;
  // The deformation this step may add, ‖Ḟ‖ Δt at its start (the rate
  // stable_time_step measured, or measured here if it was not called):
  // the damping preconditioner is refreshed when the sum since its blocks
  // were computed passes preconditioner_strain (solve_scaled).
  if (!have_strain_rate_) strain_rate_ = max_strain_rate(body, body.velocities);
  have_strain_rate_ = false;
  step_strain_ = strain_rate_ * dt;  // counted at the step's force evaluation
  StageTimer timer;
  const double h = 0.5 * dt;
  const double t_next = time_ + dt;

  // 1. v½ = vⁿ + Δt/2 M⁻¹ (f_e(xⁿ) + f_d(xⁿ, v½) + M g): linear SPD in v½.
  Points rhs;
  apply_gravity_and_forces(body, body.velocities, h, rhs);
  impose_velocities(body, t_next, dt, body.velocities);
  times_.other += timer.lap();
  solve_damped(body, h, rhs, body.velocities, status, 0);
  times_.damping += timer.lap();
  const auto& obstacles = constraints_.obstacles;
  // Collisions adjust v½ (W&T sec. 4; algorithms.md, "Time integration").
  status.collisions += collisions_.resolve_velocities(body, body.velocities, obstacles, t_next, dt, constrained_).resolved;
  times_.collisions += timer.lap();

  // 2. xⁿ⁺¹ = xⁿ + Δt v½; the surface smoothed and re-embedded (W&T
  // sec. 7, fig. 8); then the position collisions.
  const bool incompressible = body.material.incompressible;
  const Points x_start = constraints_.self_collisions || incompressible ? body.positions : Points();
  body.positions += dt * body.velocities;
  times_.other += timer.lap();
  // Incompressible materials: x and v½ projected so that every node keeps
  // its volume (Irving et al. 2007), before the contacts have their say.
  if (incompressible) status.volume = volume_.project(body, x_start, constrained_, dt, h);
  times_.volume += timer.lap();
  if (has_tension(body) && tension_settings_.smoothing > 0.0)
    tension_.smooth(body, std::min(0.5, tension_settings_.smoothing * body.material.surface_tension * dt));
  times_.surface += timer.lap();
  if (incompressible) {  // the volume the contacts take given back at once
    double restoring = 0.0;
    status.collisions += resolve_positions_keeping_volume(body, collisions_, volume_, obstacles, t_next, constrained_,
                                                          status.volume, restoring)
                             .resolved;
    times_.volume += restoring;
    times_.collisions += timer.lap() - restoring;
  } else {
    status.collisions += collisions_.resolve_positions(body, obstacles, t_next, constrained_).resolved;
    times_.collisions += timer.lap();
  }
  // The surface against itself over the whole move, obstacles' corrections
  // included; the impulses change v½ too (Bridson et al. 2002).
  if (constraints_.self_collisions) {
    SelfCollisionParameters parameters = *constraints_.self_collisions;
    parameters.reference_step = reference_step_;
    status.self_collisions = self_collisions_.resolve_step(body, x_start, dt, constrained_, parameters);
  }
  times_.self_collisions += timer.lap();
}

StepReport NewmarkIntegrator::finish_step(Body& body) {
  StepReport status = std::exchange(pending_, StepReport{});
  StageTimer timer;
  const double dt = step_dt_;
  const double h = 0.5 * dt;
  const double t_next = time_ + dt;
  const bool incompressible = body.material.incompressible;
  const auto& obstacles = constraints_.obstacles;

  // 3. The one elastic force evaluation, at xⁿ⁺¹, with plastic flow.
  evaluate_forces(body, dt);
  status.plastic_elements = elastic_.plastic_elements();
  timer.lap();  // counted by evaluate_forces

  // 4. vⁿ⁺¹ = v½ + Δt/2 M⁻¹ (f_e(xⁿ⁺¹) + f_d(xⁿ⁺¹, vⁿ⁺¹) + M g).
  Points rhs;
  apply_gravity_and_forces(body, body.velocities, h, rhs);
  for (const auto& motion : constraints_.prescribed) {
    // The path's velocity at t_next, by a central difference over the step.
    for (const Index n : motion.nodes) {
      const Eigen::Vector3d rest = body.rest_positions.row(n).transpose();
      body.velocities.row(n) =
          ((motion.position(n, rest, t_next + h) - motion.position(n, rest, t_next - h)) / dt).transpose();
    }
  }
  for (const Index n : constraints_.pinned) body.velocities.row(n).setZero();
  times_.other += timer.lap();
  solve_damped(body, h, rhs, body.velocities, status, 1);
  times_.damping += timer.lap();
  if (incompressible) status.volume += volume_.project_velocities(body, constrained_, dt, h, forces_);
  times_.volume += timer.lap();
  // vⁿ⁺¹ must not drive the surface into an obstacle over the next step.
  status.collisions += collisions_.resolve_velocities(body, body.velocities, obstacles, t_next, dt, constrained_).resolved;
  times_.collisions += timer.lap();

  time_ = t_next;
  status.dt = dt;
  status.times = std::exchange(times_, StepTimes{});
  return status;
}

}  // namespace goo
