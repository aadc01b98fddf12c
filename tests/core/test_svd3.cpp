#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include "core/svd3.h"
#include "core/svd3_batch.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
}

/// Repeated, zero and inverted singular values over 200 orders of magnitude.
std::vector<Eigen::Vector3d> hard_spectra() {
  return {
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
      // Largest entries subnormal or near overflow: F's scale is a power
      // of two, clamped to the least normal double.
      {3e-310, 2e-310, 1e-310},
      {1e300, 3e299, -1e299},
  };
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
  const std::vector<Eigen::Vector3d> spectra = hard_spectra();
  for (const auto& spectrum : spectra)
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Matrix3d F = random_rotation(rng) * spectrum.asDiagonal() * random_rotation(rng).transpose();
      expect_valid(F, svd3(F));
    }
}

/// F = diag(1, B) with B a 2×2 block of order 1e-80: FᵀF's block is of
/// order 1e-160, so its Jacobi rotation's d² + e² (d = a_qq − a_pp, e =
/// 2 a_pq) lies far below the least normal double, where a subnormal keeps
/// a dozen bits: the rotation is exact only if (d, e) is scaled up first.
Eigen::Matrix3d tiny_block(double a, double b, double c, double d) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  F.bottomRightCorner<2, 2>() << a, b, c, d;
  F *= 1e-80;
  F(0, 0) = 1.0;
  return F;
}

TEST(Svd3, PairsTooSmallToSquareStillRotateExactly) {
  for (const Eigen::Matrix3d& F :
       {tiny_block(1.0, 0.5, 0.3, 1.0), tiny_block(2.0, -0.7, 0.4, 0.5), tiny_block(1.0, 1.0, -1.0, 1.0)})
    expect_valid(F, svd3(F));
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

/// Matrices that exercise every branch of svd3: random ones, repeated, zero
/// and inverted singular values (hard_spectra), F = 0, and
/// non-finite entries.
std::vector<Eigen::Matrix3d> hard_matrices() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Matrix3d> out;
  for (int i = 0; i < 4000; ++i) {
    Eigen::Matrix3d F;
    for (int k = 0; k < 9; ++k) F(k % 3, k / 3) = u(rng);
    out.push_back(F);
  }
  const std::vector<Eigen::Vector3d> spectra = hard_spectra();
  for (const auto& spectrum : spectra)
    for (int trial = 0; trial < 40; ++trial)
      out.emplace_back(random_rotation(rng) * spectrum.asDiagonal() * random_rotation(rng).transpose());
  // Axis-aligned: the exact zeros that make the Gram–Schmidt fall back.
  out.emplace_back(Eigen::Matrix3d::Identity());
  out.emplace_back(Eigen::Matrix3d::Zero());
  out.emplace_back(Eigen::Vector3d(1, 1, -1).asDiagonal());
  out.emplace_back(Eigen::Vector3d(2, 0, 0).asDiagonal());
  out.push_back(tiny_block(1.0, 0.5, 0.3, 1.0));
  out.push_back(tiny_block(2.0, -0.7, 0.4, 0.5));
  Eigen::Matrix3d rank_one = Eigen::Matrix3d::Zero();
  rank_one.col(1) = Eigen::Vector3d(0, 0, 3);
  out.push_back(rank_one);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
  bad(0, 0) = nan;
  out.push_back(bad);
  bad(0, 0) = 1.0;
  bad(2, 1) = nan;
  out.push_back(bad);
  bad(2, 1) = inf;
  out.push_back(bad);
  return out;
}

bool same_bits(const Svd3& a, const Svd3& b) {
  return std::memcmp(a.U.data(), b.U.data(), sizeof(double) * 9) == 0 &&
         std::memcmp(a.V.data(), b.V.data(), sizeof(double) * 9) == 0 &&
         std::memcmp(a.sigma.data(), b.sigma.data(), sizeof(double) * 3) == 0;
}

// The batch's contract: every lane gives svd3's bits at every instruction-set
// level this processor has, whatever the other lanes hold (lanes that
// converge late, or never, as NaN does, change nothing in the others).
TEST(Svd3Batch, EveryLevelGivesSvd3sBitsInEveryLane) {
  const auto matrices = hard_matrices();
  std::mt19937 rng(3);
  int levels = 0;
  for (const SimdLevel level : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512}) {
    if (!simd_level_supported(level)) continue;
    ++levels;
    // In order (neighbours alike), then shuffled (a hard lane among easy ones).
    for (int pass = 0; pass < 2; ++pass) {
      std::vector<std::size_t> order(matrices.size());
      for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
      if (pass == 1) std::shuffle(order.begin(), order.end(), rng);
      int differing = 0;
      for (std::size_t first = 0; first + kSvdLanes <= order.size(); first += kSvdLanes) {
        Svd3Batch batch{};
        for (int lane = 0; lane < kSvdLanes; ++lane)
          for (int k = 0; k < 9; ++k)
            batch.F[k][lane] = matrices[order[first + static_cast<std::size_t>(lane)]].data()[k];
        svd3_batch(batch, level);
        for (int lane = 0; lane < kSvdLanes; ++lane) {
          Svd3 s;
          for (int k = 0; k < 9; ++k) {
            s.U.data()[k] = batch.U[k][lane];
            s.V.data()[k] = batch.V[k][lane];
          }
          for (int k = 0; k < 3; ++k) s.sigma[k] = batch.sigma[k][lane];
          if (!same_bits(s, svd3(matrices[order[first + static_cast<std::size_t>(lane)]]))) ++differing;
        }
      }
      EXPECT_EQ(differing, 0) << simd_level_name(level) << (pass == 0 ? ", in order" : ", shuffled");
    }
  }
  EXPECT_GE(levels, 1);
  EXPECT_TRUE(simd_level_supported(active_simd_level()));
}

TEST(Svd3Batch, ZeroAndNonFiniteLanesGiveTheIdentityOrNaNsNotHangs) {
  Svd3Batch batch{};
  // All lanes zero but one NaN: σ = 0 and U = V = I for F = 0.
  batch.F[4][3] = std::numeric_limits<double>::quiet_NaN();
  svd3_batch(batch);
  for (int lane = 0; lane < kSvdLanes; ++lane) {
    if (lane == 3) continue;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(batch.sigma[k][lane], 0.0);
    for (int k = 0; k < 9; ++k) EXPECT_EQ(batch.U[k][lane], k % 4 == 0 ? 1.0 : 0.0);
  }
  EXPECT_TRUE(std::isnan(batch.sigma[0][3]) || batch.sigma[0][3] == 0.0);
}

}  // namespace
}  // namespace goo
