// The Integrator interface (solvers/integrator.h): for every integrator,
// step is next_time_step, begin_step and finish_step in a row, bit for bit;
// an implicit begin_step that must halve covers several steps in one
// report and lands on the common time exactly.
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "core/error.h"
#include "core/tet_mesh.h"
#include "solvers/backward_euler.h"
#include "solvers/newmark.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

enum class Kind { newmark, backward_euler, statics };

std::string name_of(Kind k) {
  return k == Kind::newmark ? "newmark" : k == Kind::backward_euler ? "backward_euler" : "static";
}

/// A 10 cm cube of 3³ cells, spinning and falling; its x = 0 face pinned
/// for the static solve (which needs held nodes).
Body spinning_cube() {
  Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.1), Eigen::Vector3i::Constant(3)),
                        test::material(ElasticModel::neo_hookean, 1e5, 0.3, 2.0));
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d r = body.rest_positions.row(n).transpose() - Eigen::Vector3d::Constant(0.05);
    body.velocities.row(n) = (Eigen::Vector3d(0.2, 0.0, -1.0) + Eigen::Vector3d(3.0, -2.0, 5.0).cross(r)).transpose();
  }
  return body;
}

std::unique_ptr<Integrator> make_integrator(Kind kind, const Body& body, int max_newton_iterations = 30) {
  Constraints constraints;
  if (kind == Kind::statics)
    for (Index n = 0; n < body.num_nodes(); ++n)
      if (body.rest_positions(n, 0) == 0.0) constraints.pinned.push_back(n);
  if (kind == Kind::newmark) return std::make_unique<NewmarkIntegrator>(NewmarkSettings{}, constraints);
  BackwardEulerSettings settings;
  settings.statics = kind == Kind::statics;
  settings.time_step = 4e-3;
  settings.max_newton_iterations = max_newton_iterations;
  return std::make_unique<BackwardEulerIntegrator>(settings, constraints);
}

class EveryIntegrator : public ::testing::TestWithParam<Kind> {};

TEST_P(EveryIntegrator, StepIsBeginThenFinishBitForBit) {
  Body whole = spinning_cube(), halves = spinning_cube();
  if (GetParam() == Kind::statics) whole.velocities.setZero(), halves.velocities.setZero();
  const auto a = make_integrator(GetParam(), whole), b = make_integrator(GetParam(), halves);
  for (int step = 0; step < 4; ++step) {
    const double max_dt = 0.014 - a->time();  // backward Euler: three full steps, then one cut short
    const StepReport one = a->step(whole, max_dt);
    const double dt = b->next_time_step(halves, max_dt);
    b->begin_step(halves, dt);
    const StepReport two = b->finish_step(halves);
    ASSERT_EQ(one.dt, dt) << "step " << step;
    EXPECT_EQ(two.dt, one.dt);
    EXPECT_EQ(one.steps, 1);
    EXPECT_EQ(two.steps, 1);
    EXPECT_EQ(a->time(), b->time());
    EXPECT_EQ(whole.positions, halves.positions) << "step " << step;
    EXPECT_EQ(whole.velocities, halves.velocities) << "step " << step;
    EXPECT_EQ(whole.Fp, halves.Fp) << "step " << step;
  }
  EXPECT_GT(a->reference_step(), 0.0);
  EXPECT_EQ(a->failure_advice().empty(), GetParam() == Kind::newmark);  // only Newton's failures are numerical
}

INSTANTIATE_TEST_SUITE_P(Integrator, EveryIntegrator,
                         ::testing::Values(Kind::newmark, Kind::backward_euler, Kind::statics),
                         [](const auto& param_info) { return name_of(param_info.param); });

// Backward Euler with too few Newton iterations for its step halves it:
// begin_step to the common time then takes several steps, which its one
// report sums, and the clock lands on t0 + dt exactly, as advance_to's.
TEST(Integrator, AnImplicitBeginStepThatHalvesReportsEveryStepItTook) {
  Body body = spinning_cube(), reference = spinning_cube();
  body.velocities *= 20.0, reference.velocities *= 20.0;  // fast enough that 2 iterations do not converge
  const auto a = make_integrator(Kind::backward_euler, body, 2), b = make_integrator(Kind::backward_euler, reference, 2);
  const double dt = a->next_time_step(body, 1.0);
  ASSERT_EQ(dt, 4e-3);
  a->begin_step(body, dt);
  const StepReport report = a->finish_step(body);
  EXPECT_GT(report.halvings, 0);
  EXPECT_GT(report.steps, 1);
  EXPECT_EQ(a->time(), dt);
  EXPECT_NEAR(report.dt, dt, 1e-15);
  EXPECT_EQ(static_cast<std::size_t>(report.iterations) <= report.residuals.size(), true);
  EXPECT_EQ(b->advance_to(reference, dt), report.steps);
  EXPECT_EQ(b->time(), a->time());
  EXPECT_EQ(body.positions, reference.positions);
  EXPECT_EQ(body.velocities, reference.velocities);
}

// The paper's tension forces (W&T eq. 6) are not the gradient of an
// energy, which backward Euler and the static solve minimise.
TEST(Integrator, AnImplicitIntegratorRefusesTensionForcesWithoutAnEnergy) {
  const SurfaceTensionSettings paper{SurfaceTensionForm::paper, 0.0};
  EXPECT_TRUE(test::throws_error_containing([&] { BackwardEulerIntegrator({}, {}, standard_gravity(), paper); },
                                            "surface_tension.form"));
  EXPECT_NO_THROW(NewmarkIntegrator({}, {}, standard_gravity(), paper));
}

}  // namespace
}  // namespace goo
