#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <array>
#include <cstring>
#include <limits>
#include <random>

#include "core/body.h"
#include "core/damping.h"
#include "core/elastic_forces.h"
#include "core/error.h"
#include "core/plasticity.h"
#include "core/svd3.h"
#include "tests/common/finite_differences.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using test::kModels;

Body make_cube(ElasticModel model, int cells = 3) {
  Material m;
  m.model = model;
  m.youngs_modulus = 1e5;
  m.poisson_ratio = 0.3;
  return make_body(make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Constant(cells)), m);
}

/// The force scale of a deformation of size δ: E h² δ (h the cell size).
double force_scale(const Body& body, double delta, int cells) {
  return body.material.youngs_modulus * delta / (cells * cells);
}

class Forces : public ::testing::TestWithParam<ElasticModel> {};

TEST_P(Forces, ZeroAtRestAndUnderRigidMotion) {
  Body body = make_cube(GetParam());
  ElasticForces forces;
  Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  EXPECT_LE(f.cwiseAbs().maxCoeff(), 1e-9 * force_scale(body, 1.0, 3));
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2.1, Eigen::Vector3d(1, 1, -1).normalized()).toRotationMatrix();
  Points x = body.rest_positions;
  for (Index n = 0; n < body.num_nodes(); ++n)
    x.row(n) = (R * x.row(n).transpose() + Eigen::Vector3d(3, -1, 2)).transpose();
  forces.evaluate(body, x, 0.0, f);
  EXPECT_LE(f.cwiseAbs().maxCoeff(), 1e-9 * force_scale(body, 1.0, 3));
}

TEST_P(Forces, PatchTestAffineDeformationLeavesInteriorNodesInEquilibrium) {
  Body body = make_cube(GetParam(), 4);
  Eigen::Matrix3d A;
  A << 1.1, 0.05, -0.02, 0.03, 0.95, 0.04, -0.01, 0.02, 1.05;
  Points x = body.rest_positions;
  for (Index n = 0; n < body.num_nodes(); ++n) x.row(n) = (A * x.row(n).transpose()).transpose();
  ElasticForces forces;
  Points f;
  forces.evaluate(body, x, 0.0, f);
  double interior_max = 0.0, boundary_max = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d p = body.rest_positions.row(n);
    const bool interior = (p.array() > 1e-9).all() && (p.array() < 1.0 - 1e-9).all();
    (interior ? interior_max : boundary_max) = std::max(interior ? interior_max : boundary_max, f.row(n).norm());
  }
  EXPECT_GT(boundary_max, 1e-3 * force_scale(body, 0.1, 4)) << "the deformation must load the boundary";
  // Constant stress: interior sums cancel up to round-off of the stress.
  EXPECT_LE(interior_max, 1e-10 * force_scale(body, 1.0, 4));
  // The net force on the whole body is zero.
  EXPECT_LE(f.colwise().sum().norm(), 1e-10 * force_scale(body, 1.0, 4));
}

TEST_P(Forces, AreMinusTheEnergyGradient) {
  Body body = make_cube(GetParam(), 2);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.08, 0.08);
  Points x = body.rest_positions;
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) x(n, k) += u(rng);
  ElasticForces forces;
  Points f;
  forces.evaluate(body, x, 0.0, f);
  std::vector<Index> every_third_node;
  for (Index n = 0; n < body.num_nodes(); n += 3)
    for (int k = 0; k < 3; ++k) every_third_node.push_back(3 * n + k);
  const auto energy = [&](const Points& y) { return elastic_energy(body, y); };
  const Eigen::VectorXd gradient = -Eigen::Map<const Eigen::VectorXd>(f.data(), f.size());
  const double scale = force_scale(body, 1.0, 2);
  EXPECT_TRUE(test::second_order(
      test::check_derivative(energy, x, gradient, 1e-5, test::ErrorNorm::max_entry, every_third_node), 1e-6 * scale,
      1e-8 * scale));
}

INSTANTIATE_TEST_SUITE_P(AllModels, Forces, ::testing::ValuesIn(kModels),
                         [](const auto& param_info) { return std::string(to_string(param_info.param)); });

TEST(Forces, BitwiseIdenticalForOneTwoAndEightThreads) {
  Body body = make_cube(ElasticModel::fixed_corotated, 8);
  body.material.viscosity = 5.0;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  Points x = body.rest_positions, v = body.rest_positions;
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) {
      x(n, k) += u(rng);
      v(n, k) = u(rng);
    }
  std::vector<Points> results;
  for (const int threads : {1, 2, 8}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    ElasticForces forces;
    Damping damping;
    Points f, fd;
    forces.evaluate(body, x, 0.0, f);
    damping.freeze(body, forces);
    damping.apply(body, v, fd);
    Points both(f.rows(), 6);
    both << f, fd;
    results.push_back(both);
  }
  EXPECT_TRUE(results[0] == results[1]);
  EXPECT_TRUE(results[0] == results[2]);
}

