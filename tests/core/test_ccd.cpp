// Distances and continuous collision detection of surface primitives
// against exact answers on constructed cases, and the broad phase
// against every pair.
#include <gtest/gtest.h>

#include "core/contact/box_pairs.h"
#include "core/contact/ccd.h"

#include <algorithm>
#include <random>

namespace goo::ccd {
namespace {

using V = Vec3;

TEST(Distance, PointTriangleRegions) {
  const V a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  Vec3 w;
  EXPECT_DOUBLE_EQ(point_triangle_distance2(V(0.2, 0.3, 2), a, b, c, &w), 4.0);  // above the face
  EXPECT_NEAR(w[1], 0.2, 1e-15);
  EXPECT_NEAR(w[2], 0.3, 1e-15);
  EXPECT_DOUBLE_EQ(point_triangle_distance2(V(0.5, -1, 0), a, b, c, &w), 1.0);  // beside edge ab
  EXPECT_NEAR(w[1], 0.5, 1e-15);
  EXPECT_DOUBLE_EQ(point_triangle_distance2(V(-1, -1, 1), a, b, c, &w), 3.0);  // beyond corner a
  EXPECT_EQ(w, V(1, 0, 0));
  EXPECT_NEAR(point_triangle_distance2(V(1, 1, 0), a, b, c, &w), 0.5, 1e-15);  // beyond the hypotenuse
  EXPECT_NEAR(w[1], 0.5, 1e-15);
  // A triangle without area: its longest edge.
  EXPECT_NEAR(point_triangle_distance2(V(0.5, 1, 0), a, b, V(0.5, 0, 0)), 1.0, 1e-15);
}

TEST(Distance, SegmentSegment) {
  double s = 0, u = 0;
  // Skew lines crossing at distance 1.
  EXPECT_DOUBLE_EQ(segment_segment_distance2(V(-1, 0, 0), V(1, 0, 0), V(0, -1, 1), V(0, 1, 1), &s, &u), 1.0);
  EXPECT_DOUBLE_EQ(s, 0.5);
  EXPECT_DOUBLE_EQ(u, 0.5);
  // Crossing: 0.
  EXPECT_DOUBLE_EQ(segment_segment_distance2(V(-1, 0, 0), V(1, 0, 0), V(0, -1, 0), V(0, 1, 0)), 0.0);
  // Parallel, overlapping in x, 2 apart; and end to end, 3 apart.
  EXPECT_DOUBLE_EQ(segment_segment_distance2(V(0, 0, 0), V(2, 0, 0), V(1, 2, 0), V(3, 2, 0)), 4.0);
  EXPECT_DOUBLE_EQ(segment_segment_distance2(V(0, 0, 0), V(1, 0, 0), V(4, 0, 0), V(5, 0, 0)), 9.0);
  // A point against a segment.
  EXPECT_DOUBLE_EQ(segment_segment_distance2(V(0.5, 1, 0), V(0.5, 1, 0), V(0, 0, 0), V(1, 0, 0)), 1.0);
}

// A pair is reported approaching, between min_distance and twice that.

TEST(TimeOfImpact, VertexThroughFace) {
  // The vertex falls from z = 1 to z = −1 through the face at t = 0.5.
  const Points4 x{V(0.2, 0.2, 1), V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)};
  const Points4 d{V(0, 0, -2), V(0, 0, 0), V(0, 0, 0), V(0, 0, 0)};
  const double delta = 1e-3;
  const auto toi = time_of_impact(PairKind::vertex_triangle, x, d, delta);
  ASSERT_TRUE(toi);
  // Distance 1 − 2t at the reported time lies in [δ, 2δ].
  EXPECT_GE(1 - 2 * *toi, delta);
  EXPECT_LE(1 - 2 * *toi, 2 * delta + 1e-12);
  // Passing beside the triangle, and stopping short of it: nothing.
  Points4 beside = x;
  beside[0] = V(0.8, 0.8, 1);
  EXPECT_FALSE(time_of_impact(PairKind::vertex_triangle, beside, d, delta));
  Points4 short_d = d;
  short_d[0] = V(0, 0, -0.99);
  EXPECT_FALSE(time_of_impact(PairKind::vertex_triangle, x, short_d, 0.0));
  // Only the relative motion counts: the whole pair moving together.
  const Points4 together{V(0, 0, -2), V(0, 0, -2), V(0, 0, -2), V(0, 0, -2)};
  EXPECT_FALSE(time_of_impact(PairKind::vertex_triangle, x, together, delta));
  // Separating.
  Points4 up = d;
  up[0] = V(0, 0, 2);
  EXPECT_FALSE(time_of_impact(PairKind::vertex_triangle, x, up, delta));
  // The triangle rising to meet the vertex at t = 0.25.
  const Points4 rise{V(0, 0, -2), V(0, 0, 2), V(0, 0, 2), V(0, 0, 2)};
  const auto meet = time_of_impact(PairKind::vertex_triangle, x, rise, delta);
  ASSERT_TRUE(meet);
  EXPECT_GE(1 - 4 * *meet, delta);
  EXPECT_LE(1 - 4 * *meet, 2 * delta + 1e-12);
}

TEST(TimeOfImpact, VertexSlidingInThePlaneThroughAnEdge) {
  // Degenerate: the vertex moves in the triangle's plane, through edge bc.
  const Points4 x{V(1, 1, 0), V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)};
  const Points4 d{V(-1, -1, 0), V(0, 0, 0), V(0, 0, 0), V(0, 0, 0)};
  const auto toi = time_of_impact(PairKind::vertex_triangle, x, d, 1e-4);
  ASSERT_TRUE(toi);
  const double distance = (1 - *toi) * std::sqrt(2.0) - std::sqrt(0.5);  // to the edge x + y = 1
  EXPECT_GE(distance, 1e-4);
  EXPECT_LE(distance, 2e-4 + 1e-12);
}

