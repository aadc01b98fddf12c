#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <random>

#include "core/primitives.h"
#include "io/surface_mesh_io.h"
#include "meshing/exact_predicates.h"
#include "meshing/voxelize.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

/// Generalised winding number by solid angles (Van Oosterom & Strackee 1983):
/// an oracle that shares nothing with the ray casting it checks.
double winding_number(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double total = 0.0;
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    const auto [ta, tb, tc] = mesh.corners(t);
    const Eigen::Vector3d a = ta - p, b = tb - p, c = tc - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(numerator, denominator);
  }
  return total / (4.0 * std::numbers::pi);
}

TEST(ExactPredicates, SignConventions) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_EQ(exact::orient_xy(a, b, c), 1);
  EXPECT_EQ(exact::orient_3d(a, b, c, Eigen::Vector3d(0.2, 0.2, 1.0)), 1);  // on the normal's side
  EXPECT_EQ(exact::orient_3d(a, b, c, Eigen::Vector3d(0.2, 0.2, -1e-300)), -1);
  EXPECT_EQ(exact::orient_3d(a, b, c, Eigen::Vector3d(5.0, -3.0, 0.0)), 0);
  // Exact where floating point is not: nearly collinear points.
  EXPECT_EQ(exact::orient_xy(Eigen::Vector3d(0.1, 0.1, 0), Eigen::Vector3d(0.3, 0.3, 0), Eigen::Vector3d(0.7, 0.7, 0)),
            0);
}

// orient_xy's floating-point filter never takes a rounded 0 for a sign, nor
// a sign for an exact 0: points on a grid of 2⁻³⁰, a and b a few steps apart
// on a line, c far along it, exactly on the line or nudged off it by one
// step; against the exact integer determinant (the products fit in 128
// bits). (That it never takes a wrong sign is checked against exact rational
// arithmetic in test_clip_oracle.cpp.)
__extension__ using Int128 = __int128;

TEST(ExactPredicates, OrientXyIsExactNearCollinearity) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<std::int64_t> coordinate(-(std::int64_t{1} << 40), std::int64_t{1} << 40);
  std::uniform_int_distribution<std::int64_t> direction(-(std::int64_t{1} << 20), std::int64_t{1} << 20);
  std::uniform_int_distribution<std::int64_t> step(1, 4), far(-(std::int64_t{1} << 20), std::int64_t{1} << 20);
  std::uniform_int_distribution<std::int64_t> nudge(-1, 1);
  const double unit = 0x1p-30;
  int zero = 0, positive = 0, negative = 0, rounded_wrong = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    // The determinant m (d × e) is below 2²²; the products' rounding about 2²⁷.
    const std::int64_t ax = coordinate(rng), ay = coordinate(rng), dx = direction(rng), dy = direction(rng);
    const std::int64_t m = step(rng), n = far(rng);
    const std::int64_t bx = ax + m * dx, by = ay + m * dy;
    const std::int64_t cx = ax + n * dx + (trial % 3 == 0 ? 0 : nudge(rng));
    const std::int64_t cy = ay + n * dy + (trial % 3 == 0 ? 0 : nudge(rng));
    const Int128 det = static_cast<Int128>(bx - ax) * (cy - ay) - static_cast<Int128>(by - ay) * (cx - ax);
    const int expected = det > 0 ? 1 : det < 0 ? -1 : 0;
    const auto point = [&](std::int64_t x, std::int64_t y) {
      return Eigen::Vector3d(static_cast<double>(x) * unit, static_cast<double>(y) * unit, 0.0);
    };
    const Eigen::Vector3d pa = point(ax, ay), pb = point(bx, by), pc = point(cx, cy);
    ASSERT_EQ(exact::orient_xy(pa, pb, pc), expected) << "trial " << trial;
    (expected == 0 ? zero : expected > 0 ? positive : negative)++;
    const double rounded = (pa.x() - pc.x()) * (pb.y() - pc.y()) - (pa.y() - pc.y()) * (pb.x() - pc.x());
    rounded_wrong += (rounded > 0.0 ? 1 : rounded < 0.0 ? -1 : 0) != expected;
  }
  EXPECT_GT(zero, 1000);
  EXPECT_GT(positive, 1000);
  EXPECT_GT(negative, 1000);
  EXPECT_GT(rounded_wrong, 1000);  // the cases are hard: plain rounding gets them wrong
}

