#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "core/elasticity.h"
#include "core/error.h"
#include "tests/common/finite_differences.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using test::kModels;

IsotropicEnergy make(ElasticModel model) {
  Material m;
  m.model = model;
  m.youngs_modulus = 1e5;
  m.poisson_ratio = 0.35;
  return IsotropicEnergy(m);
}

Eigen::Matrix3d random_F(std::mt19937& rng, bool inverted) {
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  for (int k = 0; k < 9; ++k) F(k % 3, k / 3) += u(rng);
  if (inverted) F.col(2) = -F.col(2);
  return F;
}

Eigen::Matrix3d P_of(const IsotropicEnergy& energy, const Eigen::Matrix3d& F) {
  return first_piola(energy, svd3(F));
}

class Model : public ::testing::TestWithParam<ElasticModel> {};

TEST_P(Model, StressFreeAtRestAndZeroEnergy) {
  const IsotropicEnergy e = make(GetParam());
  EXPECT_NEAR(e.psi(Eigen::Vector3d::Ones()), 0.0, 1e-10);
  EXPECT_TRUE(test::matrices_near(P_of(e, Eigen::Matrix3d::Identity()), Eigen::Matrix3d::Zero(), 1e-10));
}

TEST_P(Model, RotationInvariantEnergyAndCovariantStress) {
  const IsotropicEnergy e = make(GetParam());
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Matrix3d F = random_F(rng, i % 2 == 1);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3 + i, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
    EXPECT_NEAR(energy_density(e, R * F), energy_density(e, F), 1e-9 * e.mu());
    EXPECT_TRUE(test::matrices_near(P_of(e, R * F), R * P_of(e, F), 1e-9 * e.mu()));
  }
}

TEST_P(Model, LinearisesToLinearElasticity) {
  // P(I + εH) = ε (2μ sym H + λ tr H I) + O(ε²): the error over ε shrinks
  // linearly with ε.
  const IsotropicEnergy e = make(GetParam());
  Material m;
  m.youngs_modulus = 1e5;
  m.poisson_ratio = 0.35;
  Eigen::Matrix3d H;
  H << 0.3, -0.2, 0.5, 0.1, -0.4, 0.2, 0.7, 0.3, 0.1;
  const Eigen::Matrix3d linear =
      2.0 * m.mu() * 0.5 * (H + H.transpose()) + m.lambda() * H.trace() * Eigen::Matrix3d::Identity();
  double previous = 0.0;
  for (const double eps : {1e-3, 5e-4, 2.5e-4}) {
    const double error = (P_of(e, Eigen::Matrix3d::Identity() + eps * H) / eps - linear).norm();
    if (previous > 0.0) {
      EXPECT_NEAR(previous / error, 2.0, 0.05);
    }
    previous = error;
  }
}

/// Central differences: error = h²/6 |∂³ψ| + round-off ε|ψ|/h. The third
/// derivative is at most ≈ 1/c² = 25 times the stress scale (the
/// neo-Hookean's continued logarithm bends hardest), so at h = 10⁻³ the
/// truncation is ≲ 5·10⁻⁶ of max(μ, |P|); 10⁻⁴ leaves a margin. Halving h
/// must divide the error by about 4 (second order), which is the real check.
TEST_P(Model, StressIsTheEnergyGradientToSecondOrder) {
  const IsotropicEnergy e = make(GetParam());
  std::mt19937 rng(4);
  for (int i = 0; i < 10; ++i) {
    const Eigen::Matrix3d F = random_F(rng, i % 2 == 1);
    const Eigen::Matrix3d P = P_of(e, F);
    const auto psi = [&](const Eigen::Matrix3d& G) { return energy_density(e, G); };
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> gradient(P.data());
    const double size = std::max(e.mu(), P.norm());
    EXPECT_TRUE(test::second_order(test::check_derivative(psi, F, gradient, 1e-3, test::ErrorNorm::frobenius),
                                   1e-4 * size, 1e-9 * size))
        << "F =\n"
        << F;
  }
}

TEST_P(Model, StressDerivativeMatchesFiniteDifferencesToSecondOrder) {
  const IsotropicEnergy e = make(GetParam());
  std::mt19937 rng(5);
  for (int i = 0; i < 10; ++i) {
    const Eigen::Matrix3d F = random_F(rng, i % 2 == 1);
    const Matrix9d dPdF = first_piola_derivative(e, svd3(F));
    const auto P = [&](const Eigen::Matrix3d& G) { return P_of(e, G); };
    const double size = std::max(e.mu(), dPdF.norm());
    EXPECT_TRUE(test::second_order(test::check_derivative(P, F, dPdF, 1e-3, test::ErrorNorm::frobenius), 1e-4 * size,
                                   1e-9 * size))
        << "F =\n"
        << F;
  }
}

TEST_P(Model, StressDerivativeIsSymmetric) {
  // dP/dF is the Hessian of ψ(F), hence symmetric.
  const IsotropicEnergy e = make(GetParam());
  std::mt19937 rng(6);
  for (int i = 0; i < 20; ++i) {
    const Matrix9d dPdF = first_piola_derivative(e, svd3(random_F(rng, i % 2 == 1)));
    EXPECT_TRUE(test::matrices_near(dPdF, dPdF.transpose(), 1e-9 * e.mu()));
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, Model, ::testing::ValuesIn(kModels),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

TEST(NeoHookean, IsExactlyTheStandardEnergyAboveTheThreshold) {
  const IsotropicEnergy e = make(ElasticModel::neo_hookean);
  const Eigen::Vector3d s(1.3, 0.8, 0.25);
  const double J = s.prod();
  const double expected =
      0.5 * e.mu() * (s.squaredNorm() - 3) - e.mu() * std::log(J) + 0.5 * e.lambda() * std::log(J) * std::log(J);
  EXPECT_NEAR(e.psi(s), expected, 1e-12 * std::abs(expected));
}

TEST(Material, RefusesImpossibleParametersNamingTheField) {
  Material m;
  m.poisson_ratio = 0.5;
  try {
    validate(m);
    FAIL();
  } catch (const Error& err) {
    EXPECT_STREQ(err.what(), "material.poisson_ratio must be in [0, 0.5), got 0.5");
  }
  m = Material{};
  m.density = -1.0;
  EXPECT_THROW(validate(m, "scene.objects[0].material"), Error);
  EXPECT_THROW(elastic_model_from_string("hookean"), Error);
}

}  // namespace
}  // namespace goo