TEST(TimeOfImpact, EdgesCrossing) {
  // Edge a along x at z = 1 falls onto edge b along y at z = 0 and through it.
  const Points4 x{V(-1, 0, 1), V(1, 0, 1), V(0, -1, 0), V(0, 1, 0)};
  const Points4 d{V(0, 0, -2), V(0, 0, -2), V(0, 0, 0), V(0, 0, 0)};
  const double delta = 1e-3;
  const auto toi = time_of_impact(PairKind::edge_edge, x, d, delta);
  ASSERT_TRUE(toi);
  EXPECT_GE(1 - 2 * *toi, delta);
  EXPECT_LE(1 - 2 * *toi, 2 * delta + 1e-12);
  // Shifted along x beyond b's reach: they pass.
  Points4 far = x;
  far[0] += V(3, 0, 0);
  far[1] += V(3, 0, 0);
  EXPECT_FALSE(time_of_impact(PairKind::edge_edge, far, d, delta));
  // Parallel edges closing in: caught before they come within δ.
  const Points4 parallel{V(0, 0, 1), V(1, 0, 1), V(0.5, 0, 0), V(1.5, 0, 0)};
  const auto p = time_of_impact(PairKind::edge_edge, parallel, d, delta);
  ASSERT_TRUE(p);
  EXPECT_GE(1 - 2 * *p, delta);
  EXPECT_LE(1 - 2 * *p, 2 * delta + 1e-12);
}

TEST(TimeOfImpact, StartingWithinTheDistanceReportsZero) {
  const Points4 x{V(0.2, 0.2, 1e-4), V(0, 0, 0), V(1, 0, 0), V(0, 1, 0)};
  const Points4 d{V::Zero(), V::Zero(), V::Zero(), V::Zero()};
  EXPECT_EQ(time_of_impact(PairKind::vertex_triangle, x, d, 1e-3), 0.0);
}

TEST(BoxPairs, EveryOverlappingPairOnceAndNoneOfOneGroup) {
  // 600 boxes of sizes over two decades (the grid's cell is their mean)
  // against all 179,700 pairs; then with every box in one of 40 groups
  // (a fifth in none), pairs within a group left out.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> place(0.0, 1.0), size(0.002, 0.2);
  std::vector<Box3> boxes;
  for (int i = 0; i < 600; ++i) {
    const Eigen::Vector3d lo(place(rng), place(rng), place(rng));
    boxes.emplace_back(lo, lo + Eigen::Vector3d(size(rng), size(rng), size(rng)));
  }
  std::vector<Index> groups(boxes.size());
  for (std::size_t i = 0; i < boxes.size(); ++i) groups[i] = i % 5 == 0 ? -1 : static_cast<Index>(i % 40);
  for (const bool grouped : {false, true}) {
    std::vector<std::array<Index, 2>> expected;
    for (Index i = 0; i < 600; ++i)
      for (Index j = i + 1; j < 600; ++j) {
        if (grouped && groups[static_cast<std::size_t>(i)] >= 0 && groups[static_cast<std::size_t>(i)] == groups[static_cast<std::size_t>(j)]) continue;
        if (boxes[static_cast<std::size_t>(i)].intersects(boxes[static_cast<std::size_t>(j)])) expected.push_back({i, j});
      }
    std::vector<std::array<Index, 2>> found = overlapping_pairs(boxes, grouped ? &groups : nullptr);
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, expected) << (grouped ? "with groups" : "without groups");
    EXPECT_GT(expected.size(), 1000u);
  }
}

// Boxes with corners on a grid of 1/32 touch one another exactly, face,
// edge or corner, in hundreds of pairs: closed boxes, touching counts
// (every one of the six tests is ≤, in the vector lanes and the scalar
// tail alike). And two sets paired across (a box of `a` with a box of
// `b`), against all pairs.
TEST(BoxPairs, TouchingBoxesMeetAndTwoSetsPairAcross) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> place(0, 31), size(1, 4);
  auto boxes = [&](int count) {
    std::vector<Box3> out;
    for (int i = 0; i < count; ++i) {
      const Eigen::Vector3d lo(place(rng), place(rng), place(rng));
      out.emplace_back(lo / 32.0, (lo + Eigen::Vector3d(size(rng), size(rng), size(rng))) / 32.0);
    }
    return out;
  };
  const std::vector<Box3> a = boxes(501), b = boxes(300);
  std::vector<std::array<Index, 2>> expected, touching;
  for (Index i = 0; i < 501; ++i)
    for (Index j = i + 1; j < 501; ++j) {
      const Box3 &p = a[static_cast<std::size_t>(i)], &q = a[static_cast<std::size_t>(j)];
      if (!p.intersects(q)) continue;
      expected.push_back({i, j});
      if (p.intersection(q).volume() == 0.0) touching.push_back({i, j});
    }
  std::vector<std::array<Index, 2>> found = overlapping_pairs(a);
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, expected);
  EXPECT_GT(touching.size(), 300u);
  std::vector<std::array<Index, 2>> across;
  for (Index i = 0; i < 501; ++i)
    for (Index j = 0; j < 300; ++j)
      if (a[static_cast<std::size_t>(i)].intersects(b[static_cast<std::size_t>(j)])) across.push_back({i, j});
  found = overlapping_pairs(a, b);
  std::sort(found.begin(), found.end());
  EXPECT_EQ(found, across);
}

}  // namespace
}  // namespace goo::ccd
