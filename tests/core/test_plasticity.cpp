#include <gtest/gtest.h>

#include "core/plasticity.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Material plastic_material(double yield, double flow_rate, double hardening) {
  Material m;
  m.youngs_modulus = 1e5;
  m.poisson_ratio = 0.3;
  m.yield_stress = yield;
  m.flow_rate = flow_rate;
  m.hardening = hardening;
  return m;
}

const Eigen::Matrix3d kStretch = (Eigen::Matrix3d() << 1.3, 0.1, 0.0, 0.0, 0.85, 0.05, 0.02, 0.0, 0.95).finished();

/// Holds F fixed and lets Fp flow for `steps` steps covering `duration`.
Eigen::Matrix3d flow(const Material& m, double duration, int steps, double* alpha_out = nullptr,
                     int* flowed = nullptr) {
  const IsotropicEnergy energy(m);
  Eigen::Matrix3d Fp = Eigen::Matrix3d::Identity();
  double alpha = 0.0;
  int count = 0;
  for (int i = 0; i < steps; ++i) {
    Svd3 svd = svd3(kStretch * Fp.inverse());
    count += plastic_flow(m, energy, duration / steps, svd, Fp, alpha) ? 1 : 0;
  }
  if (alpha_out) *alpha_out = alpha;
  if (flowed) *flowed = count;
  return Fp;
}

TEST(Plasticity, NoFlowBelowYield) {
  const Material m = plastic_material(1e9, 10.0, 0.0);
  EXPECT_TRUE(flow(m, 1.0, 10) == Eigen::Matrix3d::Identity());
}

TEST(Plasticity, FlowPreservesDetFpAndReducesStress) {
  const Material m = plastic_material(1e3, 5.0, 0.0);
  const Eigen::Matrix3d Fp = flow(m, 0.5, 50);
  EXPECT_NEAR(Fp.determinant(), 1.0, 1e-13);
  const IsotropicEnergy e(m);
  const auto deviatoric = [&](const Eigen::Matrix3d& Fe) {
    const Eigen::Vector3d P = e.dpsi(svd3(Fe).sigma);
    return (P.array() - P.mean()).matrix().norm();
  };
  EXPECT_LT(deviatoric(kStretch * Fp.inverse()), 0.9 * deviatoric(kStretch));
}

TEST(Plasticity, UpdatedSingularValuesAreThoseOfTheNewFe) {
  const Material m = plastic_material(1e3, 5.0, 0.0);
  const IsotropicEnergy energy(m);
  Eigen::Matrix3d Fp = Eigen::Matrix3d::Identity();
  double alpha = 0.0;
  Svd3 svd = svd3(kStretch);
  ASSERT_TRUE(plastic_flow(m, energy, 0.01, svd, Fp, alpha));
  EXPECT_TRUE(test::matrices_near(svd.U * svd.sigma.asDiagonal() * svd.V.transpose(), kStretch * Fp.inverse(), 1e-13));
}

TEST(Plasticity, RateIndependentFirstOrderInTheTimeStep) {
  // Fp(T) from n steps converges at first order: the difference between n
  // and 2n steps halves when n doubles, and the material does not depend on
  // the time step in the limit.
  const Material m = plastic_material(1e3, 2.0, 0.0);
  const double T = 0.2;
  const double d1 = (flow(m, T, 10) - flow(m, T, 20)).norm();
  const double d2 = (flow(m, T, 20) - flow(m, T, 40)).norm();
  const double d3 = (flow(m, T, 40) - flow(m, T, 80)).norm();
  EXPECT_NEAR(d1 / d2, 2.0, 0.2);
  EXPECT_NEAR(d2 / d3, 2.0, 0.1);
  EXPECT_LT(d1, 0.05 * (flow(m, T, 80) - Eigen::Matrix3d::Identity()).norm());
}

TEST(Plasticity, HardeningStopsFlowWhileStressIsStillAboveYield) {
  const Material soft = plastic_material(1e3, 20.0, 0.0);
  const Material hard = plastic_material(1e3, 20.0, 50.0);
  double alpha = 0.0;
  int flowed = 0;
  const Eigen::Matrix3d Fp = flow(hard, 5.0, 500, &alpha, &flowed);
  EXPECT_GT(alpha, 0.0);
  EXPECT_LT(flowed, 500) << "hardening must stop the flow";
  const IsotropicEnergy e(hard);
  const Eigen::Vector3d P = e.dpsi(svd3(kStretch * Fp.inverse()).sigma);
  const double s = (P.array() - P.mean()).matrix().norm();
  EXPECT_GT(s, hard.yield_stress) << "stopped by hardening, not by relaxation";
  EXPECT_LE(s, hard.yield_stress + hard.hardening * alpha);
  EXPECT_GT((flow(soft, 5.0, 500) - Eigen::Matrix3d::Identity()).norm(), (Fp - Eigen::Matrix3d::Identity()).norm());
}

TEST(Plasticity, NearlyInvertedElementsDoNotFlow) {
  const Material m = plastic_material(0.0, 100.0, 0.0);
  const IsotropicEnergy energy(m);
  Eigen::Matrix3d Fp = Eigen::Matrix3d::Identity();
  double alpha = 0.0;
  Svd3 svd = svd3(Eigen::Vector3d(1.5, 1.0, 0.01).asDiagonal());
  EXPECT_FALSE(plastic_flow(m, energy, 0.1, svd, Fp, alpha));
  EXPECT_TRUE(Fp == Eigen::Matrix3d::Identity());
}

}  // namespace
}  // namespace goo
