// The static integrator (BackwardEulerSettings::statics; docs/implicit.md,
// "Static equilibrium"): the stretched cube's closed forms, the
// Euler–Bernoulli ladder, load steps, a gravity ramp, determinism.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

#include "core/error.h"
#include "core/tet_mesh.h"
#include "solvers/backward_euler.h"
#include "tests/common/test_common.h"
#include "tests/core/cantilever.h"

namespace goo {
namespace {

using test::material;

/// The lateral stretch b of a bar stretched by a along x with traction-free
/// sides, from ∂ψ/∂σ₂(a, b, b) = 0: neo-Hookean μ(b² − 1) + λ ln(ab²) = 0,
/// fixed-corotated 2μ(b − 1) + λ(ab² − 1)ab = 0. Both are negative at
/// b = 0.2 and positive at b = 1 for a > 1: bisection to round-off.
double lateral_stretch(const Material& m, double a) {
  const double mu = m.mu(), lambda = m.lambda();
  const auto stress = [&](double b) {
    return m.model == ElasticModel::neo_hookean ? mu * (b * b - 1.0) + lambda * std::log(a * b * b)
                                                : 2.0 * mu * (b - 1.0) + lambda * (a * b * b - 1.0) * a * b;
  };
  double lo = 0.2, hi = 1.0;
  EXPECT_LT(stress(lo), 0.0);
  EXPECT_GT(stress(hi), 0.0);
  for (int i = 0; i < 200 && hi - lo > 1e-16; ++i) (stress(0.5 * (lo + hi)) < 0.0 ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

/// The homogeneous stretch (a, b, b) of the unit cube about its axis
/// y = z = ½, reached linearly over t ∈ [0, 1].
Eigen::Vector3d stretched(const Eigen::Vector3d& rest, double a, double b, double t) {
  const double s = std::min(t, 1.0);
  const double ax = 1.0 + s * (a - 1.0), bx = 1.0 + s * (b - 1.0);
  return {ax * rest.x(), 0.5 + bx * (rest.y() - 0.5), 0.5 + bx * (rest.z() - 0.5)};
}

/// The unit cube (3³ cells) with its end faces x = 0 and x = 1 moved along
/// `stretched`, solved statically without gravity in one step to t = 1.
/// Returns the largest distance of any node from the homogeneous stretch
/// (a, b_exact, b_exact); `cuts` gets the load-step halvings.
double stretch_error(const Material& m, double a, double b_faces, BackwardEulerSettings settings, int* cuts = nullptr) {
  Body body = make_body(make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Constant(3)), m);
  Constraints constraints;
  PrescribedMotion ends;
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (body.rest_positions(n, 0) == 0.0 || body.rest_positions(n, 0) == 1.0) ends.nodes.push_back(n);
  ends.position = [=](Index, const Eigen::Vector3d& rest, double t) { return stretched(rest, a, b_faces, t); };
  constraints.prescribed.push_back(ends);
  settings.statics = true;
  settings.time_step = 1.0;
  BackwardEulerIntegrator integrator(settings, constraints, Eigen::Vector3d::Zero());
  const StepReport status = integrator.step(body, 1.0);
  if (cuts != nullptr) *cuts = status.halvings;
  EXPECT_TRUE(body.velocities.isZero(0.0));  // a static solve leaves the body at rest
  const double b = lateral_stretch(m, a);
  double error = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n)
    error = std::max(error, (body.positions.row(n).transpose() -
                             stretched(body.rest_positions.row(n).transpose(), a, b, 1.0))
                                .norm());
  return error;
}

class StretchedCube : public ::testing::TestWithParam<ElasticModel> {};

// With its end faces moved by the exact (a, b, b), the cube's equilibrium
// is that homogeneous stretch, lateral faces free of traction: every node
// on it to what Newton's tolerance allows. Scale: the residual is 1e-12 of
// the load (forces ~ E × strain × face ~ 1e4 N), each node's stiffness
// ~ E h ~ 3e4 N/m, so the nodes sit within ~1e-12 m, times the mesh's
// condition number (≤ 1e3): 1e-9 m. Faces moved with b = 1 instead leave
// the sides to neck on their own, far from the homogeneous field: the test
// can tell a wrong b.
TEST_P(StretchedCube, MatchesTheClosedFormOfTractionFreeSides) {
  const Material m = material(GetParam(), 1e5, 0.3);
  BackwardEulerSettings settings;
  settings.tolerance = 1e-12;
  const double a = 1.5, b = lateral_stretch(m, a);
  EXPECT_LT(b, 0.95);
  EXPECT_LT(stretch_error(m, a, b, settings), 1e-9);
  EXPECT_GT(stretch_error(m, a, 1.0, settings), 1e-2);
}

INSTANTIATE_TEST_SUITE_P(Models, StretchedCube,
                         ::testing::Values(ElasticModel::neo_hookean, ElasticModel::fixed_corotated),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

// A stretch to three times the length, which Newton does not reach from
// rest in four iterations: the load is halved until each increment
// converges, and the end is the same closed form. With no halvings allowed
// the same solve is refused with an error that says so.
TEST(Static, LoadStepsReachWhatOneNewtonSolveCannot) {
  const Material m = material(ElasticModel::neo_hookean, 1e5, 0.3);
  BackwardEulerSettings settings;
  settings.tolerance = 1e-12;
  settings.acceptable_tolerance = 1e-12;
  settings.max_newton_iterations = 4;
  settings.max_halvings = 12;
  const double a = 3.0;
  int cuts = 0;
  EXPECT_LT(stretch_error(m, a, lateral_stretch(m, a), settings, &cuts), 1e-9);
  EXPECT_GT(cuts, 0);
  settings.max_halvings = 0;
  EXPECT_TRUE(test::throws_error_containing([&] { stretch_error(m, a, lateral_stretch(m, a), settings); },
                                            "static: no equilibrium found at t = 1 s"));
}

/// The beam of the finite-element tests (E = 1e7 Pa, ρ = 100 kg/m³, ν = 0,
/// 1 × 0.1 × 0.1 m) clamped at x = 0, on 10n × n × n cells.
struct Beam {
  Body body;
  Constraints constraints;
  std::vector<bool> clamped;

  explicit Beam(int n) {
    Material m = material(ElasticModel::fixed_corotated, 1e7, 0.0);
    m.density = 100.0;
    body = make_body(make_box_tets({1.0, 0.1, 0.1}, {10 * n, n, n}), m);
    clamped.assign(static_cast<std::size_t>(body.num_nodes()), false);
    for (Index v = 0; v < body.num_nodes(); ++v)
      if (body.positions(v, 0) == 0.0) {
        clamped[static_cast<std::size_t>(v)] = true;
        constraints.pinned.push_back(v);
      }
  }
  /// The mean downward displacement of the free end's nodes, m.
  [[nodiscard]] double tip() const { return test::tip_deflection(body, 1.0); }
};

BackwardEulerSettings statics(double time_step = 1.0, double gravity_ramp = 0.0) {
  BackwardEulerSettings s;
  s.statics = true;
  s.time_step = time_step;
  s.gravity_ramp = gravity_ramp;
  return s;
}

// The Euler–Bernoulli ladder (core/test_cantilever.cpp, the backward-Euler
// test): on each mesh the static integrator lands where the tests' own
// Newton solve does (to its tolerance, 1e-8 of the load, far below the
// ladder's steps), and its tips approach beam theory with Timoshenko's shear
// term under refinement (75%, 45%, 18%).
TEST(Static, CantileverApproachesEulerBernoulliUnderRefinement) {
  const double g = 9.81;
  const double reference = test::cantilever_tip_reference(1e7, 100.0, g, 0.1, 1.0);
  double previous_error = 1.0;
  for (const int n : {1, 2, 4}) {
    Beam beam(n);
    Body direct = beam.body;
    test::solve_static(direct, beam.clamped, g, 6);
    BackwardEulerIntegrator integrator(statics(), beam.constraints);
    integrator.advance_to(beam.body, 1.0);
    const double expected = test::tip_deflection(direct, 1.0);
    EXPECT_NEAR(beam.tip(), expected, 1e-6 * expected) << "cells " << 10 * n;
    EXPECT_TRUE(beam.body.velocities.isZero(0.0));
    const double error = std::abs(beam.tip() - reference) / reference;
    EXPECT_LT(error, previous_error) << "cells " << 10 * n;
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.2);
}

// Gravity ramped over a second: each frame is the equilibrium at its own
// load. The beam bends by δ/L ≈ 1.5%, where the response is linear to
// (δ/L)² ≈ 2e-4: at half the load, half the tip (to 1e-3); at the full load,
// the one-step solve's tip (the same equilibrium, to Newton's tolerance).
TEST(Static, AGravityRampGivesEachFrameTheEquilibriumOfItsLoad) {
  Beam ramped(1), once(1);
  BackwardEulerIntegrator ramp(statics(0.25, 1.0), ramped.constraints);
  BackwardEulerIntegrator full(statics(), once.constraints);
  full.advance_to(once.body, 1.0);
  ramp.advance_to(ramped.body, 0.5);
  EXPECT_NEAR(ramped.tip(), 0.5 * once.tip(), 1e-3 * once.tip());
  ramp.advance_to(ramped.body, 1.0);
  EXPECT_NEAR(ramped.tip(), once.tip(), 1e-6 * once.tip());
  ramp.advance_to(ramped.body, 2.0);  // past the ramp: the load stays
  EXPECT_NEAR(ramped.tip(), once.tip(), 1e-6 * once.tip());
}

TEST(Static, ABodyHeldNowhereIsRefused) {
  Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(2)),
                        material(ElasticModel::neo_hookean, 1e5, 0.3));
  BackwardEulerIntegrator integrator(statics(), Constraints{});
  EXPECT_TRUE(test::throws_error_containing([&] { integrator.step(body, 1.0); }, "no pinned or moved nodes"));
}

TEST(Static, SameBitsForAnyThreadCount) {
  Points result[2];
  for (const int threads : {1, 2}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Beam beam(2);
    BackwardEulerIntegrator integrator(statics(0.5, 1.0), beam.constraints);
    integrator.advance_to(beam.body, 1.0);
    result[threads - 1] = beam.body.positions;
  }
  EXPECT_TRUE(result[0] == result[1]);
}

}  // namespace
}  // namespace goo