/// The body's rest positions sheared and stretched by a fixed map: a
/// deformed configuration, not the rest shape.
Points sheared(const Body& body) {
  Eigen::Matrix3d A;
  A << 1.3, 0.2, 0.0, -0.1, 0.8, 0.15, 0.05, 0.0, 1.1;
  Points x = body.rest_positions;
  for (Index n = 0; n < body.num_nodes(); ++n) x.row(n) = (A * x.row(n).transpose()).transpose();
  return x;
}

/// A cube of three cells a side, of viscosity β, sheared (x) with its
/// elastic forces evaluated there: what a damping operator freezes at.
struct ShearedCube {
  Body body;
  Points x;
  ElasticForces forces;
};
ShearedCube sheared_cube(double viscosity) {
  ShearedCube c{make_cube(ElasticModel::fixed_corotated, 3), {}, {}};
  c.body.material.viscosity = viscosity;
  c.x = sheared(c.body);
  Points f;
  c.forces.evaluate(c.body, c.x, 0.0, f);
  return c;
}

TEST(Damping, ZeroForRigidMotionOfADeformedBodyTorqueFreeAndDissipative) {
  const ShearedCube cube = sheared_cube(10.0);
  const Body& body = cube.body;
  const Points& x = cube.x;
  const ElasticForces& forces = cube.forces;
  Damping damping;
  damping.freeze(body, forces);
  auto apply = [&](const Points& v, Points& out) { damping.apply(body, v, out); };
  // A rigid velocity field v = ω × x + c dissipates nothing.
  const Eigen::Vector3d omega(0.3, -1.2, 0.7), c(1, 2, 3);
  Points v(body.num_nodes(), 3);
  for (Index n = 0; n < body.num_nodes(); ++n) v.row(n) = (omega.cross(Eigen::Vector3d(x.row(n))) + c).transpose();
  Points fd;
  apply(v, fd);
  // Scale of a damping force for unit strain rate: β h² (h = 1/3).
  const double scale = 10.0 / 9.0;
  EXPECT_LE(fd.cwiseAbs().maxCoeff(), 1e-12 * scale * omega.norm());
  // Any field: the damping forces sum to zero and exert no torque.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  Points a(body.num_nodes(), 3), b(body.num_nodes(), 3), fa, fb;
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) {
      a(n, k) = u(rng);
      b(n, k) = u(rng);
    }
  apply(a, fa);
  apply(b, fb);
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
  for (Index n = 0; n < body.num_nodes(); ++n) torque += Eigen::Vector3d(x.row(n)).cross(Eigen::Vector3d(fa.row(n)));
  const double magnitude = fa.cwiseAbs().maxCoeff();
  EXPECT_LE(fa.colwise().sum().norm(), 1e-12 * magnitude * body.num_nodes());
  EXPECT_LE(torque.norm(), 1e-12 * magnitude * body.num_nodes());
  // Dissipative and symmetric: aᵀ f(a) = −aᵀ C a < 0, aᵀ C b = bᵀ C a.
  EXPECT_LT(a.cwiseProduct(fa).sum(), 0.0);
  EXPECT_NEAR(a.cwiseProduct(fb).sum(), b.cwiseProduct(fa).sum(), 1e-12 * std::abs(a.cwiseProduct(fa).sum()));
}

TEST(Damping, DiagonalBlocksAreTheForceOfEachNodesOwnVelocity) {
  // C_nn column k = −(force on n when only n moves, at unit speed along k),
  // the damping force being linear in v: checked on a deformed, plastically
  // deformed body at every node, to round-off of the force's scale.
  Body body = make_cube(ElasticModel::fixed_corotated, 3);
  body.material.viscosity = 7.0;
  Eigen::Matrix3d Fp;
  Fp << 1.1, 0.05, 0.0, 0.0, 0.95, 0.02, 0.0, 0.0, 1.0 / (1.1 * 0.95);
  for (auto& fp : body.Fp) fp = Fp;
  const Points x = sheared(body);
  ElasticForces forces;
  Points f;
  forces.evaluate(body, x, 0.0, f);
  Damping damping;
  std::vector<Eigen::Matrix3d> blocks;
  damping.freeze(body, forces);
  damping.diagonal_blocks(body, blocks);
  ASSERT_EQ(blocks.size(), static_cast<std::size_t>(body.num_nodes()));
  const double scale = 7.0 / 3.0;  // β h (h = 1/3): a block's size
  for (Index n = 0; n < body.num_nodes(); ++n) {
    Eigen::Matrix3d column_by_column;
    for (int k = 0; k < 3; ++k) {
      Points v = Points::Zero(body.num_nodes(), 3), fd;
      v(n, k) = 1.0;
      damping.apply(body, v, fd);
      column_by_column.col(k) = -fd.row(n).transpose();
    }
    EXPECT_LE((blocks[static_cast<std::size_t>(n)] - column_by_column).cwiseAbs().maxCoeff(), 1e-13 * scale)
        << "node " << n;
    EXPECT_GT(blocks[static_cast<std::size_t>(n)].ldlt().vectorD().minCoeff(), 0.0)
        << "node " << n;  // SPD: a preconditioner
  }
}

