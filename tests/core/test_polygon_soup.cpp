#include <gtest/gtest.h>

#include <random>

#include "core/polygon_soup.h"
#include "core/primitives.h"
#include "core/surface_check.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Points points(std::initializer_list<std::array<double, 3>> list) {
  Points p(static_cast<Eigen::Index>(list.size()), 3);
  Eigen::Index i = 0;
  for (const auto& q : list) p.row(i++) << q[0], q[1], q[2];
  return p;
}

Eigen::Vector3d area_vector(const Points& p, const std::vector<Eigen::Vector3i>& triangles) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = p.row(t[0]), b = p.row(t[1]), c = p.row(t[2]);
    sum += 0.5 * (b - a).cross(c - a);
  }
  return sum;
}

TEST(TriangulatePolygon, NonConvexPolygonKeepsAreaAndWinding) {
  // An L shape in the plane y = 2, wound so that its normal is −y; area 3.
  const Points p = points({{0, 2, 0}, {2, 2, 0}, {2, 2, 1}, {1, 2, 1}, {1, 2, 2}, {0, 2, 2}});
  const std::vector<Index> polygon = {0, 1, 2, 3, 4, 5};
  std::vector<Eigen::Vector3i> triangles;
  triangulate_polygon(polygon, p, triangles);
  ASSERT_EQ(triangles.size(), 4U);
  const Eigen::Vector3d expected_normal(0.0, -1.0, 0.0);
  for (const auto& t : triangles) {
    const Eigen::Vector3d a = p.row(t[0]), b = p.row(t[1]), c = p.row(t[2]);
    const Eigen::Vector3d n = (b - a).cross(c - a);
    EXPECT_GT(n.dot(expected_normal), 0.0) << "a triangle is flipped or degenerate";
  }
  EXPECT_TRUE(test::matrices_near(area_vector(p, triangles), 3.0 * expected_normal, 1e-15));
}

TEST(TriangulatePolygon, ReversedWindingGivesReversedTriangles) {
  const Points p = points({{0, 0, 0}, {0, 0, 2}, {0, 1, 2}, {0, 1, 1}, {0, 2, 1}, {0, 2, 0}});
  std::vector<Eigen::Vector3i> forward, backward;
  triangulate_polygon(std::vector<Index>{0, 1, 2, 3, 4, 5}, p, forward);
  triangulate_polygon(std::vector<Index>{5, 4, 3, 2, 1, 0}, p, backward);
  EXPECT_TRUE(test::matrices_near(area_vector(p, forward), -area_vector(p, backward), 1e-15));
  EXPECT_NEAR(area_vector(p, forward).norm(), 3.0, 1e-15);
}

TEST(WeldVertices, TriangleSoupOfABoxBecomesTheIndexedBox) {
  const TriangleMesh box = make_box({1.0, 1.0, 1.0}, 2);
  TriangleMesh soup;
  soup.vertices.resize(3 * box.num_triangles(), 3);
  soup.triangles.resize(box.num_triangles(), 3);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-1e-9, 1e-9);  // below the 1e-7 × √3 tolerance
  for (Index t = 0; t < box.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      soup.vertices.row(3 * t + k) = box.vertices.row(box.triangles(t, k));
      for (int c = 0; c < 3; ++c) soup.vertices(3 * t + k, c) += jitter(rng);
      soup.triangles(t, k) = 3 * t + k;
    }
  ASSERT_TRUE(analyze_surface(soup).first_defect.has_value());  // a soup is not closed
  const WeldResult weld = weld_vertices(soup, 1e-7);
  EXPECT_EQ(soup.num_vertices(), box.num_vertices());
  EXPECT_EQ(weld.merged, 3 * box.num_triangles() - box.num_vertices());
  const SurfaceReport r = analyze_surface(soup);
  EXPECT_FALSE(r.first_defect.has_value()) << *r.first_defect;
  EXPECT_NEAR(r.volume, 1.0, 1e-8);  // the jitter moves the surface by ≤ 1e-9
}

TEST(WeldVertices, ZeroToleranceMergesOnlyIdenticalPointsIntoTheFirst) {
  TriangleMesh mesh;
  mesh.vertices = points({{0, 0, 0}, {1, 0, 0}, {0, 0, 0}, {1e-300, 0, 0}, {0, 1, 0}});
  mesh.triangles.resize(2, 3);
  mesh.triangles << 2, 1, 4, 3, 1, 4;
  weld_vertices(mesh, 0.0);
  // 2 is identical to 0 and merges into it; 3 differs from 0 by 1e-300 and
  // stays separate; nothing references 0 before the weld, vertex 0 after it.
  EXPECT_EQ(mesh.num_vertices(), 4);
  EXPECT_EQ(mesh.triangles(0, 0), 0);
  EXPECT_EQ(mesh.vertices(mesh.triangles(1, 0), 0), 1e-300);
}

TEST(RemoveUnreferencedVertices, KeepsOrderAndRenumbers) {
  TriangleMesh mesh;
  mesh.vertices = points({{9, 9, 9}, {0, 0, 0}, {1, 0, 0}, {8, 8, 8}, {0, 1, 0}});
  mesh.triangles.resize(1, 3);
  mesh.triangles << 1, 2, 4;
  EXPECT_EQ(remove_unreferenced_vertices(mesh), 2);
  EXPECT_TRUE(test::matrices_near(mesh.vertices, points({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), 0.0));
  EXPECT_EQ(mesh.triangles, (Triangles(1, 3) << 0, 1, 2).finished());
}

}  // namespace
}  // namespace goo
