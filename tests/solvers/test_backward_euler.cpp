#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <random>

#include "core/elastic_forces.h"
#include "core/tet_mesh.h"
#include "solvers/backward_euler.h"
#include "solvers/newmark.h"
#include "tests/common/test_common.h"
#include "tests/core/cantilever.h"

namespace goo {
namespace {

using test::material;

Body box(const Material& m, int cells, double size = 0.3) {
  return make_body(make_box_tets(Eigen::Vector3d::Constant(size), Eigen::Vector3i::Constant(cells)), m);
}

double total_energy(const Body& body, double g) {
  double potential = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n) potential += body.masses[n] * g * body.positions(n, 2);
  return kinetic_energy(body) + elastic_energy(body, body.positions) + potential;
}

// Near the solution Newton converges quadratically: r_{k+1} ≤ c r_k².
// The body is stretched unequally along three axes (tension: dP/dF positive
// definite, so the projection changes nothing; separated singular values, so
// dP/dF is evaluated by its exact formula everywhere).
TEST(BackwardEuler, NewtonConvergesQuadratically) {
  Body body = box(material(ElasticModel::neo_hookean, 1e5, 0.3), 3);
  body.positions = body.rest_positions * Eigen::Vector3d(1.25, 1.1, 1.02).asDiagonal();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Index n = 0; n < body.num_nodes(); ++n)
    body.velocities.row(n) = 0.05 * Eigen::RowVector3d(u(rng), u(rng), u(rng));
  BackwardEulerSettings settings;
  settings.time_step = 5e-3;
  settings.tolerance = 1e-12;
  BackwardEulerIntegrator integrator(settings, {});
  const StepReport status = integrator.step(body, 1.0);
  ASSERT_GE(status.residuals.size(), 3u);
  EXPECT_EQ(status.line_search_steps, 0);
  const auto& r = status.residuals;
  // Quadratic, not linear, until the round-off floor (≈ 1e-12 of the force scale).
  for (std::size_t k = 1; k + 1 < r.size(); ++k)
    if (r[k] < 1e-3 && r[k + 1] > 1e-11) {
      EXPECT_LT(r[k + 1], 10.0 * r[k] * r[k] / r[0] + 1e-13) << "iteration " << k;
    }
}

// Stiff and nearly incompressible cubes at Δt 100× the explicit bound: no
// NaN, and the total energy never rises above the initial one.
TEST(BackwardEuler, StableFarAboveTheExplicitLimit) {
  for (const auto& [E, nu] : {std::pair{1e7, 0.3}, std::pair{1e5, 0.49}}) {
    SCOPED_TRACE(nu);
    Body body = box(material(ElasticModel::stable_neo_hookean, E, nu), 3);
    // Squashed and spinning: plenty of elastic and kinetic energy.
    for (Index n = 0; n < body.num_nodes(); ++n) {
      body.positions(n, 2) *= 0.8;
      body.velocities.row(n) = Eigen::RowVector3d(-body.positions(n, 1), body.positions(n, 0), 0.0) * 3.0;
    }
    NewmarkIntegrator probe(NewmarkSettings{}, {});
    const double explicit_dt = probe.stable_time_step(body);
    BackwardEulerSettings settings;
    settings.time_step = 100.0 * explicit_dt;
    BackwardEulerIntegrator integrator(settings, {});
    const double initial = total_energy(body, 9.81);
    for (int i = 0; i < 20; ++i) {
      integrator.step(body, 1.0);
      ASSERT_TRUE(body.positions.allFinite());
      EXPECT_LE(total_energy(body, 9.81), initial * (1.0 + 1e-9)) << "step " << i;
    }
  }
}

TEST(BackwardEuler, SymbolicFactorisationOncePerTopology) {
  Body body = box(material(ElasticModel::fixed_corotated, 1e5, 0.3, 1.0), 2);
  body.velocities.col(0) = body.positions.col(2);  // shearing: Newton has work to do
  BackwardEulerSettings settings;
  settings.time_step = 1e-2;
  BackwardEulerIntegrator integrator(settings, {});
  integrator.advance_to(body, 0.2);
  EXPECT_EQ(integrator.symbolic_factorisations(), 1);
  body = box(material(ElasticModel::fixed_corotated, 1e5, 0.3, 1.0), 3);  // a new mesh
  body.velocities.col(0) = body.positions.col(2);
  integrator.advance_to(body, 0.3);
  EXPECT_EQ(integrator.symbolic_factorisations(), 2);
}

// The cantilever of the finite-element tests: backward Euler with viscosity
// settles where a direct static Newton solve puts it.
TEST(BackwardEuler, CantileverSettlesAtTheStaticEquilibrium) {
  Material m = material(ElasticModel::neo_hookean, 1e8, 0.3, 1e4);
  Body dynamic = make_body(make_box_tets({1.0, 0.1, 0.1}, {20, 2, 2}), m);
  std::vector<bool> clamped(static_cast<std::size_t>(dynamic.num_nodes()));
  Constraints c;
  for (Index n = 0; n < dynamic.num_nodes(); ++n)
    if (dynamic.positions(n, 0) == 0.0) {
      clamped[static_cast<std::size_t>(n)] = true;
      c.pinned.push_back(n);
    }
  Body statics = dynamic;
  test::solve_static(statics, clamped, 9.81, 12);
  BackwardEulerSettings settings;
  settings.time_step = 0.02;
  BackwardEulerIntegrator integrator(settings, c);
  integrator.advance_to(dynamic, 1.5);
  const double tip = statics.positions.col(2).minCoeff();
  ASSERT_LT(tip, -1e-3);
  EXPECT_NEAR(dynamic.positions.col(2).minCoeff(), tip, 1e-4 * std::abs(tip));
}

