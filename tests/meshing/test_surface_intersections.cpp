// Exact triangle–triangle tests on constructed cases, and the surface
// measurements of whole meshes.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstdint>
#include <random>
#include <vector>

#include "core/primitives.h"
#include "core/surface_check.h"
#include "meshing/surface_intersections.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using V = Eigen::Vector3d;

TriangleMesh two_triangles(const V& a0, const V& a1, const V& a2, const V& b0, const V& b1, const V& b2) {
  TriangleMesh m;
  m.vertices.resize(6, 3);
  m.vertices << a0.transpose(), a1.transpose(), a2.transpose(), b0.transpose(), b1.transpose(), b2.transpose();
  m.triangles.resize(2, 3);
  m.triangles << 0, 1, 2, 3, 4, 5;
  return m;
}

TEST(TriangleIntersection, CrossingAndApart) {
  const V a0(0, 0, 0), a1(1, 0, 0), a2(0, 1, 0);
  // A triangle standing through the middle of the first.
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(0.2, 0.2, -1), V(0.3, 0.2, 1), V(0.2, 0.3, 1)));
  // The same lifted just clear of it, and a parallel copy above.
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, V(0.2, 0.2, 1e-300), V(0.3, 0.2, 1), V(0.2, 0.3, 1)));
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, V(0, 0, 1e-9), V(1, 0, 1e-9), V(0, 1, 1e-9)));
  // Touching: a vertex exactly on the face (closed triangles meet there).
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(0.25, 0.25, 0), V(0.3, 0.2, 1), V(0.2, 0.3, 1)));
  // A vertex exactly on an edge, and exactly on a corner.
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(0.5, 0, 0), V(0.5, -1, 1), V(0.6, -1, 1)));
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(1, 0, 0), V(2, 0, 1), V(2, 1, 1)));
  // A vertex just beyond the edge.
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, V(0.5, -1e-12, 0), V(0.5, -1, 1), V(0.6, -1, 1)));
  // In a mesh, triangles that share no vertex id are tested the same way,
  // even when their corners coincide in space.
  EXPECT_TRUE(triangles_intersect(two_triangles(a0, a1, a2, V(1, 0, 0), V(2, 0, 1), V(2, 1, 1)), 0, 1));
  EXPECT_TRUE(triangles_intersect(two_triangles(a0, a1, a2, a0, a1, V(0, -1, 0.5)), 0, 1));
  EXPECT_FALSE(triangles_intersect(two_triangles(a0, a1, a2, V(0.5, -1e-12, 0), V(0.5, -1, 1), V(0.6, -1, 1)), 0, 1));
}

TEST(TriangleIntersection, EdgesCrossingWithoutVertexInside) {
  // Two triangles whose edges cross like a chain's links: no vertex of
  // either lies in the other, yet they meet.
  const V a0(-1, 0, 0), a1(1, 0, 0), a2(0, 0, 2);
  const V b0(0, -1, 1), b1(0, 1, 1), b2(0, 0, -1);
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, b0, b1, b2));
  // Moved so that the crossing edges miss each other.
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, V(0, -1, 2.1), V(0, 1, 2.1), V(0, 0, 3)));
}

TEST(TriangleIntersection, Coplanar) {
  const V a0(0, 0, 0), a1(1, 0, 0), a2(0, 1, 0);
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(0.1, 0.1, 0), V(2, 0.1, 0), V(0.1, 2, 0)));   // overlapping
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(0.1, 0.1, 0), V(0.2, 0.1, 0), V(0.1, 0.2, 0)));  // inside
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(1, 0, 0), V(2, 0, 0), V(2, 1, 0)));            // a shared point
  EXPECT_TRUE(triangles_intersect(a0, a1, a2, V(0.5, -0.5, 0), V(0.5, 0.5, 0), V(2, 0, 0)));   // edges cross
  EXPECT_FALSE(triangles_intersect(a0, a1, a2, V(1, 1, 0), V(2, 1, 0), V(1, 2, 0)));           // apart
  // The same cases in a tilted plane, where projections matter.
  const V n = V(1, 2, 3).normalized(), t1 = n.unitOrthogonal(), t2 = n.cross(t1);
  auto at = [&](double x, double y) { return V(x * t1 * 4 + y * t2 * 4); };
  EXPECT_TRUE(triangles_intersect(at(0, 0), at(1, 0), at(0, 1), at(0.5, -0.5), at(0.5, 0.5), at(2, 0)));
  EXPECT_FALSE(triangles_intersect(at(0, 0), at(1, 0), at(0, 1), at(1, 1), at(2, 1), at(1, 2)));
}

