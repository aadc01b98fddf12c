#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "core/primitives.h"
#include "core/radix_sort.h"
#include "core/surface_topology.h"

namespace goo {
namespace {

// Stability is what the callers rely on (items filled in one order, sorted
// by a key that repeats, come out sorted by key then fill order): the radix
// sort must match std::stable_sort on keys with many repeats, spread over
// every digit, and on keys that share all their high digits.
TEST(RadixSort, MatchesAStableSortOnRepeatedKeys) {
  std::mt19937_64 rng(11);
  for (const int bits : {3, 20, 40, 64}) {
    std::vector<std::pair<std::uint64_t, int>> items(20000);
    for (std::size_t i = 0; i < items.size(); ++i) {
      const std::uint64_t key = bits == 64 ? rng() : rng() & ((std::uint64_t{1} << bits) - 1);
      items[i] = {key, static_cast<int>(i)};
    }
    auto expected = items;
    std::stable_sort(expected.begin(), expected.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    radix_sort(items, [](const std::pair<std::uint64_t, int>& item) { return item.first; });
    EXPECT_EQ(items, expected) << bits << " bits";
  }
  std::vector<std::pair<std::uint64_t, int>> none;
  radix_sort(none, [](const std::pair<std::uint64_t, int>& item) { return item.first; });
  EXPECT_TRUE(none.empty());
}

// The sides of a surface come out sorted by all four entries, as a sort of
// the whole tuples would give them.
TEST(SortedSides, AreEveryTrianglesSidesSortedByEdgeThenTriangle) {
  const TriangleMesh sphere = make_sphere(1.0, 24);
  std::vector<std::array<Index, 4>> expected;
  for (Index t = 0; t < sphere.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index a = sphere.triangles(t, k), b = sphere.triangles(t, (k + 1) % 3);
      expected.push_back({std::min(a, b), std::max(a, b), t, k});
    }
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(sorted_sides(sphere.triangles), expected);
}

// On a closed surface every edge has its two triangles, each the other's
// neighbour across the same edge; an open edge and an edge met by three
// triangles (not manifold: no one of them is the neighbour) have none.
TEST(TrianglesAcross, PairsTheTwoTrianglesOfEachEdgeAndNoneElsewhere) {
  const TriangleMesh sphere = make_sphere(1.0, 12);
  const auto across = triangles_across(sphere.triangles);
  for (Index t = 0; t < sphere.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index a = sphere.triangles(t, k), b = sphere.triangles(t, (k + 1) % 3);
      const Index u = across(t, k);
      ASSERT_GE(u, 0);
      ASSERT_NE(u, t);
      int back = -1;  // the side of u on the same edge, pointing back at t
      for (int j = 0; j < 3; ++j)
        if (sphere.triangles(u, j) == b && sphere.triangles(u, (j + 1) % 3) == a) back = j;
      ASSERT_GE(back, 0) << "triangle " << u << " does not share edge " << a << "-" << b << " reversed";
      EXPECT_EQ(across(u, back), t);
    }
  // Three triangles on edge 0-1 (a fin) and a lone edge elsewhere.
  Triangles fin(3, 3);
  fin << 0, 1, 2, 1, 0, 3, 0, 1, 4;
  const auto fin_across = triangles_across(fin);
  EXPECT_TRUE((fin_across.array() == -1).all()) << fin_across;
  Triangles two(2, 3);
  two << 0, 1, 2, 1, 0, 3;
  const auto two_across = triangles_across(two);
  EXPECT_EQ(two_across(0, 0), 1);
  EXPECT_EQ(two_across(1, 0), 0);
  EXPECT_EQ(two_across(0, 1), -1);
  EXPECT_EQ(two_across(1, 2), -1);
}

}  // namespace
}  // namespace goo
