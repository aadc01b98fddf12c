#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <random>

#include "meshing/bcc_lattice.h"
#include "meshing/convex_clip.h"
#include "meshing/lattice_slicing.h"

namespace goo {
namespace {

using Parts = std::vector<std::pair<BccLattice::Key, double>>;
using Tet = std::array<Eigen::Vector3d, 4>;

double signed_volume(const Tet& x) { return (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) / 6.0; }

/// The overlaps found the slow way (overlaps_by_clipping), by key.
std::map<BccLattice::Key, double> clipped_pairwise(const BccLattice& lattice, const Tet& x) {
  Parts parts;
  overlaps_by_clipping(lattice, x, 1e-12, parts);
  return {parts.begin(), parts.end()};
}

/// A random positive tetrahedron of size about `size` near `centre`.
Tet random_tet(std::mt19937_64& rng, const Eigen::Vector3d& centre, double size) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (;;) {
    Tet x;
    for (auto& p : x) p = centre + size * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    if (signed_volume(x) < 0.0) std::swap(x[2], x[3]);
    if (std::abs(signed_volume(x)) > 1e-3 * size * size * size) return x;
  }
}

// Round-off bound of a part's volume: coordinates of at most M = 12 spacings
// (in lattice units, where the slicing runs), each vertex moved by at most
// about 4ε M per cut through at most 12 cuts, times a part's area of at most
// a few h²: ~1e-12 h³; the pairwise clip errs as much.
constexpr double kVolumeTolerance = 1e-11;

// Random tetrahedra, small and large against the lattice, inside the block
// and reaching out of it: the parts are the pairwise clip's, key for key
// (parts of round-off size aside), and inside the block they add up to the
// tetrahedron.
TEST(LatticeSlicing, PartsAreThePairwiseClipsOverlaps) {
  const double h = 0.37;
  const BccLattice lattice(Eigen::Vector3d(-1.1, 0.4, 2.0), h, Eigen::Vector3i(10, 11, 12));
  const double tol = kVolumeTolerance * h * h * h;
  std::mt19937_64 rng(20261203);
  std::uniform_real_distribution<double> where(0.0, 1.0);
  LatticeSlicer slicer;
  Parts parts;
  int outside = 0;
  for (int trial = 0; trial < 400; ++trial) {
    SCOPED_TRACE(trial);
    const double size = h * (trial % 4 == 0 ? 3.0 : trial % 4 == 1 ? 0.2 : 0.8);
    // Mostly inside the block; every 10th reaches over its border.
    const double margin = trial % 10 == 0 ? 0.0 : 0.3;
    const Eigen::Vector3d span = lattice.cells().cast<double>() * h;
    const Eigen::Vector3d centre =
        lattice.origin() + Eigen::Vector3d(margin + (1 - 2 * margin) * where(rng), margin + (1 - 2 * margin) * where(rng),
                                           margin + (1 - 2 * margin) * where(rng))
                               .cwiseProduct(span);
    const Tet x = random_tet(rng, centre, size);
    slicer.overlaps(lattice, x, 1e-12, parts);
    const std::map<BccLattice::Key, double> expected = clipped_pairwise(lattice, x);
    double total = 0.0, expected_total = 0.0;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (i > 0) {
        EXPECT_LT(parts[i - 1].first, parts[i].first);  // increasing, each once
      }
      EXPECT_GT(parts[i].second, 0.0);
      const auto it = expected.find(parts[i].first);
      if (it == expected.end()) {
        EXPECT_LE(parts[i].second, tol) << "key " << parts[i].first;
      } else {
        EXPECT_NEAR(parts[i].second, it->second, tol) << "key " << parts[i].first;
      }
      total += parts[i].second;
    }
    for (const auto& [key, v] : expected) {
      expected_total += v;
      if (v > tol) {
        EXPECT_TRUE(std::any_of(parts.begin(), parts.end(), [&](const auto& p) { return p.first == key; }))
            << "missing key " << key << " of volume " << v;
      }
    }
    EXPECT_NEAR(total, expected_total, tol * static_cast<double>(expected.size() + 1));
    const bool inside = ((x[0].cwiseMin(x[1]).cwiseMin(x[2]).cwiseMin(x[3]) - lattice.origin()).array() > h).all() &&
                        ((lattice.origin() + span - x[0].cwiseMax(x[1]).cwiseMax(x[2]).cwiseMax(x[3])).array() > h).all();
    if (inside) {
      EXPECT_NEAR(total, signed_volume(x), tol * static_cast<double>(parts.size() + 1));
    } else {
      ++outside;
    }
  }
  EXPECT_GT(outside, 10);  // the block's border was exercised
}