TEST(Damping, OnePassForTwoVelocityFieldsGivesEachTheBitsOfItsOwnPass) {
  // element_pass(v, w): the damping solve's residuals at v and at its warm
  // start from one pass over the elements. Each field's corner forces must
  // be those of a pass for it alone, to the bit.
  const ShearedCube cube = sheared_cube(3.0);
  const Body& body = cube.body;
  Damping damping;
  damping.freeze(body, cube.forces);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  Points v(body.num_nodes(), 3), w(body.num_nodes(), 3);
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) {
      v(n, k) = u(rng);
      w(n, k) = u(rng);
    }
  damping.element_pass(body, v);
  const std::vector<Eigen::Vector3d> alone_v = damping.corner_forces();
  damping.element_pass(body, w);
  const std::vector<Eigen::Vector3d> alone_w = damping.corner_forces();
  damping.element_pass(body, v, w);
  ASSERT_EQ(damping.corner_forces().size(), alone_v.size());
  ASSERT_EQ(damping.second_corner_forces().size(), alone_w.size());
  for (std::size_t c = 0; c < alone_v.size(); ++c) {
    EXPECT_TRUE(damping.corner_forces()[c] == alone_v[c]) << "corner " << c;
    EXPECT_TRUE(damping.second_corner_forces()[c] == alone_w[c]) << "corner " << c;
  }
  EXPECT_FALSE(alone_v == alone_w);  // two fields, two sets of forces
}

// The conjugate gradients' pass for their next direction z + β p reads it
// as it gathers each corner: the bits of a pass for z + β p formed first,
// on a body whose last block of eight is not full (the gathers of the full
// blocks and the one-by-one reads of the last both), and at every
// instruction-set level the gather itself gives the corners' values, the
// last block's spare lanes zero.
TEST(Damping, ThePassForTheNextDirectionGivesTheBitsOfAPassForItFormedFirst) {
  std::mt19937 rng(21);
  Body body = make_cube(ElasticModel::fixed_corotated, 5);
  ASSERT_NE(body.num_elements() % kDampingLanes, 0);
  body.material.viscosity = 2.0;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Points x = body.positions;
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) x(n, k) += 0.05 * u(rng);
  ElasticForces forces;
  Points f;
  forces.evaluate(body, x, 0.0, f);
  Damping damping;
  damping.freeze(body, forces);
  const Points z = Points::NullaryExpr(body.num_nodes(), 3, [&] { return u(rng); });
  const Points p = Points::NullaryExpr(body.num_nodes(), 3, [&] { return u(rng); });
  const double beta = 0.7303;
  const Points formed = z + beta * p;
  damping.element_pass(body, formed);
  const std::vector<Eigen::Vector3d> expected = damping.corner_forces();
  damping.element_pass(body, z, p, beta);
  ASSERT_EQ(damping.corner_forces().size(), expected.size());
  EXPECT_EQ(std::memcmp(damping.corner_forces().data(), expected.data(), sizeof(Eigen::Vector3d) * expected.size()), 0);

  for (const SimdLevel level : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512}) {
    if (!simd_level_supported(level)) continue;
    int differing = 0;
    for (Index first = 0; first < body.num_elements(); first += kDampingLanes)
      for (const bool next_direction : {false, true}) {
        const int count = static_cast<int>(std::min<Index>(kDampingLanes, body.num_elements() - first));
        DampingSources sources;
        sources.v = z.data();
        sources.tets = body.tets.data();
        if (next_direction) {
          sources.p = p.data();
          sources.beta = beta;
        }
        DampingLanes lanes;
        std::fill_n(&lanes.v[0][0][0], 4 * 3 * kDampingLanes, 1.0);  // the spare lanes must come out zero
        damping_gather(sources, static_cast<int>(first), count, lanes, level);
        const Points& read = next_direction ? formed : z;
        for (int lane = 0; lane < kDampingLanes; ++lane)
          for (int c = 0; c < 4; ++c)
            for (int i = 0; i < 3; ++i) {
              const double expected_value = lane < count ? read(body.tets(first + lane, c), i) : 0.0;
              differing += std::memcmp(&lanes.v[c][i][lane], &expected_value, sizeof(double)) != 0;
            }
      }
    EXPECT_EQ(differing, 0) << simd_level_name(level);
  }
}

