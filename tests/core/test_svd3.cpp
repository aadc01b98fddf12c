#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "core/svd3.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

/// Every property the rotation-variant SVD promises, with ε-derived bounds:
/// the reconstruction and orthogonality errors are a few ε per operation.
void expect_valid(const Eigen::Matrix3d& F, const Svd3& s) {
  const double scale = std::max(F.norm(), std::numeric_limits<double>::min());
  const Eigen::Matrix3d back = s.U * s.sigma.asDiagonal() * s.V.transpose();
  EXPECT_LE((back - F).norm(), 1e-12 * scale) << "F =\n" << F;
  EXPECT_NEAR(s.U.determinant(), 1.0, 1e-12);
  EXPECT_NEAR(s.V.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(test::matrices_near(s.U.transpose() * s.U, Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_TRUE(test::matrices_near(s.V.transpose() * s.V, Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_GE(s.sigma[0], s.sigma[1]);
  EXPECT_GE(s.sigma[1], std::abs(s.sigma[2]) - 1e-12 * scale);
  if (std::abs(F.determinant()) > 1e-9 * scale * scale * scale) {
    EXPECT_EQ(s.sigma[2] < 0.0, F.determinant() < 0.0) << "inversion must show in σ3";
  }
  // The singular values are unique even where the vectors are not.
  const Svd3 reference = svd3_reference(F);
  EXPECT_TRUE(test::matrices_near(s.sigma, reference.sigma, 1e-12 * scale));
}

TEST(Svd3, RandomMatrices) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 2000; ++i) {
    Eigen::Matrix3d F;
    for (int k = 0; k < 9; ++k) F(k % 3, k / 3) = u(rng);
    expect_valid(F, svd3(F));
  }
}

TEST(Svd3, RepeatedZeroAndInvertedSingularValues) {
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector3d> spectra = {
      {1, 1, 1},
      {2, 2, 1},
      {2, 1, 1},
      {3, 2, 0},
      {1, 0, 0},
      {0, 0, 0},
      {1, 1, -1},
      {2, 1, -0.5},
      {1, 0.5, -0.5},
      {1, 1, 0},
      {1e-8, 1e-8, 1e-8},
      {5, 1e-9, -1e-9},
      {1, 1 + 1e-15, 1 - 1e-15},
      {1e100, 1, 1e-100},
  };
  for (const auto& spectrum : spectra)
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Matrix3d F = random_rotation(rng) * spectrum.asDiagonal() * random_rotation(rng).transpose();
      expect_valid(F, svd3(F));
    }
}

TEST(Svd3, ExactCases) {
  const Svd3 identity = svd3(Eigen::Matrix3d::Identity());
  EXPECT_TRUE(test::matrices_near(identity.sigma, Eigen::Vector3d::Ones(), 0.0));
  const Svd3 zero = svd3(Eigen::Matrix3d::Zero());
  EXPECT_TRUE(test::matrices_near(zero.sigma, Eigen::Vector3d::Zero(), 0.0));
  EXPECT_NEAR(zero.U.determinant(), 1.0, 1e-15);
  // A reflection: one negative singular value, rotations on both sides.
  const Eigen::Matrix3d mirror = Eigen::Vector3d(1, 1, -1).asDiagonal();
  const Svd3 m = svd3(mirror);
  EXPECT_TRUE(test::matrices_near(m.sigma, Eigen::Vector3d(1, 1, -1), 1e-15));
  expect_valid(mirror, m);
}

}  // namespace
}  // namespace goo