TEST(TriangleIntersection, SegmentThroughTriangle) {
  const V u(0, 0, 0), v(1, 0, 0), w(0, 1, 0);
  EXPECT_TRUE(segment_meets_triangle(V(0.2, 0.2, -1), V(0.2, 0.2, 1), u, v, w));
  EXPECT_FALSE(segment_meets_triangle(V(0.2, 0.2, 0.5), V(0.2, 0.2, 1), u, v, w));   // stops short
  EXPECT_TRUE(segment_meets_triangle(V(0.2, 0.2, 0), V(0.2, 0.2, 1), u, v, w));      // ends on it
  EXPECT_FALSE(segment_meets_triangle(V(0.6, 0.6, -1), V(0.6, 0.6, 1), u, v, w));    // beside it
  EXPECT_TRUE(segment_meets_triangle(V(-1, 0.5, 0), V(2, 0.5, 0), u, v, w));         // in its plane
  EXPECT_FALSE(segment_meets_triangle(V(-1, 1.5, 0), V(2, 1.5, 0), u, v, w));
  // Through an edge and through a corner exactly.
  EXPECT_TRUE(segment_meets_triangle(V(0.5, 0, -1), V(0.5, 0, 1), u, v, w));
  EXPECT_TRUE(segment_meets_triangle(V(1, 0, -1), V(1, 0, 1), u, v, w));
}

TEST(TriangleIntersection, NeighboursSharingAnEdge) {
  TriangleMesh m;
  m.vertices.resize(4, 3);
  m.triangles.resize(2, 3);
  m.triangles << 0, 1, 2, 1, 0, 3;
  // A hinge: open, flat, folded back to 1e-12 rad short of flat, folded flat.
  m.vertices << 0, 0, 0, 1, 0, 0, 0.5, 1, 0, 0.5, -1, 0.3;
  EXPECT_FALSE(triangles_intersect(m, 0, 1));
  m.vertices.row(3) << 0.5, -1, 0;
  EXPECT_FALSE(triangles_intersect(m, 0, 1));  // flat and unfolded
  m.vertices.row(3) << 0.5, 1, 1e-12;
  EXPECT_FALSE(triangles_intersect(m, 0, 1));  // almost folded onto the other
  m.vertices.row(3) << 0.3, 2, 0;
  EXPECT_TRUE(triangles_intersect(m, 0, 1));  // folded flat onto it
}

TEST(TriangleIntersection, NeighboursSharingAVertex) {
  TriangleMesh m;
  m.vertices.resize(5, 3);
  m.triangles.resize(2, 3);
  m.triangles << 0, 1, 2, 0, 3, 4;
  // A fan around vertex 0: apart, then the second's far edge through the first.
  m.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0, -1, 0, 0.5, 0, -1, 0.5;
  EXPECT_FALSE(triangles_intersect(m, 0, 1));
  m.vertices.row(3) << 0.3, 0.3, -1;
  m.vertices.row(4) << 0.3, 0.3, 1;
  EXPECT_TRUE(triangles_intersect(m, 0, 1));
  // Touching only along the shared vertex's side: the second lies on the
  // first's edge 0–1 but its far edge stays clear.
  m.vertices.row(3) << 0.5, 0, 0;
  m.vertices.row(4) << 0.5, -1, 0.5;
  EXPECT_TRUE(triangles_intersect(m, 0, 1));  // vertex 3 lies on triangle 0: the far edge 3–4 touches it
  // Duplicated triangle.
  m.triangles.row(1) << 2, 0, 1;
  EXPECT_TRUE(triangles_intersect(m, 0, 1));
}

TEST(SurfaceQuality, ClosedPrimitivesAreClean) {
  for (const TriangleMesh& mesh : {make_sphere(1.0, 24), make_torus(1.0, 0.3, 32, 12), make_box({1, 2, 3}, 4)}) {
    const SurfaceQuality q = measure_surface_quality(mesh);
    EXPECT_EQ(q.self_intersecting_pairs, 0);
    EXPECT_EQ(q.creased_edges, 0);
    EXPECT_EQ(q.degenerate_triangles, 0);
    EXPECT_EQ(q.edges * 2, q.triangles * 3);
  }
}