// The small-load limit: on the beam-theory cantilever of the finite-element
// tests (ν = 0, δ/L ≈ 1.5%), backward Euler settles on each mesh of the
// refinement ladder where the static solve does, and the static tips converge
// to Euler–Bernoulli (core/test_cantilever.cpp: errors 75%, 45%, 18%, 5%);
// so do these, level by level.
TEST(BackwardEuler, CantileverApproachesEulerBernoulliUnderRefinement) {
  const double E = 1e7, rho = 100.0, g = 9.81, h = 0.1, L = 1.0;
  const double reference = test::cantilever_tip_reference(E, rho, g, h, L);
  double previous_error = 1.0;
  for (const int n : {1, 2, 4}) {
    Material m = material(ElasticModel::fixed_corotated, E, 0.0, 2e3);  // viscous: it settles in about a second
    m.density = rho;
    Body dynamic = make_body(make_box_tets({L, h, h}, {10 * n, n, n}), m);
    std::vector<bool> clamped(static_cast<std::size_t>(dynamic.num_nodes()));
    Constraints c;
    for (Index v = 0; v < dynamic.num_nodes(); ++v)
      if (dynamic.positions(v, 0) == 0.0) {
        clamped[static_cast<std::size_t>(v)] = true;
        c.pinned.push_back(v);
      }
    Body statics = dynamic;
    test::solve_static(statics, clamped, g, 4);
    BackwardEulerSettings settings;
    settings.time_step = 0.05;
    BackwardEulerIntegrator integrator(settings, c);
    integrator.advance_to(dynamic, 2.0);
    auto tip = [&](const Body& b) { return test::tip_deflection(b, L); };
    const double static_tip = tip(statics), dynamic_tip = tip(dynamic);
    // Settled: the remaining motion decays as exp(−t/τ); 1e-4 is below every
    // level's distance to beam theory by two orders.
    EXPECT_NEAR(dynamic_tip, static_tip, 1e-4 * static_tip) << "cells " << 10 * n;
    const double error = std::abs(dynamic_tip - reference) / reference;
    EXPECT_LT(error, previous_error) << "cells " << 10 * n;
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.2);  // 18% at 40 × 4 × 4 cells, as the static ladder
}

// CG preconditioned with a lagged factor solves the same Newton systems
// (to 1e-10) with fewer factorisations: the same motion to Newton's tolerance.
TEST(BackwardEuler, LaggedPcgFollowsTheDirectSolveWithFewerFactorisations) {
  auto run = [](LinearSolver solver, int* factorisations) {
    Body body = box(material(ElasticModel::neo_hookean, 1e5, 0.3, 3.0), 3);
    for (Index n = 0; n < body.num_nodes(); ++n) body.velocities(n, 0) = 2.0 * body.positions(n, 2);
    BackwardEulerSettings settings;
    settings.time_step = 1e-2;
    settings.linear_solver = solver;
    BackwardEulerIntegrator integrator(settings, {});
    *factorisations = 0;
    while (integrator.time() < 0.2) *factorisations += integrator.step(body, 0.2 - integrator.time()).factorisations;
    return body.positions;
  };
  int direct = 0, lagged = 0;
  const Points a = run(LinearSolver::direct, &direct), b = run(LinearSolver::lagged_pcg, &lagged);
  EXPECT_TRUE(test::matrices_near(a, b, 1e-7));
  EXPECT_LT(lagged, direct / 2);
}

// automatic: the lagged preconditioner above 10k unknowns (14³ cells: 10,125).
TEST(BackwardEuler, AutomaticSolverLagsTheFactorOnLargeSystems) {
  Body body = box(material(ElasticModel::neo_hookean, 1e5, 0.3, 3.0), 14);
  ASSERT_GT(3L * body.num_nodes(), kLaggedPcgUnknowns);
  for (Index n = 0; n < body.num_nodes(); ++n) body.velocities(n, 0) = 2.0 * body.positions(n, 2);
  BackwardEulerSettings settings;
  settings.time_step = 1e-2;
  BackwardEulerIntegrator integrator(settings, {});
  int factorisations = 0, iterations = 0;
  for (int i = 0; i < 3; ++i) {
    const StepReport status = integrator.step(body, 1.0);
    factorisations += status.factorisations;
    iterations += status.iterations;
  }
  EXPECT_GT(iterations, 3);
  EXPECT_LT(factorisations, iterations);
}

TEST(BackwardEuler, SameBitsForAnyThreadCount) {
  auto run = [](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Body body = box(material(ElasticModel::neo_hookean, 1e5, 0.3, 3.0), 3);
    for (Index n = 0; n < body.num_nodes(); ++n) body.velocities(n, 0) = body.positions(n, 2);
    BackwardEulerSettings settings;
    settings.time_step = 1e-2;
    BackwardEulerIntegrator integrator(settings, {});
    integrator.advance_to(body, 0.1);
    return body.positions;
  };
  EXPECT_TRUE(run(1) == run(2));
}

}  // namespace
}  // namespace goo