TEST(Body, LumpedMassesAndIncidence) {
  Body body = make_cube(ElasticModel::fixed_corotated, 3);
  EXPECT_NEAR(body.masses.sum(), body.material.density * 1.0, 1e-12 * body.material.density);
  EXPECT_NEAR(body.rest_volumes.sum(), 1.0, 1e-14);
  EXPECT_EQ(body.incidence.corners.size(), 4U * static_cast<std::size_t>(body.num_elements()));
  for (Index e = 0; e < body.num_elements(); ++e) EXPECT_GT(body.rest_volumes[e], 0.0);
  // Each node's corners increasing, and slots their inverse: the place of
  // corner 4e + k is within node tets(e, k)'s range and holds that corner.
  const NodeIncidence& inc = body.incidence;
  ASSERT_EQ(inc.slots.size(), inc.corners.size());
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (Index i = inc.offsets[at(n)] + 1; i < inc.offsets[at(n) + 1]; ++i)
      EXPECT_LT(inc.corners[at(i - 1)], inc.corners[at(i)]);
  for (Index e = 0; e < body.num_elements(); ++e)
    for (int k = 0; k < 4; ++k) {
      const Index slot = inc.slots[at(4 * e + k)];
      EXPECT_EQ(inc.corners[at(slot)], 4 * e + k);
      EXPECT_GE(slot, inc.offsets[at(body.tets(e, k))]);
      EXPECT_LT(slot, inc.offsets[at(body.tets(e, k)) + 1]);
    }
}

TEST(Damping, AFrozenOperatorIsRefusedForABodyItWasNotFrozenFor) {
  Body body = make_cube(ElasticModel::fixed_corotated, 2);
  Damping damping;
  Points out;
  const Points v = Points::Zero(body.num_nodes(), 3);
  EXPECT_TRUE(test::throws_error_containing([&] { damping.apply(body, v, out); }, "not frozen"));
  ElasticForces forces;
  Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  damping.freeze(body, forces);
  damping.apply(body, v, out);
  EXPECT_EQ(out.cwiseAbs().maxCoeff(), 0.0);
  Body bigger = make_cube(ElasticModel::fixed_corotated, 3);
  EXPECT_TRUE(test::throws_error_containing([&] { damping.apply(bigger, Points::Zero(bigger.num_nodes(), 3), out); },
                                            "not frozen"));
  // Frozen from a force evaluation, or from deformations, of another body's
  // elements: refused, naming both counts.
  EXPECT_TRUE(test::throws_error_containing([&] { damping.freeze(bigger, forces); },
                                            "a force evaluation of 48 elements for a body of 162"));
  const std::vector<Eigen::Matrix3d> identities(static_cast<std::size_t>(body.num_elements()),
                                                Eigen::Matrix3d::Identity());
  EXPECT_TRUE(test::throws_error_containing([&] { damping.freeze(bigger, identities, identities); },
                                            "48 deformations for a body of 162 elements"));
  // Both passes go through the incidence (the forces write each corner's
  // force at its place in it, the damping's node sums read the corners it
  // lists): one that is not the elements' is refused, not written or read
  // past.
  Body stale = body;
  stale.incidence = NodeIncidence::build(bigger.tets, bigger.num_nodes());
  EXPECT_TRUE(test::throws_error_containing([&] { damping.apply(stale, v, out); }, "node incidence"));
  EXPECT_TRUE(test::throws_error_containing([&] { forces.evaluate(stale, stale.positions, 0.0, f); }, "node incidence"));
}

/// A cube of 4·5³·6 = 750 elements (not a multiple of eight), some of them
/// inverted, with a plastic deformation, its forces evaluated (Fe and Fp⁻¹
/// recorded), drawn from `rng`.
struct ShakenCube {
  Body body = make_cube(ElasticModel::neo_hookean, 5);
  ElasticForces forces;
  explicit ShakenCube(std::mt19937& rng) {
    body.material.viscosity = 3.0;
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Points x = body.positions;
    for (Index n = 0; n < body.num_nodes(); ++n)
      for (int k = 0; k < 3; ++k) x(n, k) += 0.3 * u(rng);  // inverts some elements
    for (auto& Fp : body.Fp) Fp += 0.1 * Eigen::Matrix3d::NullaryExpr([&] { return u(rng); });
    Points f;
    forces.evaluate(body, x, 0.0, f);
  }
};

