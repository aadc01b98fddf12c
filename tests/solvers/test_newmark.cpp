#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <limits>
#include <random>
#include <utility>

#include "core/body.h"
#include "core/elastic_forces.h"
#include "core/error.h"
#include "solvers/backward_euler.h"
#include "solvers/newmark.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using test::kModels;

Body make_cube(ElasticModel model = ElasticModel::fixed_corotated, int cells = 3, double viscosity = 0.0) {
  Material m;
  m.model = model;
  m.youngs_modulus = 1e4;
  m.poisson_ratio = 0.3;
  m.viscosity = viscosity;
  return make_body(make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(cells)), m);
}

const Eigen::Vector3d kNoGravity = Eigen::Vector3d::Zero();

/// A spinning, translating, deforming initial velocity field.
void kick(Body& body, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  const Eigen::Vector3d omega(1.0, -2.0, 0.5), drift(0.2, 0.1, -0.3);
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d x = body.positions.row(n);
    body.velocities.row(n) = (omega.cross(x) + drift + Eigen::Vector3d(u(rng), u(rng), u(rng))).transpose();
  }
}

double total_energy(const Body& body) {
  return kinetic_energy(body) + elastic_energy(body, body.positions);
}

TEST(Newmark, FreeBodyConservesLinearAndAngularMomentumToRoundOff) {
  Body body = make_cube();
  kick(body, 1);
  const Eigen::Vector3d p0 = linear_momentum(body), L0 = angular_momentum(body);
  NewmarkIntegrator integrator({}, {}, kNoGravity);
  for (int i = 0; i < 500; ++i) integrator.step(body, 1.0);
  // Kick–drift–kick with internal forces that sum to zero and exert no
  // torque conserves both exactly; what remains is round-off of the sums.
  EXPECT_TRUE(test::matrices_near(linear_momentum(body), p0, 1e-12 * body.masses.sum()));
  EXPECT_TRUE(test::matrices_near(angular_momentum(body), L0, 1e-10 * L0.norm()));
}

TEST(Newmark, DampedFreeBodyConservesMomentumToRoundOffWhateverTheSolverTolerance) {
  for (const double tolerance : {1e-6, 1e-2}) {
    SCOPED_TRACE(tolerance);
    Body body = make_cube(ElasticModel::neo_hookean, 3, 20.0);
    for (Index n = 0; n < body.num_nodes(); ++n) body.positions(n, 2) *= 1.3;
    kick(body, 3);
    const Eigen::Vector3d p0 = linear_momentum(body), L0 = angular_momentum(body);
    NewmarkSettings settings;
    settings.cg_tolerance = tolerance;
    NewmarkIntegrator integrator(settings, {}, kNoGravity);
    integrator.advance_to(body, 0.5);
    // Damping forces are torque-free and vanish for rigid motion, and each
    // solve removes its residual's net force and torque by a rigid velocity:
    // a loose solve changes the motion, never the momenta. Round-off as the
    // undamped body's.
    EXPECT_TRUE(test::matrices_near(linear_momentum(body), p0, 1e-12 * body.masses.sum()));
    EXPECT_TRUE(test::matrices_near(angular_momentum(body), L0, 1e-10 * L0.norm()));
  }
}

/// 40 steps of a soft viscous cube (β = 20 Pa·s), stretched and kicked:
/// its final velocities and its largest over its smallest nodal mass; the
/// damping solves' figures into *stats, Σ |Δv| over the steps into *changes.
std::pair<Points, double> soft_cube_run(const NewmarkSettings& settings, DampingSolveStats* stats, double* changes) {
  Body body = make_cube(ElasticModel::neo_hookean, 3, 20.0);
  for (Index n = 0; n < body.num_nodes(); ++n) body.positions(n, 2) *= 1.3;
  kick(body, 3);
  NewmarkIntegrator integrator(settings, {}, kNoGravity);
  for (int i = 0; i < 40; ++i) {
    const Points before = body.velocities;
    *stats += integrator.step(body, 1.0).damping;
    *changes += (body.velocities - before).norm();
  }
  return {Points(body.velocities), body.masses.maxCoeff() / body.masses.minCoeff()};
}

