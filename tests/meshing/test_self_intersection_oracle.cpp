// CGAL's Polygon_mesh_processing::self_intersections as the oracle of goo's
// self-intersection search: the same pairs on constructed and crumpled
// surfaces, including coplanar foldings.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>

#include <random>

#include "core/primitives.h"
#include "meshing/exact_predicates.h"
#include "meshing/surface_intersections.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

std::vector<std::array<Index, 2>> cgal_pairs(const TriangleMesh& m) {
  Mesh mesh;
  std::vector<Mesh::Vertex_index> v;
  for (Index i = 0; i < m.num_vertices(); ++i)
    v.push_back(mesh.add_vertex(Kernel::Point_3(m.vertices(i, 0), m.vertices(i, 1), m.vertices(i, 2))));
  for (Index t = 0; t < m.num_triangles(); ++t) {
    const auto f = mesh.add_face(v[static_cast<std::size_t>(m.triangles(t, 0))],
                                 v[static_cast<std::size_t>(m.triangles(t, 1))],
                                 v[static_cast<std::size_t>(m.triangles(t, 2))]);
    EXPECT_EQ(static_cast<Index>(f.idx()), t);
  }
  std::vector<std::pair<Mesh::Face_index, Mesh::Face_index>> found;
  PMP::self_intersections(mesh, std::back_inserter(found));
  std::vector<std::array<Index, 2>> pairs;
  for (const auto& [f, g] : found) {
    const auto a = static_cast<Index>(f.idx()), b = static_cast<Index>(g.idx());
    pairs.push_back({std::min(a, b), std::max(a, b)});
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

void expect_same_as_cgal(const TriangleMesh& m, std::size_t at_least) {
  ASSERT_EQ(measure_surface_quality(m).degenerate_triangles, 0);
  const auto ours = self_intersecting_pairs(m), theirs = cgal_pairs(m);
  EXPECT_GE(ours.size(), at_least);
  ::testing::Test::RecordProperty("pairs", static_cast<int>(ours.size()));
  EXPECT_EQ(ours, theirs);
}

// The orientation predicate's fast path (a static error bound) agrees with
// CGAL's exact one: on random points, on points exactly in a plane (dyadic
// combinations: 0), and on those moved off it by one unit in the last place.
TEST(SelfIntersectionOracle, OrientationAgreesWithCgal) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto point = [&] { return Eigen::Vector3d(u(rng), u(rng), u(rng)); };
  auto cgal = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                 const Eigen::Vector3d& d) {
    auto p = [](const Eigen::Vector3d& x) { return Kernel::Point_3(x.x(), x.y(), x.z()); };
    return static_cast<int>(CGAL::orientation(p(a), p(b), p(c), p(d)));
  };
  int zeros = 0, near = 0;
  for (int i = 0; i < 20000; ++i) {
    // Corners on a grid of 2⁻¹⁰ so that dyadic combinations stay exact.
    auto grid = [&] { return Eigen::Vector3d((point() * 1024.0).array().round() / 1024.0); };
    const Eigen::Vector3d a = grid(), b = grid(), c = grid();
    Eigen::Vector3d d = i % 3 == 0 ? point() : Eigen::Vector3d(a + 0.5 * (b - a) + 0.25 * (c - a));
    if (i % 3 == 2) d.x() = std::nextafter(d.x(), 2.0);
    const Eigen::Vector3d shift = 1e3 * point();  // large offsets: cancellation in the differences
    const int want = cgal(a + shift, b + shift, c + shift, d + shift),
              got = exact::orient_3d(a + shift, b + shift, c + shift, d + shift);
    ASSERT_EQ(got, want) << i;
    ASSERT_EQ(exact::orient_3d(a, b, c, d), cgal(a, b, c, d)) << i;
    zeros += cgal(a, b, c, d) == 0 ? 1 : 0;
    near += i % 3 == 2 ? 1 : 0;
  }
  EXPECT_GT(zeros, 6000);
  EXPECT_GT(near, 6000);
}

TEST(SelfIntersectionOracle, CrumpledSpheres) {
  // Noise of a third to twice the edge length: from a few folds to a tangle.
  for (const double amplitude : {0.02, 0.05, 0.12}) {
    TriangleMesh s = make_sphere(1.0, 40);
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, amplitude);
    for (Index v = 0; v < s.num_vertices(); ++v)
      for (int k = 0; k < 3; ++k) s.vertices(v, k) += noise(rng);
    SCOPED_TRACE(amplitude);
    expect_same_as_cgal(s, 1);
  }
}

TEST(SelfIntersectionOracle, SquashedTorusFoldsOntoItself) {
  // A torus pressed flat (z scaled by 1e-3, then exactly to 0 on a band):
  // many coplanar neighbours, folded and unfolded.
  TriangleMesh t = make_torus(1.0, 0.4, 48, 16);
  for (Index v = 0; v < t.num_vertices(); ++v) {
    t.vertices(v, 2) *= 1e-3;
    if (t.vertices(v, 0) > 0.5) t.vertices(v, 2) = 0.0;
  }
  expect_same_as_cgal(t, 1);
}

TEST(SelfIntersectionOracle, BoxesMeetingOnOneGrid) {
  // Two boxes on one grid, the second shifted by exactly half a box so
  // vertices land on faces and edges of the other: the touching cases.
  TriangleMesh a = make_box({1, 1, 1}, 4), b = a;
  b.vertices.array() += 0.5;
  TriangleMesh both = test::joined(a, b);
  expect_same_as_cgal(both, 1);
  // And touching face to face: shifted by exactly one box along x.
  b = a;
  b.vertices.col(0).array() += 1.0;
  both.vertices << a.vertices, b.vertices;
  expect_same_as_cgal(both, 1);
}

}  // namespace
}  // namespace goo