/// Fe of every element at the forces' last evaluation.
std::vector<Eigen::Matrix3d> elastic_deformations(const ElasticForces& forces) {
  std::vector<Eigen::Matrix3d> Fe(static_cast<std::size_t>(forces.evaluated_elements()));
  for (Index e = 0; e < forces.evaluated_elements(); ++e)
    Fe[static_cast<std::size_t>(e)] = forces.elastic_deformation(e);
  return Fe;
}

/// Fp⁻¹ of every element: the force pass's own (the same bits:
/// Forces.EveryVectorWidthGivesTheOneElementCodesBits).
std::vector<Eigen::Matrix3d> inverses(const std::vector<Eigen::Matrix3d>& Fp) {
  std::vector<Eigen::Matrix3d> out(Fp.size());
  for (std::size_t k = 0; k < Fp.size(); ++k) out[k] = Fp[k].inverse();
  return out;
}

/// The frozen damping operator of elements first … first + 7 (lanes past
/// the last element zero), as Damping::freeze stores it.
DampingBlock frozen_block(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                          const std::vector<Eigen::Matrix3d>& Fp_inv, Index first) {
  DampingBlock block{};
  for (int lane = 0; lane < kDampingLanes && first + lane < body.num_elements(); ++lane) {
    const auto k = static_cast<std::size_t>(first + lane);
    const Eigen::Matrix3d A = body.Dm_inv[k] * Fp_inv[k];
    for (int i = 0; i < 9; ++i) {
      block.G[i][lane] = Fe[k].data()[i];
      block.A[i][lane] = A.data()[i];
    }
    block.scale[lane] = 2.0 * body.material.viscosity * body.rest_volumes[first + lane] / Fp_inv[k].determinant();
  }
  return block;
}

// The operator runs eight elements at a time in vector lanes; each lane must
// give the bits of the element loop it replaced (Eigen's expressions, below)
// at every instruction-set level, with a plastic deformation and inverted
// elements among them, and a last block that is not full (4·5³·6 = 750 is
// not a multiple of eight).
TEST(Damping, EveryVectorWidthGivesTheElementLoopsBits) {
  std::mt19937 rng(11);
  const ShakenCube cube(rng);
  const Body& body = cube.body;
  ASSERT_NE(body.num_elements() % kDampingLanes, 0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Points v = Points::NullaryExpr(body.num_nodes(), 3, [&] { return u(rng); });
  const std::vector<Eigen::Matrix3d> Fe = elastic_deformations(cube.forces);
  const std::vector<Eigen::Matrix3d> Fp_inv = inverses(body.Fp);

  std::vector<Matrix34> per_element(static_cast<std::size_t>(body.num_elements()));
  for (Index e = 0; e < body.num_elements(); ++e) {
    const auto k = static_cast<std::size_t>(e);
    const Eigen::Matrix3d& G = Fe[k];
    const Eigen::Matrix3d A = body.Dm_inv[k] * Fp_inv[k];
    const double scale = 2.0 * body.material.viscosity * body.rest_volumes[e] / Fp_inv[k].determinant();
    const Eigen::RowVector3d v0 = v.row(body.tets(e, 0));
    Eigen::Matrix3d Vs;
    for (int c = 0; c < 3; ++c) Vs.col(c) = (v.row(body.tets(e, c + 1)) - v0).transpose();
    const Eigen::Matrix3d E_dot = G.transpose() * (Vs * A);
    const Eigen::Matrix3d S = 0.5 * (E_dot + E_dot.transpose());
    const Eigen::Matrix3d H = (-scale * (G * S)) * A.transpose();
    per_element[k].col(0) = -H.rowwise().sum();
    per_element[k].rightCols<3>() = H;
  }
  Points expected;
  gather_to_nodes(body.incidence, per_element, expected);

  Damping damping;
  Points out;
  damping.apply(body, Fe, Fp_inv, v, out);
  EXPECT_GT(expected.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(std::memcmp(out.data(), expected.data(), sizeof(double) * static_cast<std::size_t>(out.size())), 0)
      << "largest difference " << (out - expected).cwiseAbs().maxCoeff();

  // Block by block at every level this processor has.
  for (const SimdLevel level : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512}) {
    if (!simd_level_supported(level)) continue;
    int differing = 0;
    for (Index first = 0; first < body.num_elements(); first += kDampingLanes) {
      const DampingBlock block = frozen_block(body, Fe, Fp_inv, first);
      DampingLanes lanes{};
      for (int lane = 0; lane < kDampingLanes && first + lane < body.num_elements(); ++lane)
        for (int c = 0; c < 4; ++c)
          for (int i = 0; i < 3; ++i) lanes.v[c][i][lane] = v(body.tets(first + lane, c), i);
      damping_block(block, lanes, level);
      for (int lane = 0; lane < kDampingLanes && first + lane < body.num_elements(); ++lane)
        for (int c = 0; c < 4; ++c)
          for (int i = 0; i < 3; ++i)
            differing += std::memcmp(&lanes.f[c][i][lane], &per_element[static_cast<std::size_t>(first + lane)](i, c),
                                     sizeof(double)) != 0;
    }
    EXPECT_EQ(differing, 0) << simd_level_name(level);
  }
}

// The operator's gather reads each block's corner velocities, v or the
// conjugate gradients' next direction v + β p formed as it reads them, into
// lanes; at every level (the AVX2 one by masked row loads transposed in
// registers) each lane must hold that corner's entries exactly, v + (β p) as
// Eigen rounds it, and the lanes past a short last block zero, with the
// array's last node among the corners read.
TEST(Damping, TheGatherAtEveryVectorWidthReadsEachCornersVelocityExactly) {
  std::mt19937 rng(17);
  const ShakenCube cube(rng);
  const Body& body = cube.body;
  const Index ne = body.num_elements();
  ASSERT_NE(ne % kDampingLanes, 0);
  ASSERT_TRUE((body.tets.array() == body.num_nodes() - 1).any());
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Points v = Points::NullaryExpr(body.num_nodes(), 3, [&] { return u(rng); });
  const Points p = Points::NullaryExpr(body.num_nodes(), 3, [&] { return u(rng); });
  const double beta = 0.7316;
  for (const bool with_direction : {false, true}) {
    const Points expected = with_direction ? Points(v + beta * p) : v;
    DampingSources sources;
    sources.v = v.data();
    sources.p = with_direction ? p.data() : nullptr;
    sources.beta = beta;
    sources.tets = body.tets.data();
    for (const SimdLevel level : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512}) {
      if (!simd_level_supported(level)) continue;
      int differing = 0, nonzero_past_the_end = 0;
      for (Index first = 0; first < ne; first += kDampingLanes) {
        const int count = static_cast<int>(std::min<Index>(kDampingLanes, ne - first));
        DampingLanes lanes;
        for (auto& corner : lanes.v)
          for (auto& component : corner)
            for (double& x : component) x = std::numeric_limits<double>::quiet_NaN();
        damping_gather(sources, static_cast<int>(first), count, lanes, level);
        for (int lane = 0; lane < kDampingLanes; ++lane)
          for (int c = 0; c < 4; ++c)
            for (int i = 0; i < 3; ++i) {
              const double got = lanes.v[c][i][lane];
              if (lane >= count) {
                nonzero_past_the_end += got != 0.0;
                continue;
              }
              const double want = expected(body.tets(first + lane, c), i);
              differing += std::memcmp(&got, &want, sizeof(double)) != 0;
            }
      }
      EXPECT_EQ(differing, 0) << simd_level_name(level) << (with_direction ? " v + beta p" : " v");
      EXPECT_EQ(nonzero_past_the_end, 0) << simd_level_name(level);
    }
  }
}