TEST(Newmark, DampingSolveMeetsItsToleranceAndATighterOneChangesLittle) {
  // The solve stops at cg_tolerance τ of the half step's impulse r₀ = A Δv
  // (A = M + hC, Δv the exact increment): its error A⁻¹r is at most
  // τ κ(A) |Δv|, κ(A) ≤ (max m + h λ_max(C)) / min m. So a run at 1e-6
  // stays within τ κ Σ|Δv| of one at 1e-12, Σ over the steps' changes
  // (errors carried on by the undamped-to-damped dynamics do not grow).
  auto run = [](double tolerance, DampingSolveStats* stats, double* changes) {
    NewmarkSettings settings;
    settings.cg_tolerance = tolerance;
    return soft_cube_run(settings, stats, changes);
  };
  DampingSolveStats loose, tight;
  double changes = 0.0, unused = 0.0;
  const auto [v_loose, mass_ratio] = run(1e-6, &loose, &changes);
  const auto [v_tight, same_ratio] = run(1e-12, &tight, &unused);
  EXPECT_EQ(loose.solves, 80);
  EXPECT_EQ(loose.unconverged, 0);
  EXPECT_LE(loose.max_residual, 1e-6);
  EXPECT_LE(tight.max_residual, 1e-12);
  EXPECT_LT(loose.iterations, tight.iterations);
  // κ(A) ≤ 2 × the mass ratio when hC ≤ M, as for this soft cube (β = 20
  // Pa·s at its stable steps: the solves take a handful of iterations).
  EXPECT_LE((v_loose - v_tight).norm(), 1e-6 * 2.0 * mass_ratio * changes);
}

TEST(Newmark, APreconditionerKeptOverSeveralStepsChangesTheSolvesOnlyWithinTheirTolerance) {
  // The damping solves' block-Jacobi preconditioner, C's diagonal blocks at
  // one force evaluation's Fe, is kept over the steps while the
  // deformation since, Σ ‖Ḟ‖ Δt, stays within preconditioner_strain (and
  // for fewer than preconditioner_steps evaluations). Every solve still
  // stops at its own tolerance, so a run differs from one with blocks
  // renewed at every evaluation by at most both runs' errors: 2 τ κ Σ|Δv|
  // on the soft cube of DampingSolveMeetsItsToleranceAndATighterOneChangesLittle.
  NewmarkSettings fresh_settings, never_settings;
  fresh_settings.preconditioner_strain = 0.0;
  fresh_settings.preconditioner_steps = 1;
  never_settings.preconditioner_strain = 1e300;
  never_settings.preconditioner_steps = std::numeric_limits<int>::max();
  {
    DampingSolveStats fresh, kept;
    double changes = 0.0, unused = 0.0;
    const auto [v_fresh, mass_ratio] = soft_cube_run(fresh_settings, &fresh, &changes);
    const auto [v_kept, same_ratio] = soft_cube_run(NewmarkSettings{}, &kept, &unused);
    EXPECT_EQ(fresh.solves, 80);
    EXPECT_EQ(fresh.preconditioners, 41);  // both solves of the first step, then each step's second
    EXPECT_LT(kept.preconditioners, fresh.preconditioners);
    EXPECT_LE(kept.max_residual, 1e-6);
    EXPECT_LE((v_kept - v_fresh).norm(), 2.0 * 1e-6 * 2.0 * mass_ratio * changes);
  }
  // Blocks of Fe Feᵀ off by ε ≈ 2 × 0.05 change the condition number by at
  // most (1 + ε)/(1 − ε), the iterations' bound by its square root, 1.1.
  // On a stiffly damped (β = 2000 Pa·s: hC ≫ M), stretched cube spinning at
  // 4 rad/s, blocks never renewed while it turns cost more than that
  // (17,762 iterations against 12,788 here).
  auto spin = [](const NewmarkSettings& settings) {
    Body body = make_cube(ElasticModel::neo_hookean, 4, 2000.0);
    for (Index n = 0; n < body.num_nodes(); ++n) body.positions(n, 2) *= 1.5;
    const Eigen::Vector3d omega(0.0, 4.0, 0.0);
    const Eigen::Vector3d centre = body.positions.colwise().mean();
    for (Index n = 0; n < body.num_nodes(); ++n)
      body.velocities.row(n) = omega.cross(Eigen::Vector3d(body.positions.row(n).transpose() - centre)).transpose();
    NewmarkIntegrator integrator(settings, {}, kNoGravity);
    DampingSolveStats stats;
    for (int i = 0; i < 300; ++i) stats += integrator.step(body, 1.0).damping;
    return stats;
  };
  const DampingSolveStats fresh = spin(fresh_settings), kept = spin(NewmarkSettings{}), never = spin(never_settings);
  EXPECT_EQ(fresh.preconditioners, 301);
  EXPECT_EQ(never.preconditioners, 1);
  EXPECT_LT(kept.preconditioners, fresh.preconditioners);
  EXPECT_GE(kept.preconditioners, 300 / 8);
  for (const DampingSolveStats* stats : {&fresh, &kept, &never}) {
    EXPECT_EQ(stats->unconverged, 0);
    EXPECT_LE(stats->max_residual, 1e-6);
  }
  EXPECT_LE(static_cast<double>(kept.iterations), 1.1 * static_cast<double>(fresh.iterations));
  EXPECT_GT(static_cast<double>(never.iterations), 1.1 * static_cast<double>(fresh.iterations));
  // The spin's strain, ‖Ḟ‖ Δt a step, renews them more often than every
  // 8th evaluation; a falling cube does not deform (Ḟ = 0), and only
  // every 8th evaluation renews them.
  EXPECT_GT(kept.preconditioners, 1 + 300 / 8);
  Body falling = make_cube(ElasticModel::neo_hookean, 3, 20.0);
  NewmarkIntegrator integrator(NewmarkSettings{}, {});
  DampingSolveStats fall;
  for (int i = 0; i < 40; ++i) fall += integrator.step(falling, 1.0).damping;
  EXPECT_EQ(fall.solves, 80);
  EXPECT_EQ(fall.preconditioners, 1 + 40 / 8);
}