TEST(SurfaceQuality, CreasesArePastNinetyDegrees) {
  // A regular tetrahedron: dihedral angles of 70.5°, normals 109.5° apart,
  // all six edges creased. A regular octahedron: normals 70.5° apart, none.
  TriangleMesh tet;
  tet.vertices.resize(4, 3);
  tet.vertices << 1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1;
  tet.triangles.resize(4, 3);
  tet.triangles << 0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2;
  EXPECT_EQ(measure_surface_quality(tet).creased_edges, 6);
  TriangleMesh octa;
  octa.vertices.resize(6, 3);
  octa.vertices << 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1;
  octa.triangles.resize(8, 3);
  octa.triangles << 0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5;
  EXPECT_EQ(measure_surface_quality(octa).creased_edges, 0);
  // A box's edges are at exactly 90°: not creased, however the box is
  // turned and wherever it stands (its coordinates then carry round-off).
  TriangleMesh box = make_box({0.2, 0.2, 0.2}, 8);
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(0.52, Eigen::Vector3d::UnitY()))
                                .toRotationMatrix();
  for (Index v = 0; v < box.num_vertices(); ++v)
    box.vertices.row(v) = (r * box.vertices.row(v).transpose() + Eigen::Vector3d(100.3, -7.1, 0.3)).transpose();
  EXPECT_EQ(measure_surface_quality(box).creased_edges, 0);
}

TEST(SurfaceQuality, TwoInterpenetratingSpheres) {
  // Two spheres of radius 1, centres 1.5 apart: the pairs crossing are those
  // near the circle where the spheres meet, none within one sphere.
  TriangleMesh a = make_sphere(1.0, 16), b = a;
  b.vertices.col(0).array() += 1.5;
  TriangleMesh both = test::joined(a, b);
  const auto pairs = self_intersecting_pairs(both);
  ASSERT_FALSE(pairs.empty());
  for (const auto& p : pairs) {
    EXPECT_LT(p[0], a.num_triangles());
    EXPECT_GE(p[1], a.num_triangles());
  }
  // Moved apart by 2.01 they do not touch.
  b.vertices.col(0).array() += 0.51;
  both.vertices << a.vertices, b.vertices;
  EXPECT_TRUE(self_intersecting_pairs(both).empty());
}

TEST(SurfaceQuality, FoldedSurfaceCountsCreasesAndCrossings) {
  // Push one vertex of a fine sphere through to the far side: its fan now
  // pierces the opposite cap and folds against its neighbours.
  TriangleMesh s = make_sphere(1.0, 20);
  Index top = 0;
  for (Index v = 1; v < s.num_vertices(); ++v)
    if (s.vertices(v, 2) > s.vertices(top, 2)) top = v;
  s.vertices.row(top) << 0.013, 0.021, -1.3;
  const SurfaceQuality q = measure_surface_quality(s);
  EXPECT_GT(q.self_intersecting_pairs, 0);
  EXPECT_GT(q.creased_edges, 0);
}

TEST(SurfaceQuality, SameAnswerOnOneAndTwoThreads) {
  TriangleMesh s = make_sphere(1.0, 40);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (Index v = 0; v < s.num_vertices(); ++v)
    for (int k = 0; k < 3; ++k) s.vertices(v, k) += noise(rng);
  std::vector<std::array<Index, 2>> one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = self_intersecting_pairs(s);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = self_intersecting_pairs(s);
  }
  EXPECT_GT(one.size(), 10u);
  EXPECT_EQ(one, two);
}

TEST(FacingSheets, TwoBoxesFaceEachOtherAcrossANarrowGap) {
  // Unit cubes one above the other, 0.1 apart: the lower one's top and the
  // upper one's bottom (area 1 each, 32 triangles each, each triangle 0.1
  // from its twin) face each other; no other face does (the sides are
  // parallel or perpendicular to them).
  const TriangleMesh lower = make_box({1, 1, 1}, 4);
  TriangleMesh upper = lower;
  upper.vertices.col(2).array() += 1.1;
  const FacingSheets near = facing_sheets(test::joined(lower, upper), 0.3);
  EXPECT_EQ(near.triangles, 64);
  EXPECT_NEAR(near.area, 2.0, 1e-12);
  // Farther apart than the gap: nothing.
  upper.vertices.col(2).array() += 0.4;
  const FacingSheets far = facing_sheets(test::joined(lower, upper), 0.3);
  EXPECT_EQ(far.triangles, 0);
  EXPECT_EQ(far.area, 0.0);
}