// The preconditioner's blocks run eight elements at a time in vector lanes
// too; each must give the bits of the element loop they replaced (the
// Eigen formula below, summed over each node's corners in the incidence
// order), at every level, on the same inverted, plastically deformed cube.
TEST(Damping, DiagonalBlocksAtEveryVectorWidthGiveTheElementLoopsBits) {
  std::mt19937 rng(13);
  const ShakenCube cube(rng);
  const Body& body = cube.body;
  ASSERT_NE(body.num_elements() % kDampingLanes, 0);
  const std::vector<Eigen::Matrix3d> Fe = elastic_deformations(cube.forces);
  const std::vector<Eigen::Matrix3d> Fp_inv = inverses(body.Fp);

  std::vector<std::array<Eigen::Matrix3d, 4>> per_element(static_cast<std::size_t>(body.num_elements()));
  for (Index e = 0; e < body.num_elements(); ++e) {
    const auto k = static_cast<std::size_t>(e);
    const Eigen::Matrix3d& G = Fe[k];
    const Eigen::Matrix3d A = body.Dm_inv[k] * Fp_inv[k];
    const double scale = body.material.viscosity * body.rest_volumes[e] / Fp_inv[k].determinant();
    const Eigen::Matrix3d W = A.transpose();
    const Eigen::Matrix3d GGt = G * G.transpose();
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector3d w = c == 0 ? Eigen::Vector3d(-W.rowwise().sum()) : Eigen::Vector3d(W.col(c - 1));
      const Eigen::Vector3d Gw = G * w;
      per_element[k][static_cast<std::size_t>(c)] = scale * (w.squaredNorm() * GGt + Gw * Gw.transpose());
    }
  }
  std::vector<Eigen::Matrix3d> expected(static_cast<std::size_t>(body.num_nodes()), Eigen::Matrix3d::Zero());
  const NodeIncidence& incidence = body.incidence;
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (Index i = incidence.offsets[static_cast<std::size_t>(n)];
         i < incidence.offsets[static_cast<std::size_t>(n) + 1]; ++i) {
      const Index corner = incidence.corners[static_cast<std::size_t>(i)];
      expected[static_cast<std::size_t>(n)] +=
          per_element[static_cast<std::size_t>(corner / 4)][static_cast<std::size_t>(corner % 4)];
    }

  Damping damping;
  std::vector<Eigen::Matrix3d> blocks;
  damping.diagonal_blocks(body, Fe, Fp_inv, blocks);
  ASSERT_EQ(blocks.size(), expected.size());
  EXPECT_EQ(std::memcmp(blocks.data(), expected.data(), sizeof(Eigen::Matrix3d) * blocks.size()), 0);
  // The damping solve's way: the corner blocks from an element pass, each
  // node's summed by node_block.
  Damping passing;
  passing.freeze(body, Fe, Fp_inv);
  passing.element_pass(body, Points::Zero(body.num_nodes(), 3), true);
  int nodes_differing = 0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Matrix3d block = passing.node_block(incidence, n);
    nodes_differing += std::memcmp(block.data(), expected[static_cast<std::size_t>(n)].data(), sizeof(block)) != 0;
  }
  EXPECT_EQ(nodes_differing, 0);

  // Block by block at every level this processor has.
  for (const SimdLevel level : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512}) {
    if (!simd_level_supported(level)) continue;
    int differing = 0;
    for (Index first = 0; first < body.num_elements(); first += kDampingLanes) {
      const DampingBlock block = frozen_block(body, Fe, Fp_inv, first);
      DampingDiagonal diagonal{};
      damping_diagonal(block, diagonal, level);
      for (int lane = 0; lane < kDampingLanes && first + lane < body.num_elements(); ++lane)
        for (int c = 0; c < 4; ++c)
          for (int i = 0; i < 9; ++i)
            differing +=
                std::memcmp(&diagonal.d[c][i][lane],
                            &per_element[static_cast<std::size_t>(first + lane)][static_cast<std::size_t>(c)].data()[i],
                            sizeof(double)) != 0;
    }
    EXPECT_EQ(differing, 0) << simd_level_name(level);
  }
}