/// Worst |E − E₀| over 10⁴ steps of an undamped oscillating cube, and the
/// same over the first and the last 2000 steps.
struct EnergyError {
  double worst = 0.0, early = 0.0, late = 0.0, e0 = 0.0;
};
EnergyError undamped_energy_error(double cfl) {
  Body body = make_cube(ElasticModel::stable_neo_hookean, 2);
  for (Index n = 0; n < body.num_nodes(); ++n) body.positions(n, 0) *= 1.2;  // stretched, released
  EnergyError out;
  out.e0 = total_energy(body);
  NewmarkSettings settings;
  settings.cfl = cfl;
  NewmarkIntegrator integrator(settings, {}, kNoGravity);
  for (int i = 0; i < 10000; ++i) {
    integrator.step(body, 1.0);
    const double error = std::abs(total_energy(body) - out.e0);
    out.worst = std::max(out.worst, error);
    if (i < 2000) out.early = std::max(out.early, error);
    if (i >= 8000) out.late = std::max(out.late, error);
  }
  return out;
}

TEST(Newmark, UndampedEnergyErrorIsBoundedSecondOrderAndUnderOnePercent) {
  // Kick–drift–kick is symplectic: the energy error oscillates with an
  // amplitude O(Δt²) and does not drift. Measured at CFL 0.5 it is ≈ 1.7%,
  // at 0.25 ≈ 0.37%: the 1% budget needs CFL 0.25.
  const EnergyError coarse = undamped_energy_error(0.5);
  const EnergyError fine = undamped_energy_error(0.25);
  EXPECT_LT(fine.worst, 0.01 * fine.e0);
  EXPECT_NEAR(coarse.worst / fine.worst, 4.0, 1.0) << "second order in Δt";
  EXPECT_LT(fine.late, 1.5 * fine.early) << "no secular drift";
}

TEST(Newmark, ViscosityMakesEnergyDecayMonotonically) {
  Body body = make_cube(ElasticModel::fixed_corotated, 2, 50.0);
  for (Index n = 0; n < body.num_nodes(); ++n) body.positions(n, 2) *= 1.3;
  NewmarkIntegrator integrator({}, {}, kNoGravity);
  double previous = total_energy(body);
  const double e0 = previous;
  for (int frame = 0; frame < 40; ++frame) {
    integrator.advance_to(body, (frame + 1) * 0.005);
    const double e = total_energy(body);
    EXPECT_LT(e, previous) << "frame " << frame;
    previous = e;
  }
  EXPECT_LT(previous, 0.5 * e0);
}