// Tetrahedra whose corners sit on lattice nodes, on the planes' crossings
// (quarter spacings) or within the tolerance of them: planes through
// vertices, edges and faces, where a cut passes through a vertex and leaves
// copies of it. The parts are the pairwise clip's, they add up to the
// tetrahedron, and no piece outgrows the slicer's graph (no fallback).
TEST(LatticeSlicing, DegenerateTetrahedraOnTheLatticesPlanesNeedNoFallback) {
  const double h = 0.5;
  const BccLattice lattice(Eigen::Vector3d(0.25, -0.5, 1.0), h, Eigen::Vector3i(10, 10, 10));
  const double tol = kVolumeTolerance * h * h * h;
  std::mt19937_64 rng(20261207);
  std::uniform_int_distribution<int> quarter(12, 28);  // 3 to 7 spacings, in quarters
  std::uniform_int_distribution<int> kind(0, 2);
  std::uniform_real_distribution<double> tiny(-1e-13, 1e-13);
  LatticeSlicer slicer;
  Parts parts;
  int tried = 0;
  for (int trial = 0; trial < 600; ++trial) {
    SCOPED_TRACE(trial);
    Tet x;
    for (auto& p : x) {
      Eigen::Vector3d u(0.25 * quarter(rng), 0.25 * quarter(rng), 0.25 * quarter(rng));
      if (kind(rng) == 1) u = u.array().round();                                  // a lattice corner node
      if (trial % 3 == 0) u += Eigen::Vector3d(tiny(rng), tiny(rng), tiny(rng));  // within the tolerance
      p = lattice.origin() + h * u;
    }
    if (signed_volume(x) < 0.0) std::swap(x[2], x[3]);
    if (!(signed_volume(x) > 1e-3 * h * h * h)) continue;
    ++tried;
    slicer.overlaps(lattice, x, 1e-12, parts);
    const std::map<BccLattice::Key, double> expected = clipped_pairwise(lattice, x);
    double total = 0.0;
    for (const auto& [key, v] : parts) {
      const auto it = expected.find(key);
      EXPECT_NEAR(v, it == expected.end() ? 0.0 : it->second, tol) << "key " << key;
      total += v;
    }
    for (const auto& [key, v] : expected)
      if (v > tol) {
        EXPECT_TRUE(std::any_of(parts.begin(), parts.end(), [&](const auto& p) { return p.first == key; })) << key;
      }
    EXPECT_NEAR(total, signed_volume(x), tol * static_cast<double>(parts.size() + 1));
  }
  EXPECT_GT(tried, 300);
  EXPECT_EQ(slicer.fallbacks(), 0U);
}

// A tetrahedron lying exactly on lattice planes: a lattice tetrahedron is
// one part, itself; two lattice tetrahedra's worth of a larger one made of
// lattice faces are split along the planes without slivers. Faces on the
// planes cut nothing off.
TEST(LatticeSlicing, ATetrahedronOnTheLatticePlanesIsWholeParts) {
  const double h = 0.5;
  const BccLattice lattice(Eigen::Vector3d::Zero(), h, Eigen::Vector3i(6, 6, 6));
  LatticeSlicer slicer;
  Parts parts;
  const BccLattice::Key key = lattice.tet_key({2, 3, 1}, 1, 2);
  const auto nodes = lattice.tet_nodes(key);
  const Tet t = {lattice.position(nodes[0]), lattice.position(nodes[1]), lattice.position(nodes[2]),
                 lattice.position(nodes[3])};
  slicer.overlaps(lattice, t, 1e-12, parts);
  ASSERT_EQ(parts.size(), 1U);
  EXPECT_EQ(parts[0].first, key);
  EXPECT_NEAR(parts[0].second, lattice.tet_volume(), 1e-14);
  // Scaled by 2 about a corner node: 8 lattice tetrahedra's volume, each part
  // a whole lattice tetrahedron (a face-aligned scaling of a BCC tetrahedron
  // by 2 is tiled by them: its faces lie on lattice planes).
  Tet big = t;
  for (auto& p : big) p = t[0] + 2.0 * (p - t[0]);
  slicer.overlaps(lattice, big, 1e-12, parts);
  ASSERT_EQ(parts.size(), 8U);
  for (const auto& [k, v] : parts) EXPECT_NEAR(v, lattice.tet_volume(), 1e-14) << "key " << k;
}