// The force pass runs eight elements at a time in vector lanes; at every
// level this processor has, it must give the bits of the one-element code
// (element_forces after svd3 and plastic_flow, gathered in the incidence
// order): forces, Fe, the flowed Fp and α, the stability bounds and what the
// damping freezes (Fe, Dm⁻¹ Fp⁻¹, 2β W det Fp) for every model, with
// inverted elements, plastic flow, and a last batch that is not full.
TEST(Forces, EveryVectorWidthGivesTheOneElementCodesBits) {
  for (const ElasticModel model : kModels) {
    Body start = make_cube(model, 5);
    start.material.yield_stress = 10.0;
    start.material.flow_rate = 50.0;
    start.material.hardening = 5.0;
    start.material.viscosity = 3.0;
    ASSERT_TRUE(start.material.plastic());
    std::mt19937 rng(12);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Points x = start.positions;
    for (Index n = 0; n < start.num_nodes(); ++n)
      for (int k = 0; k < 3; ++k) x(n, k) += 0.25 * u(rng);  // inverts some elements
    for (auto& Fp : start.Fp) Fp += 0.1 * Eigen::Matrix3d::NullaryExpr([&] { return u(rng); });
    // A lattice's Dm⁻¹ has entries whose sums round exactly: perturbed, they
    // tell every order of the stability bound's sums apart.
    for (auto& Dm_inv : start.Dm_inv)
      Dm_inv += 0.01 * Dm_inv.norm() * Eigen::Matrix3d::NullaryExpr([&] { return u(rng); });
    const double plastic_dt = 1e-3;

    // The one-element code.
    Body expected = start;
    const IsotropicEnergy energy(expected.material);
    std::vector<Matrix34> per_element(static_cast<std::size_t>(expected.num_elements()));
    std::vector<Eigen::Matrix3d> Fe(per_element.size()), Fp_inv(per_element.size());
    int flowed = 0;
    for (Index e = 0; e < expected.num_elements(); ++e) {
      const auto k = static_cast<std::size_t>(e);
      Eigen::Matrix3d& Fp = expected.Fp[k];
      Fp_inv[k] = Fp.inverse();
      Svd3 svd = svd3(deformation_gradient(expected, x, e) * Fp_inv[k]);
      if (plastic_flow(expected.material, energy, plastic_dt, svd, Fp, expected.alpha[e])) {
        Fp_inv[k] = Fp.inverse();
        ++flowed;
      }
      per_element[k] =
          element_forces(energy, svd, Fp_inv[k], expected.Dm_inv[k], expected.rest_volumes[e] * Fp.determinant());
      Fe[k] = svd.U * svd.sigma.asDiagonal() * svd.V.transpose();
    }
    Points f_expected;
    gather_to_nodes(expected.incidence, per_element, f_expected);
    EXPECT_GT(flowed, 0);
    // Each element's stability bound m_min / k_e, k_e = (λ + 2μ) W det(Fp)
    // Σ_i |∇λ_i|², as the one-element code wrote it.
    std::vector<double> dt_squared(per_element.size());
    for (Index e = 0; e < expected.num_elements(); ++e) {
      const auto k = static_cast<std::size_t>(e);
      const Eigen::Matrix3d& Dm_inv = expected.Dm_inv[k];
      const double grad_sq = Dm_inv.squaredNorm() + Dm_inv.colwise().sum().squaredNorm();
      const double k_e =
          (energy.lambda() + 2.0 * energy.mu()) * (expected.rest_volumes[e] * expected.Fp[k].determinant()) * grad_sq;
      double m_min = expected.masses[expected.tets(e, 0)];
      for (int c = 1; c < 4; ++c) m_min = std::min(m_min, expected.masses[expected.tets(e, c)]);
      dt_squared[k] = m_min / k_e;
    }

    const auto same = [](const auto& a, const auto& b) {
      return a.size() == b.size() &&
             std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
    };
    for (const SimdLevel level : {SimdLevel::scalar, SimdLevel::sse2, SimdLevel::avx2, SimdLevel::avx512}) {
      if (!simd_level_supported(level)) continue;
      Body body = start;
      ElasticForces forces;
      forces.set_simd_level(level);
      Points f;
      forces.evaluate(body, x, plastic_dt, f);
      const std::string what = std::string(to_string(model)) + " at " + std::string(simd_level_name(level));
      EXPECT_TRUE(same(f, f_expected)) << what << ": largest difference " << (f - f_expected).cwiseAbs().maxCoeff();
      EXPECT_EQ(forces.plastic_elements(), flowed) << what;
      int differing_Fe = 0, differing_Fp = 0, differing_blocks = 0;
      for (std::size_t k = 0; k < per_element.size(); ++k) {
        differing_Fe += !same(forces.elastic_deformation(static_cast<Index>(k)), Fe[k]);
        differing_Fp += !same(body.Fp[k], expected.Fp[k]);
      }
      // What the damping freezes, as Damping::freeze(body, Fe, Fp⁻¹) would
      // (Fe, A = Dm⁻¹ Fp⁻¹, 2β W det Fp), its last block's spare lanes zero.
      ASSERT_EQ(forces.damping_blocks().size(), (per_element.size() + kDampingLanes - 1) / kDampingLanes);
      for (std::size_t block = 0; block < forces.damping_blocks().size(); ++block) {
        const DampingBlock frozen = frozen_block(expected, Fe, Fp_inv, static_cast<Index>(block) * kDampingLanes);
        differing_blocks += std::memcmp(&forces.damping_blocks()[block], &frozen, sizeof(DampingBlock)) != 0;
      }
      EXPECT_EQ(differing_Fe, 0) << what;
      EXPECT_EQ(differing_blocks, 0) << what;
      EXPECT_EQ(differing_Fp, 0) << what;
      EXPECT_TRUE(same(body.alpha, expected.alpha)) << what;
      EXPECT_EQ(std::memcmp(forces.element_critical_dt_squared().data(), dt_squared.data(),
                            sizeof(double) * dt_squared.size()),
                0)
          << what;
    }
  }
}

TEST(TetMesh, CheckRefusesBadElementsAndReorients) {
  TetMesh mesh = make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Ones());
  std::swap(mesh.tets(2, 1), mesh.tets(2, 2));
  EXPECT_EQ(check_and_orient(mesh, "m"), 1);
  TetMesh bad = mesh;
  bad.tets(3, 3) = 99;
  EXPECT_TRUE(test::throws_error_containing([&] { check_and_orient(bad, "m"); },
                                            "m: tetrahedron 3 references node 99, but the mesh has 8 nodes"));
  bad = mesh;
  bad.positions.row(7) = bad.positions.row(0) + 0.5 * (bad.positions.row(1) - bad.positions.row(0));
  bad.tets.row(0) << 0, 1, 7, 2;  // 7 on the edge 0–1: zero volume
  EXPECT_TRUE(test::throws_error_containing([&] { check_and_orient(bad, "m"); }, "m: tetrahedron 0 has zero volume"));
}

}  // namespace
}  // namespace goo