TEST(Voxelize, LatticeAlignedCubeFollowsTheSymbolicTieBreakAtEveryNode) {
  // The cube [0, 1]³ with its vertices on lattice columns and its faces on
  // lattice planes: rays through vertices and edges, nodes on faces, edges
  // and corners. The shifted node p + (ε, ε², ε³) is inside exactly when
  // 0 ≤ x < 1, 0 ≤ y < 1 and 0 ≤ z < 1.
  for (const int subdivisions : {1, 4}) {
    TriangleMesh cube = make_box(Eigen::Vector3d::Ones(), subdivisions);
    cube.vertices.rowwise() += Eigen::RowVector3d::Constant(0.5);
    const BccLattice lattice(Eigen::Vector3d::Constant(-0.5), 0.25, Eigen::Vector3i::Constant(8));
    const auto inside = voxelize(lattice, cube);
    for (BccLattice::Key node = 0; node < lattice.num_nodes(); ++node) {
      const Eigen::Vector3d p = lattice.position(node);
      const bool expected = (p.array() >= 0.0).all() && (p.array() < 1.0).all();
      EXPECT_EQ(inside[static_cast<std::size_t>(node)] != 0, expected) << "node at " << p.transpose();
    }
  }
}

TEST(Voxelize, SphereMatchesTheWindingNumberIncludingRaysThroughVertices) {
  // A sphere whose poles and ring vertices sit on lattice columns.
  const TriangleMesh sphere = make_sphere(1.0, 16);
  const BccLattice lattice(Eigen::Vector3d::Constant(-1.5), 0.125, Eigen::Vector3i::Constant(24));
  const auto inside = voxelize(lattice, sphere);
  for (BccLattice::Key node = 0; node < lattice.num_nodes(); ++node) {
    const double w = winding_number(sphere, lattice.position(node));
    if (std::abs(w - std::round(w)) > 1e-6) continue;  // on the surface: the tie-break decides
    EXPECT_EQ(inside[static_cast<std::size_t>(node)] != 0, std::round(w) != 0.0) << lattice.position(node).transpose();
  }
}

class RealModelVoxels : public ::testing::TestWithParam<std::pair<const char*, int>> {};

TEST_P(RealModelVoxels, AgreeWithTheWindingNumberOnRandomNodes) {
  const auto [file, samples] = GetParam();
  const auto path = test::asset(file);
  ASSERT_TRUE(std::filesystem::exists(path)) << "run scripts/fetch-assets";
  const TriangleMesh mesh = io::read_surface_mesh(path);
  const Eigen::AlignedBox3d box(mesh.vertices.colwise().minCoeff().transpose(),
                                mesh.vertices.colwise().maxCoeff().transpose());
  const double h = box.diagonal().maxCoeff() / 64.0;
  const Eigen::Vector3d origin = box.min() - 2.0 * h * Eigen::Vector3d::Ones();
  const Eigen::Vector3i cells = ((box.diagonal() / h).array().ceil() + 4.0).cast<int>();
  const BccLattice lattice(origin, h, cells);
  const auto inside = voxelize(lattice, mesh);
  std::mt19937_64 rng(12);
  std::uniform_int_distribution<BccLattice::Key> pick(0, lattice.num_nodes() - 1);
  std::vector<BccLattice::Key> nodes(static_cast<std::size_t>(samples));
  for (auto& node : nodes) node = pick(rng);
  std::vector<double> w(nodes.size());
  tbb::parallel_for(std::size_t{0}, nodes.size(),
                    [&](std::size_t i) { w[i] = winding_number(mesh, lattice.position(nodes[i])); });
  int inside_count = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    ASSERT_LT(std::abs(w[i] - std::round(w[i])), 1e-3) << "node on the surface: the oracle cannot decide";
    const bool expected = std::round(w[i]) != 0.0;
    inside_count += expected ? 1 : 0;
    EXPECT_EQ(inside[static_cast<std::size_t>(nodes[i])] != 0, expected) << lattice.position(nodes[i]).transpose();
  }
  EXPECT_GT(inside_count, samples / 50) << "the sample must reach inside";
}

// 10⁴ random lattice nodes per model; the solid-angle oracle costs
// #triangles per node, ≈ 8 s for the bunny on two cores.
INSTANTIATE_TEST_SUITE_P(Assets, RealModelVoxels,
                         ::testing::Values(std::pair{"hand.off", 10000}, std::pair{"bunny00.off", 10000},
                                           std::pair{"armadillo.off", 10000}),
                         [](const auto& param_info) {
                           const std::string name = param_info.param.first;
                           return name.substr(0, name.find('.'));
                         });

}  // namespace
}  // namespace goo