// A tetrahedron reaching a million spacings out of the block costs no more
// than the block: its parts are the block's share (the pairwise clip's),
// found without slicing the space outside. A tetrahedron or a triangle
// that is not finite has no parts, and the slicing ends.
TEST(LatticeSlicing, PartsOutsideTheBlockAreDroppedAndNonFiniteInputHasNone) {
  const double h = 0.5;
  const BccLattice lattice(Eigen::Vector3d(0.3, -0.2, 0.1), h, Eigen::Vector3i(4, 5, 6));
  LatticeSlicer slicer;
  Parts parts;
  const Eigen::Vector3d inside = lattice.origin() + Eigen::Vector3d(1.1, 1.3, 1.7);
  const double far = 1e6 * h;
  Tet x = {inside, inside + Eigen::Vector3d(far, 0.1 * far, 0.0), inside + Eigen::Vector3d(0.0, far, 0.2 * far),
           inside + Eigen::Vector3d(0.1 * far, 0.0, far)};
  if (signed_volume(x) < 0.0) std::swap(x[2], x[3]);
  slicer.overlaps(lattice, x, 1e-12, parts);
  const std::map<BccLattice::Key, double> expected = clipped_pairwise(lattice, x);
  // The huge tetrahedron's own size sets the round-off of its parts: its
  // faces' planes are computed from vertices 1e6 h away.
  const double tol = 1e-6 * lattice.tet_volume();
  ASSERT_FALSE(expected.empty());
  for (const auto& [key, v] : parts) {
    const auto it = expected.find(key);
    EXPECT_NEAR(v, it == expected.end() ? 0.0 : it->second, tol) << "key " << key;
  }
  for (const auto& [key, v] : expected)
    if (v > tol) {
      EXPECT_TRUE(std::any_of(parts.begin(), parts.end(), [&](const auto& p) { return p.first == key; })) << key;
    }
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const double bad : {nan, inf, -inf}) {
    Tet y = x;
    y[1].x() = bad;
    slicer.overlaps(lattice, y, 1e-12, parts);
    EXPECT_TRUE(parts.empty());
    Polygon triangle;
    for (const Eigen::Vector3d& p : {inside, Eigen::Vector3d(inside + Eigen::Vector3d(bad, 0.1, 0.0)),
                                     Eigen::Vector3d(inside + Eigen::Vector3d(0.0, 0.3, 0.1))})
      triangle.push(p);
    std::vector<PolygonPart> polygon_parts;
    slicer.polygon_parts(lattice, triangle, 1e-12, polygon_parts);
    EXPECT_TRUE(polygon_parts.empty());
  }
}

// Moving the tetrahedron by a lattice vector moves every part to the same
// tetrahedron shape in the moved cell, with the same volume (round-off).
TEST(LatticeSlicing, ALatticeTranslationMovesThePartsAlong) {
  const double h = 0.25;
  const BccLattice lattice(Eigen::Vector3d(0.1, 0.2, 0.3), h, Eigen::Vector3i(12, 12, 12));
  std::mt19937_64 rng(7);
  LatticeSlicer slicer;
  Parts a, b;
  for (int trial = 0; trial < 50; ++trial) {
    const Tet x = random_tet(rng, lattice.origin() + Eigen::Vector3d::Constant(3.3 * h), 1.5 * h);
    Tet moved = x;
    const Eigen::Vector3i shift(2, 5, 1);
    for (auto& p : moved) p += h * shift.cast<double>();
    slicer.overlaps(lattice, x, 1e-12, a);
    slicer.overlaps(lattice, moved, 1e-12, b);
    std::map<BccLattice::Key, double> by_key;
    for (const auto& [key, v] : b) by_key[key] = v;
    for (const auto& [key, v] : a) {
      // The key of the same shape in the shifted cell: the lattice positions of
      // its nodes moved by the shift.
      const auto nodes = lattice.tet_nodes(key);
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const auto n : nodes) centre += 0.25 * lattice.position(n);
      const auto there = lattice.locate(centre + h * shift.cast<double>());
      ASSERT_TRUE(there.has_value());
      const auto it = by_key.find(*there);
      if (v <= kVolumeTolerance * h * h * h && it == by_key.end()) continue;
      ASSERT_NE(it, by_key.end());
      EXPECT_NEAR(it->second, v, kVolumeTolerance * h * h * h);
    }
  }
}

}  // namespace
}  // namespace goo
