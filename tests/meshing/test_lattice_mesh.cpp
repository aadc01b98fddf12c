#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <limits>
#include <random>
#include <string>

#include "core/error.h"
#include "core/primitives.h"
#include "core/surface_check.h"
#include "io/surface_mesh_io.h"
#include "meshing/lattice_mesh.h"
#include "meshing/voxelize.h"
#include "tests/common/test_common.h"
#include "tests/meshing/lattice_cases.h"

namespace goo {
namespace {

using test::Case;

TEST(LatticeMesh, CoversTheSurfaceAndEmbedsEveryVertexInItsParent) {
  for (const Case& c : test::lattice_cases()) {
    SCOPED_TRACE(c.name);
    const LatticeMesh lm = build_lattice_mesh(c.surface, c.h);
    ASSERT_GT(lm.mesh.num_elements(), 0);
    // Congruent, positive, compact.
    for (Index e = 0; e < lm.mesh.num_elements(); ++e)
      ASSERT_NEAR(signed_volume(lm.mesh.positions, lm.mesh.tets, e), c.h * c.h * c.h / 12.0, 1e-12 * c.h * c.h * c.h);
    std::vector<int> used(static_cast<std::size_t>(lm.mesh.num_nodes()), 0);
    for (Index e = 0; e < lm.mesh.num_elements(); ++e)
      for (int k = 0; k < 4; ++k) used[static_cast<std::size_t>(lm.mesh.tets(e, k))] = 1;
    EXPECT_EQ(std::count(used.begin(), used.end(), 1), lm.mesh.num_nodes());

    // Every vertex in its parent; x_s = W x reproduces the surface.
    const Embedding embedding = embed(lm, c.surface.vertices);
    EXPECT_GE(embedding.bary.minCoeff(), -1e-12);
    EXPECT_TRUE(
        test::matrices_near(embedding.bary.rowwise().sum(), Eigen::VectorXd::Ones(c.surface.num_vertices()), 1e-13));
    const Eigen::SparseMatrix<double, Eigen::RowMajor> W = embedding.operator_matrix(lm.mesh);
    const Points xs = W * lm.mesh.positions;
    EXPECT_TRUE(test::matrices_near(xs, c.surface.vertices, 1e-13 * (1.0 + c.surface.vertices.cwiseAbs().maxCoeff())));
    // The same four-term sums in another order: 4 ε of the coordinates.
    EXPECT_TRUE(test::matrices_near(embedding.surface_positions(lm.mesh.tets, lm.mesh.positions), xs,
                                    1e-15 * (1.0 + c.surface.vertices.cwiseAbs().maxCoeff())));

    // Coverage: points spread over every triangle lie in kept tetrahedra.
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    Points samples(4 * c.surface.num_triangles(), 3);
    for (Index t = 0; t < c.surface.num_triangles(); ++t) {
      const auto [ca, cb, cd] = c.surface.corners(t);
      const Eigen::RowVector3d a = ca.transpose(), b = cb.transpose(), d = cd.transpose();
      samples.row(4 * t) = (a + b + d) / 3.0;
      samples.row(4 * t + 1) = 0.5 * (a + b);
      samples.row(4 * t + 2) = 0.5 * (b + d);
      double r1 = u(rng), r2 = u(rng);
      if (r1 + r2 > 1.0) {
        r1 = 1.0 - r1;
        r2 = 1.0 - r2;
      }
      samples.row(4 * t + 3) = a + r1 * (b - a) + r2 * (d - a);
    }
    const Embedding covered = embed(lm, samples);
    EXPECT_GE(covered.bary.minCoeff(), -1e-12) << "a point of the surface lies outside every kept tetrahedron";

    // The kept tetrahedra hold the whole solid.
    EXPECT_GE(lm.mesh.num_elements() * c.h * c.h * c.h / 12.0, analyze_surface(c.surface).volume);
  }
}

// The kept tetrahedra are exactly those with an inside node and those a
// triangle overlaps, found the plain way: every triangle against every
// tetrahedron near its box (for_each_tet_shape_near), the same box and
// overlap tests. build_lattice_mesh tests each tetrahedron only against the
// triangles binned in its two cells, and stops at the first that overlaps it.
void expect_the_tetrahedra_with_an_inside_node_or_a_triangle_over_them(const Case& c) {
  SCOPED_TRACE(c.name);
  const LatticeMesh lm = build_lattice_mesh(c.surface, c.h);
  const BccLattice& lattice = lm.lattice;
  const std::vector<std::uint8_t> inside = voxelize(lattice, c.surface);
  std::vector<std::uint8_t> expected(static_cast<std::size_t>(lattice.num_tet_keys()), 0);
  for (BccLattice::Key t = 0; t < lattice.num_tet_keys(); ++t) {
    if (!lattice.valid(t)) continue;
    for (const auto n : lattice.tet_nodes(t))
      if (inside[static_cast<std::size_t>(n)]) expected[static_cast<std::size_t>(t)] = 1;
  }
  const double slack = 1e-9 * c.h;
  int overlapped = 0;
  for (Index t = 0; t < c.surface.num_triangles(); ++t) {
    const std::array<Eigen::Vector3d, 3> tri = c.surface.corners(t);
    const Eigen::Vector3d lo = tri[0].cwiseMin(tri[1]).cwiseMin(tri[2]), hi = tri[0].cwiseMax(tri[1]).cwiseMax(tri[2]);
    lattice.for_each_tet_shape_near(lo, hi, [&](BccLattice::Key key, const Eigen::Vector3i& cell, int axis, int edge) {
      const auto tet = lattice.tet_positions(cell, axis, edge);
      Eigen::Vector3d tet_lo = tet[0], tet_hi = tet[0];
      for (const auto& p : tet) {
        tet_lo = tet_lo.cwiseMin(p);
        tet_hi = tet_hi.cwiseMax(p);
      }
      if (((tet_lo.array() - slack) > hi.array()).any() || ((tet_hi.array() + slack) < lo.array()).any()) return;
      if (!overlaps_inflated(tri, tet, slack)) return;
      if (!expected[static_cast<std::size_t>(key)]) ++overlapped;
      expected[static_cast<std::size_t>(key)] = 1;
    });
  }
  std::vector<BccLattice::Key> keys;
  for (BccLattice::Key t = 0; t < lattice.num_tet_keys(); ++t)
    if (expected[static_cast<std::size_t>(t)]) keys.push_back(t);
  EXPECT_EQ(lm.tet_keys, keys);
  EXPECT_GT(overlapped, 0);  // some kept for a triangle alone (every case here has such)
}

TEST(LatticeMesh, KeepsTheTetrahedraWithAnInsideNodeOrATriangleOverThem) {
  std::vector<Case> cases = test::lattice_cases();
  std::erase_if(cases, [](const Case& c) { return c.name.ends_with(".off"); });  // the real models: the next test
  // A crumpled surface: every vertex of a sphere moved at random by up to
  // half the spacing, triangles crossing cells every which way.
  TriangleMesh crumpled = make_sphere(0.5, 12);
  std::mt19937 rng(46);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  for (Index v = 0; v < crumpled.num_vertices(); ++v)
    for (int k = 0; k < 3; ++k) crumpled.vertices(v, k) += u(rng);
  cases.push_back({"crumpled", crumpled, 0.1});
  for (const Case& c : cases) expect_the_tetrahedra_with_an_inside_node_or_a_triangle_over_them(c);
}

// The same on bunny and armadillo: 75k and 52k triangles, 17 s under the
// sanitizers, so release runs it (scripts/test).
TEST(LatticeMesh, RealModelsKeepTheTetrahedraWithAnInsideNodeOrATriangleOverThem) {
  int models = 0;
  for (const Case& c : test::lattice_cases())
    if (c.name.ends_with(".off")) {
      expect_the_tetrahedra_with_an_inside_node_or_a_triangle_over_them(c);
      ++models;
    }
  EXPECT_EQ(models, 2) << "bunny00.off and armadillo.off: run scripts/fetch-assets";
}

TEST(LatticeMesh, BitwiseIdenticalForOneAndTwoThreads) {
  TriangleMesh surface = make_torus(0.6, 0.2, 48, 24);
  const auto bunny = test::asset("bunny00.off");
  if (std::filesystem::exists(bunny)) surface = io::read_surface_mesh(bunny);
  std::vector<LatticeMesh> meshes;
  std::vector<Embedding> embeddings;
  for (const int threads : {1, 2}) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    meshes.push_back(build_lattice_mesh(surface, 0.04));
    embeddings.push_back(embed(meshes.back(), surface.vertices));
  }
  EXPECT_TRUE(meshes[0].mesh.tets == meshes[1].mesh.tets);
  EXPECT_TRUE(meshes[0].mesh.positions == meshes[1].mesh.positions);
  EXPECT_EQ(embeddings[0].parent, embeddings[1].parent);
  EXPECT_TRUE(embeddings[0].bary == embeddings[1].bary);
}

// A surface flung far out (one vertex 10¹² m away) spans more cells than a
// block can hold, and one with a vertex not finite has no block at all:
// errors that say so, not a conversion of the cell count past int's range
// or a NaN left out of the bounding box.
TEST(LatticeMesh, ASurfaceSpanningMoreThanABlockCanHoldOrNotFiniteIsRefused) {
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [far, message] :
       {std::pair{1e12, "more than 1073741824 along an axis"}, std::pair{inf, "vertex 3 is not finite"},
        std::pair{nan, "vertex 3 is not finite"}}) {
    SCOPED_TRACE(far);
    TriangleMesh surface = make_box(Eigen::Vector3d::Ones(), 1);
    surface.vertices(3, 1) = far;
    try {
      (void)build_lattice_mesh(surface, 0.1);
      ADD_FAILURE() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

TEST(LatticeMesh, IsDeterministicAndAlignedToTheWorldGrid) {
  const TriangleMesh sphere = make_sphere(0.7, 20);
  const LatticeMesh a = build_lattice_mesh(sphere, 0.1), b = build_lattice_mesh(sphere, 0.1);
  EXPECT_TRUE(a.mesh.tets == b.mesh.tets);
  EXPECT_TRUE(a.mesh.positions == b.mesh.positions);
  const Eigen::Vector3d cells = a.lattice.origin() / 0.1;
  EXPECT_TRUE(test::matrices_near(cells, cells.array().round().matrix(), 1e-12));
  EXPECT_THROW(build_lattice_mesh(sphere, 0.0), Error);
}

TEST(LatticeMesh, NumbersNodesInSpaceOrderSoThatAnElementsNodesLieNearEachOther) {
  // Nodes in BccLattice::space_order (corner (i, j, k), then the centre of
  // cell (i, j, k)): a tet's four nodes lie in the corner grid's cells c +
  // {0, 1}³ of its lower centre's cell c, so their places in that order
  // differ by at most 2 (1 + X + X Y) + 1 (X, Y the corner grid's rows), and
  // their compact numbers (ranks among the used nodes) by no more. In key
  // order (corners, then centres) every element spanned the two halves.
  int telling = 0;  // cases where the bound is below half the nodes (key order's spread)
  for (const Case& c : test::lattice_cases()) {
    SCOPED_TRACE(c.name);
    const LatticeMesh lm = build_lattice_mesh(c.surface, c.h);
    for (std::size_t i = 1; i < lm.node_keys.size(); ++i)
      ASSERT_LT(lm.lattice.space_order(lm.node_keys[i - 1]), lm.lattice.space_order(lm.node_keys[i]));
    for (std::size_t i = 0; i < lm.node_keys.size(); ++i)
      ASSERT_EQ(lm.node(lm.node_keys[i]), static_cast<Index>(i));
    const Index X = lm.lattice.cells().x() + 1, Y = lm.lattice.cells().y() + 1;
    Index spread = 0;
    for (Index e = 0; e < lm.mesh.num_elements(); ++e)
      spread = std::max(spread, lm.mesh.tets.row(e).maxCoeff() - lm.mesh.tets.row(e).minCoeff());
    EXPECT_LE(spread, 2 * (1 + X + X * Y) + 1);
    if (2 * (1 + X + X * Y) + 1 < lm.mesh.num_nodes() / 2) ++telling;
  }
  EXPECT_GT(telling, 0);
}

}  // namespace
}  // namespace goo