TEST(FacingSheets, AThinSlabIsMaterialBetweenItsSidesNotAGap) {
  // Its top and bottom are 0.05 apart with opposed normals, but each lies
  // on the inner side of the other: material between them, not air.
  EXPECT_EQ(facing_sheets(make_box({1, 1, 0.05}, 8), 0.3).triangles, 0);
  EXPECT_EQ(facing_sheets(make_sphere(1.0, 24), 0.5).triangles, 0);  // convex: faces nothing
}

TEST(FacingSheets, OnlyGapsNarrowerThanTheThresholdCount) {
  // Two uprights side by side, 0.1 apart, standing 0.25 above a base: their
  // inner faces (1 × 1 each) face each other within 0.2; their bottoms face
  // the base's top too, but 0.25 away.
  const TriangleMesh base = make_box({2.1, 1, 0.5}, 4);
  TriangleMesh left = make_box({1, 1, 1}, 4), right = left;
  left.vertices.col(0).array() -= 0.55;
  right.vertices.col(0).array() += 0.55;
  left.vertices.col(2).array() += 1.0;
  right.vertices.col(2).array() += 1.0;
  const FacingSheets fold = facing_sheets(test::joined(test::joined(base, left), right), 0.2);
  EXPECT_EQ(fold.triangles, 64);
  EXPECT_NEAR(fold.area, 2.0, 1e-12);
}

TEST(FacingSheets, SameBitsOnOneAndTwoThreads) {
  const TriangleMesh lower = make_box({1, 1, 1}, 12);
  TriangleMesh upper = make_sphere(0.7, 40);
  upper.vertices.col(2).array() += 1.25;
  const TriangleMesh both = test::joined(lower, upper);
  FacingSheets one, two;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = facing_sheets(both, 0.2);
  }
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = facing_sheets(both, 0.2);
  }
  ASSERT_GT(one.triangles, 0);
  EXPECT_EQ(one.triangles, two.triangles);
  EXPECT_EQ(one.area, two.area);
}

// Every pair against every other, by the definition (normals more than
// 120° apart, each centroid on the outer side of the other's plane, closer
// than the gap, no shared vertex): the grid and the skipping of normals of
// one direction must find exactly these, on crumpled sheets facing at every
// orientation (a sphere inside a larger one, both shaken radially).
TEST(FacingSheets, FindsWhatEveryPairAgainstEveryOtherFinds) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> shake(-0.04, 0.04);
  TriangleMesh inner = make_sphere(1.0, 14), outer = make_sphere(1.12, 14);
  for (TriangleMesh* m : {&inner, &outer})
    for (Index v = 0; v < m->num_vertices(); ++v) m->vertices.row(v) *= 1.0 + shake(rng);
  flip_orientation(outer);  // a shell: the outer sheet's normals point in, across the gap
  const TriangleMesh both = test::joined(inner, outer);
  const double gap = 0.2;
  const Index nt = both.num_triangles();
  std::vector<V> centre(static_cast<std::size_t>(nt)), normal(static_cast<std::size_t>(nt));
  std::vector<double> area(static_cast<std::size_t>(nt));
  for (Index t = 0; t < nt; ++t) {
    const auto [a, b, c] = both.corners(t);
    const V n = (b - a).cross(c - a);
    centre[static_cast<std::size_t>(t)] = (a + b + c) / 3.0;
    area[static_cast<std::size_t>(t)] = 0.5 * n.norm();
    normal[static_cast<std::size_t>(t)] = n / n.norm();
  }
  std::vector<std::uint8_t> faces(static_cast<std::size_t>(nt), 0);
  for (Index s = 0; s < nt; ++s)
    for (Index t = s + 1; t < nt; ++t) {
      const auto i = static_cast<std::size_t>(s), j = static_cast<std::size_t>(t);
      const V d = centre[j] - centre[i];
      bool shared = false;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) shared = shared || both.triangles(s, a) == both.triangles(t, b);
      if (normal[i].dot(normal[j]) < -0.5 && d.dot(normal[i]) > 0.0 && d.dot(normal[j]) < 0.0 &&
          d.squaredNorm() < gap * gap && !shared)
        faces[i] = faces[j] = 1;
    }
  FacingSheets expected;
  for (Index t = 0; t < nt; ++t)
    if (faces[static_cast<std::size_t>(t)]) expected.area += area[static_cast<std::size_t>(t)], ++expected.triangles;
  const FacingSheets found = facing_sheets(both, gap);
  ASSERT_GT(expected.triangles, nt / 2);  // most of both sheets face
  EXPECT_EQ(found.triangles, expected.triangles);
  EXPECT_EQ(found.area, expected.area);
}

}  // namespace
}  // namespace goo