TEST(Newmark, FreeFallMatchesTheAnalyticTrajectory) {
  Body body = make_cube();
  const Eigen::Vector3d v0(0.5, 0.0, 2.0);
  body.velocities.rowwise() = v0.transpose();
  const Points x0 = body.positions;
  const Eigen::Vector3d g = standard_gravity();
  NewmarkIntegrator integrator({}, {}, g);
  const double T = 0.37;
  integrator.advance_to(body, T);
  EXPECT_DOUBLE_EQ(integrator.time(), T);
  // Constant acceleration is integrated exactly; the error is round-off of
  // the many steps, relative to the distance travelled.
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d expected = x0.row(n).transpose() + v0 * T + 0.5 * g * T * T;
    EXPECT_TRUE(test::matrices_near(body.positions.row(n).transpose(), expected, 1e-12));
    EXPECT_TRUE(test::matrices_near(body.velocities.row(n).transpose(), v0 + g * T, 1e-12));
  }
}

class Recovery : public ::testing::TestWithParam<ElasticModel> {};

TEST_P(Recovery, InvertedAndFlattenedElementsReturnToTheirRestVolume) {
  for (const double squash : {-0.2, 1e-6}) {  // mirrored through a plane, or flattened onto it
    Body body = make_cube(GetParam(), 2, 20.0);
    for (Index n = 0; n < body.num_nodes(); ++n) body.positions(n, 2) *= squash;
    NewmarkIntegrator integrator({}, {}, kNoGravity);
    integrator.advance_to(body, 3.0);
    ASSERT_TRUE(body.positions.allFinite());
    for (Index e = 0; e < body.num_elements(); ++e) {
      // Released and damped, every element returns near its rest volume.
      EXPECT_NEAR(deformation_gradient(body, body.positions, e).determinant(), 1.0, 0.05)
          << "element " << e << ", squash " << squash;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, Recovery, ::testing::ValuesIn(kModels),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

/// Kinetic + elastic + gravitational energy.
double mechanical_energy(const Body& body, const Eigen::Vector3d& gravity) {
  double potential = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n)
    potential -= body.masses[n] * gravity.dot(Eigen::Vector3d(body.positions.row(n)));
  return total_energy(body) + potential;
}

// The floor as the scenes have it: a half-space obstacle that the body's
// surface (its boundary faces, every boundary node a surface vertex)
// collides with.
TEST(Newmark, TheFloorIsNeverCrossedAndContactOnlyDissipates) {
  Body body = make_cube(ElasticModel::fixed_corotated, 2, 0.0);
  body.positions.col(2).array() += 0.1;
  embed_boundary(body);
  Constraints constraints;
  constraints.obstacles.push_back(
      Obstacle{"ground", make_half_space(Eigen::Vector3d::UnitZ(), 0.0), RigidMotion{}, 0.0});
  const Eigen::Vector3d g = standard_gravity();
  NewmarkIntegrator integrator({}, constraints, g);
  const double e0 = mechanical_energy(body, g);
  Index contacts = 0;
  while (integrator.time() < 1.0) {
    contacts += integrator.step(body, 1.0 - integrator.time()).collisions;
    ASSERT_GE(body.positions.col(2).minCoeff(), 0.0);
  }
  EXPECT_GT(contacts, 0);
  // Removing inward normal velocity never adds energy; the Verlet energy
  // oscillation is O(Δt²) ≈ 1e-3 of e0 at this step size.
  EXPECT_LT(mechanical_energy(body, g), e0 * (1.0 + 1e-2));
  EXPECT_LT(body.positions.col(2).maxCoeff(), 0.4 + 1e-9) << "no bounce above the drop height";
}

TEST(Newmark, PinnedNodesStayAndPrescribedNodesFollowTheirPath) {
  Body body = make_cube(ElasticModel::fixed_corotated, 2, 1.0);
  Constraints constraints;
  constraints.pinned = {0};
  PrescribedMotion motion;
  motion.nodes = {static_cast<Index>(body.num_nodes() - 1)};
  motion.position = [](Index, const Eigen::Vector3d& rest, double t) {
    return Eigen::Vector3d(rest + Eigen::Vector3d(0.1 * t, 0.0, 0.0));
  };
  constraints.prescribed.push_back(motion);
  NewmarkIntegrator integrator(NewmarkSettings{}, constraints);
  integrator.advance_to(body, 0.5);
  EXPECT_TRUE(test::matrices_near(body.positions.row(0), body.rest_positions.row(0), 0.0));
  const Index last = body.num_nodes() - 1;
  EXPECT_TRUE(test::matrices_near(body.positions.row(last),
                                  body.rest_positions.row(last) + Eigen::RowVector3d(0.05, 0.0, 0.0), 1e-12));
}

TEST(Newmark, BitwiseIdenticalAfter100StepsWithOneAndTwoThreads) {
  std::vector<Points> results;
  for (const int threads : {1, 2}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Body body = make_cube(ElasticModel::neo_hookean, 4, 3.0);
    body.material.yield_stress = 100.0;
    body.material.flow_rate = 5.0;
    kick(body, 2);
    NewmarkIntegrator integrator(NewmarkSettings{}, {});
    for (int i = 0; i < 100; ++i) integrator.step(body, 1.0);
    Points state(body.num_nodes(), 6);
    state << body.positions, body.velocities;
    results.push_back(state);
  }
  EXPECT_TRUE(results[0] == results[1]);
}

// The damping solve's passes split the nodes into runs of 256, the runs
// shared evenly among an arena's threads; its sums go run by run. A viscous
// block of 1,331 nodes (six runs) in arenas of 1, 2 and 3 threads (the
// runs split 6, 3 + 3 and 2 + 2 + 2): the same bits.
TEST(Newmark, DampingSolveOverManyRunsIsBitwiseTheSameInArenasOfOneTwoAndThreeThreads) {
  std::vector<Points> results;
  for (const int threads : {1, 2, 3}) {
    tbb::task_arena arena(threads);
    arena.execute([&] {
      Body body = make_cube(ElasticModel::neo_hookean, 10, 30.0);
      ASSERT_GT(body.num_nodes(), 5 * 256);
      kick(body, 2);
      NewmarkIntegrator integrator(NewmarkSettings{}, {});
      StepReport report;
      for (int i = 0; i < 20; ++i) report = integrator.step(body, 1.0);
      EXPECT_GT(report.damping.iterations, 0);
      Points state(body.num_nodes(), 6);
      state << body.positions, body.velocities;
      results.push_back(state);
    });
  }
  ASSERT_EQ(results.size(), 3U);
  EXPECT_TRUE(results[0] == results[1]);
  EXPECT_TRUE(results[0] == results[2]);
}

TEST(Newmark, RefusesImpossibleSettings) {
  NewmarkSettings s;
  s.cfl = 1.5;
  EXPECT_THROW(NewmarkIntegrator(s, {}), Error);
  NewmarkSettings p;
  p.preconditioner_strain = -0.1;
  EXPECT_TRUE(test::throws_error_containing([&] { NewmarkIntegrator(p, {}); }, "preconditioner_strain"));
  p = NewmarkSettings{};
  p.preconditioner_strain = std::nan("");
  EXPECT_TRUE(test::throws_error_containing([&] { NewmarkIntegrator(p, {}); }, "preconditioner_strain"));
  p = NewmarkSettings{};
  p.preconditioner_steps = 0;
  EXPECT_TRUE(test::throws_error_containing([&] { NewmarkIntegrator(p, {}); }, "preconditioner_steps"));
  for (const double tolerance : {0.0, -1e-4, 0.5}) {
    NewmarkSettings v;
    v.volume_tolerance = tolerance;
    EXPECT_TRUE(test::throws_error_containing([&] { NewmarkIntegrator(v, {}); }, "newmark.volume_tolerance must be in"));
    BackwardEulerSettings b;
    b.volume_tolerance = tolerance;
    EXPECT_TRUE(test::throws_error_containing([&] { BackwardEulerIntegrator(b, {}); },
                                              "backward_euler.volume_tolerance must be in"));
  }
}

}  // namespace
}  // namespace goo
