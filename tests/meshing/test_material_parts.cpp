#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "core/primitives.h"
#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "core/tet_mesh.h"
#include "core/union_find.h"
#include "meshing/exact_mass.h"
#include "meshing/lattice_slicing.h"
#include "meshing/material_parts.h"
#include "meshing/voxelize.h"
#include "tests/common/test_common.h"
#include "tests/meshing/lattice_cases.h"

namespace goo {
namespace {

TriangleMesh moved(TriangleMesh mesh, const Eigen::Matrix3d& R, const Eigen::Vector3d& shift) {
  mesh.vertices = (mesh.vertices * R.transpose()).rowwise() + shift.transpose();
  return mesh;
}

Eigen::Matrix3d tilt(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
}

/// The solid of `piece` in each element of a lattice mesh built around a
/// surface that holds it (the inside flags recomputed for the piece alone).
ElementSolid piece_solid(const LatticeMesh& lm, const TriangleMesh& piece) {
  LatticeMesh alone = lm;
  const std::vector<std::uint8_t> inside = voxelize(lm.lattice, piece);
  for (std::size_t n = 0; n < alone.node_keys.size(); ++n)
    alone.node_inside[n] = inside[static_cast<std::size_t>(alone.node_keys[n])];
  return clip_solid_to_elements(alone, piece);
}

/// Pieces of one surface that are each convex: in every element each has
/// one part (a convex solid ∩ a tetrahedron is convex), so the element's
/// parts are exactly the pieces that reach into it, with their volumes.
void expect_parts_are_the_convex_pieces(const std::vector<TriangleMesh>& pieces, double h, Index* split = nullptr) {
  TriangleMesh surface = pieces[0];
  for (std::size_t i = 1; i < pieces.size(); ++i) surface = test::joined(surface, pieces[i]);
  const LatticeMesh lm = build_lattice_mesh(surface, h);
  const MaterialParts parts = material_parts(lm, surface);
  const double tet = lm.lattice.tet_volume();
  // A piece reaching less than this into an element is round-off's to
  // decide (the clipping is exact up to about 1e-15 of the element).
  const double tiny = 1e-9 * tet;
  std::vector<ElementSolid> solids;
  std::vector<Eigen::VectorXd> volumes;
  for (const auto& piece : pieces) {
    solids.push_back(piece_solid(lm, piece));
    volumes.push_back(solids.back().volume);
  }
  ASSERT_EQ(parts.num_elements(), lm.mesh.num_elements());
  EXPECT_EQ(parts.degenerate_elements(), 0);
  Index checked = 0, several = 0;
  const Index np = parts.first_part.back();
  std::vector<int> piece_of_part(at(np), -1);  // −1: not decided here
  for (Index e = 0; e < parts.num_elements(); ++e) {
    std::vector<std::pair<double, int>> expected, found;
    bool ambiguous = false;
    for (std::size_t i = 0; i < volumes.size(); ++i) {
      if (volumes[i][e] > tiny) expected.push_back({volumes[i][e], static_cast<int>(i)});
      ambiguous = ambiguous || (volumes[i][e] > 0.0 && volumes[i][e] <= tiny);
    }
    for (Index p = parts.first_part[at(e)]; p < parts.first_part[at(e) + 1]; ++p)
      found.push_back({parts.part_volume[p], static_cast<int>(p)});
    if (ambiguous) continue;
    ++checked;
    std::sort(expected.begin(), expected.end());
    std::sort(found.begin(), found.end());
    ASSERT_EQ(found.size(), expected.size()) << "element " << e;
    for (std::size_t i = 0; i < found.size(); ++i) {
      EXPECT_NEAR(found[i].first, expected[i].first, 1e-10 * tet) << "element " << e;
      piece_of_part[at(found[i].second)] = expected[i].second;
      // The same first moment (volume × centroid) about the element's corner.
      const Eigen::Vector3d corner = lm.mesh.positions.row(lm.mesh.tets(e, 0)).transpose();
      const Eigen::Vector3d mine = found[i].first * (parts.part_centroid.row(found[i].second).transpose() - corner);
      const Eigen::Vector3d theirs =
          expected[i].first *
          (solids[static_cast<std::size_t>(expected[i].second)].centroid.row(e).transpose() - corner);
      EXPECT_LT((mine - theirs).norm(), 1e-10 * tet * h) << "element " << e;
    }
    several += found.size() >= 2 ? 1 : 0;
  }
  EXPECT_GT(checked, parts.num_elements() * 9 / 10);
  EXPECT_EQ(parts.split_elements(), several);
  if (split) *split = several;
  // The node copies never glue two pieces (no copy is a corner of parts of
  // two pieces) and never crack one (each piece's parts are connected
  // through the copies they share).
  ASSERT_EQ(parts.part_nodes.size(), at(np));
  std::vector<int> piece_of_copy(parts.copy_node.size(), -1);
  UnionFind connected(np + static_cast<Index>(parts.copy_node.size()));
  for (Index p = 0; p < np; ++p)
    for (const Index c : parts.part_nodes[at(p)]) {
      connected.unite(p, np + c);
      const int piece = piece_of_part[at(p)];
      if (piece < 0) continue;
      if (piece_of_copy[at(c)] < 0) piece_of_copy[at(c)] = piece;
      EXPECT_EQ(piece_of_copy[at(c)], piece)
          << "copy " << c << " of node " << parts.copy_node[at(c)] << " glues two pieces";
    }
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    Index root = -1;
    for (Index p = 0; p < np; ++p) {
      if (piece_of_part[at(p)] != static_cast<int>(i)) continue;
      if (root < 0) root = connected.find(p);
      EXPECT_EQ(connected.find(p), root) << "piece " << i << " falls apart at part " << p;
    }
  }
  // Each node copy sits at a node of the element of every part using it.
  for (Index e = 0; e < parts.num_elements(); ++e)
    for (Index p = parts.first_part[at(e)]; p < parts.first_part[at(e) + 1]; ++p)
      for (int k = 0; k < 4; ++k)
        EXPECT_EQ(parts.copy_node[at(parts.part_nodes[at(p)][static_cast<std::size_t>(k)])], lm.mesh.tets(e, k));
  if (several > 0) {
    EXPECT_GT(parts.duplicated_nodes(), 0);
  }
}

// Two boxes a third of the spacing apart, tilted: the elements across the
// gap hold one part of each; each part's volume is its box's solid there.
TEST(MaterialParts, TwoBoxesAcrossAGapAreTwoPartsWhereTheyShareElements) {
  const double h = 0.2;
  const Eigen::Matrix3d R = tilt(0.3);
  const TriangleMesh a = moved(make_box({1.0, 0.8, 0.6}, 3), R, {0.013, -0.021, 0.007});
  const TriangleMesh b = moved(make_box({1.0, 0.8, 0.6}, 3), R,
                               R * Eigen::Vector3d(1.0 + h / 3.0, 0.0, 0.0) + Eigen::Vector3d(0.013, -0.021, 0.007));
  Index split = 0;
  expect_parts_are_the_convex_pieces({a, b}, h, &split);
  EXPECT_GT(split, 20);  // the gap's face is 0.8 × 0.6 = 12 h²
}

// Two strands a hundredth of the spacing thick, a third of it apart: no
// inside node at all, every part bounded by a patch that crosses no edge
// of its element, or crosses edges outside the material.
TEST(MaterialParts, TwoThinStrandsSideBySideAreTwoParts) {
  const double h = 0.2;
  const Eigen::Matrix3d R = tilt(0.7);
  const TriangleMesh a = moved(make_box({1.5, 0.002, 0.002}, 2), R, {0.011, 0.017, -0.013});
  const TriangleMesh b = moved(make_box({1.5, 0.002, 0.002}, 2), R,
                               R * Eigen::Vector3d(0.0, h / 3.0, 0.0) + Eigen::Vector3d(0.011, 0.017, -0.013));
  Index split = 0;
  expect_parts_are_the_convex_pieces({a, b}, h, &split);
  EXPECT_GT(split, 5);
}

// One convex solid is one part in every element it reaches: a tilted box, a
// thin tilted sheet (no inside node), a sphere.
TEST(MaterialParts, AConvexSolidIsOnePartEverywhere) {
  const Eigen::Matrix3d R = tilt(0.3);
  for (const auto& [surface, h] : {std::pair{moved(make_box({1.0, 0.8, 0.6}, 3), R, {0.013, -0.021, 0.007}), 0.2},
                                   std::pair{moved(make_box({1.0, 0.8, 0.002}, 3), R, {0.013, -0.021, 0.007}), 0.2},
                                   std::pair{moved(make_sphere(1.0, 24), R, {0.013, -0.021, 0.007}), 0.2}}) {
    Index split = -1;
    expect_parts_are_the_convex_pieces({surface}, h, &split);
    EXPECT_EQ(split, 0);
  }
}

/// The prism over a polygon in the x–z plane (vertices `profile`, closed,
/// its caps the triangle fans `caps`), from y = 0 to y = depth, outward.
TriangleMesh prism(const std::vector<Eigen::Vector2d>& profile, const std::vector<std::array<int, 3>>& caps,
                   double depth) {
  const auto n = static_cast<Index>(profile.size());
  TriangleMesh mesh;
  mesh.vertices.resize(2 * n, 3);
  for (Index i = 0; i < n; ++i) {
    mesh.vertices.row(i) << profile[at(i)].x(), 0.0, profile[at(i)].y();
    mesh.vertices.row(n + i) << profile[at(i)].x(), depth, profile[at(i)].y();
  }
  std::vector<std::array<Index, 3>> tris;
  for (const auto& c : caps) {
    tris.push_back({c[0], c[1], c[2]});
    tris.push_back({n + c[0], n + c[2], n + c[1]});
  }
  for (Index i = 0; i < n; ++i) {
    const Index j = (i + 1) % n;
    tris.push_back({j, i, n + i});
    tris.push_back({j, n + i, n + j});
  }
  mesh.triangles.resize(static_cast<Index>(tris.size()), 3);
  for (std::size_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k) mesh.triangles(static_cast<Index>(t), k) = tris[t][static_cast<std::size_t>(k)];
  if (enclosed_volume_by_z_flux(mesh) < 0.0) flip_orientation(mesh);
  return mesh;
}

// One connected solid folded onto itself: a block with a V-shaped notch
// from the top, its two walls (one triangle pair each) meeting at a crease
// 0.2 above the bottom, the gap between them narrower than the spacing
// near it. An element across the gap above the crease holds material of
// both sides, apart in it (joined below, outside it); a triangle of each
// wall meets such an element while their shared crease edge passes
// beneath. The oracle: the block is two convex halves touching on the
// rectangle below the crease, so an element's material is one part where
// it reaches both halves and meets the rectangle, else a part per half.
TEST(MaterialParts, ANotchedBlockIsSplitAcrossItsNotchOnly) {
  const double h = 0.1, w = 0.1, crease = 0.2, depth = 0.6;
  const std::vector<Eigen::Vector2d> profile = {{0.0, 0.0}, {0.5, 0.0}, {1.0, 0.0},         {1.0, 1.0},
                                                {0.5 + w, 1.0}, {0.5, crease}, {0.5 - w, 1.0}, {0.0, 1.0}};
  const Eigen::Matrix3d R = tilt(0.2);
  const Eigen::Vector3d shift(0.013, -0.021, 0.007);
  const TriangleMesh block = moved(prism(profile, {{0, 1, 5}, {0, 5, 6}, {0, 6, 7}, {1, 2, 3}, {1, 3, 4}, {1, 4, 5}},
                                         depth),
                                   R, shift);
  const TriangleMesh left = moved(prism({profile[0], profile[1], profile[5], profile[6], profile[7]},
                                        {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}}, depth),
                                  R, shift);
  const TriangleMesh right = moved(prism({profile[1], profile[2], profile[3], profile[4], profile[5]},
                                         {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}}, depth),
                                   R, shift);
  const LatticeMesh lm = build_lattice_mesh(block, h);
  const MaterialParts parts = material_parts(lm, block);
  const ElementSolid a = piece_solid(lm, left), b = piece_solid(lm, right);
  // Where the halves touch: the rectangle x = 0.5, 0 ≤ z ≤ crease, its area
  // in each lattice tetrahedron.
  Polygon contact;
  for (const auto& [y, z] : {std::pair{0.0, 0.0}, std::pair{depth, 0.0}, std::pair{depth, crease},
                             std::pair{0.0, crease}})
    contact.push(R * Eigen::Vector3d(0.5, y, z) + shift);
  LatticeSlicer slicer;
  std::vector<PolygonPart> pieces;
  slicer.polygon_parts(lm.lattice, contact, 1e-12, pieces);
  std::vector<double> touching(at(lm.mesh.num_elements()), 0.0);
  for (const PolygonPart& piece : pieces)
    if (const Index e = lm.element(piece.key); e >= 0) {
      for (int i = 1; i + 1 < piece.polygon.size; ++i)
        touching[at(e)] += 0.5 * (piece.polygon.v[static_cast<std::size_t>(i)] - piece.polygon.v[0])
                                     .cross(piece.polygon.v[static_cast<std::size_t>(i + 1)] - piece.polygon.v[0])
                                     .norm();
    }
  const double tet = lm.lattice.tet_volume(), tiny = 1e-9 * tet, tiny_area = 1e-9 * h * h;
  Index split = 0, checked = 0;
  for (Index e = 0; e < lm.mesh.num_elements(); ++e) {
    const double va = a.volume[e], vb = b.volume[e];
    if ((va > 0.0 && va <= tiny) || (vb > 0.0 && vb <= tiny) ||
        (touching[at(e)] > 0.0 && touching[at(e)] <= tiny_area))
      continue;
    ++checked;
    std::vector<double> expected;
    if (va > tiny && vb > tiny && touching[at(e)] > 0.0)
      expected = {va + vb};
    else
      for (const double v : {va, vb})
        if (v > tiny) expected.push_back(v);
    std::vector<double> found;
    for (Index p = parts.first_part[at(e)]; p < parts.first_part[at(e) + 1]; ++p) found.push_back(parts.part_volume[p]);
    std::sort(expected.begin(), expected.end());
    std::sort(found.begin(), found.end());
    ASSERT_EQ(found.size(), expected.size()) << "element " << e;
    for (std::size_t i = 0; i < found.size(); ++i) EXPECT_NEAR(found[i], expected[i], 1e-10 * tet) << "element " << e;
    split += expected.size() >= 2 ? 1 : 0;
  }
  EXPECT_GT(checked, lm.mesh.num_elements() * 9 / 10);
  EXPECT_EQ(parts.split_elements(), split);
  EXPECT_GT(split, 20);  // the notch's narrow part: about 0.6 × 0.8 / h² faces
}

// The parts tile each element's solid: their volumes sum to the exact
// masses' clipped volume, for every lattice case (the aligned cubes' faces
// lie on lattice planes: degenerate configurations, one part where the
// surface runs through an element's corners); a connected solid's elements
// hold at most a few split ones.
TEST(MaterialParts, PartsTileEachElementsSolid) {
  for (const test::Case& c : test::lattice_cases()) {
    SCOPED_TRACE(c.name);
    const LatticeMesh lm = build_lattice_mesh(c.surface, c.h);
    const MaterialParts parts = material_parts(lm, c.surface);
    const ElementSolid solid = clip_solid_to_elements(lm, c.surface);
    const double tet = lm.lattice.tet_volume();
    for (Index e = 0; e < parts.num_elements(); ++e) {
      double sum = 0.0;
      for (Index p = parts.first_part[at(e)]; p < parts.first_part[at(e) + 1]; ++p) sum += parts.part_volume[p];
      // Both are the same divergence-theorem sums from different apexes.
      ASSERT_NEAR(std::max(sum, 0.0), solid.volume[e], 1e-9 * tet) << "element " << e;
      // Corners inside the surface lie in a part; outside ones in none.
      for (int k = 0; k < 4; ++k)
        EXPECT_EQ(parts.corner_part[at(e)][static_cast<std::size_t>(k)] >= 0,
                  lm.node_inside[at(lm.mesh.tets(e, k))] != 0);
    }
    if (c.name == "sphere" || c.name == "thin_sheet") {
      EXPECT_EQ(parts.split_elements(), 0);
    }
    if (c.name == "aligned_cube" || c.name == "centre_aligned_cube") {
      EXPECT_GT(parts.degenerate_elements(), 0);
    }
  }
}

// A ball with a bubble inside one element (radius 0.02 about a point near
// the centroid (0.2, 0.1, 0.05) of a lattice tetrahedron whose inscribed
// sphere has radius 3V/A = h / (4√2) ≈ 0.035): the bubble's patch crosses
// no edge and encloses air (negative volume), so it belongs to the material
// around it, not a part of its own.
TEST(MaterialParts, ABubbleIsPartOfTheMaterialAroundIt) {
  const double h = 0.2;
  TriangleMesh bubble = moved(make_sphere(0.02, 8), Eigen::Matrix3d::Identity(), {0.2013, 0.1007, 0.0509});
  flip_orientation(bubble);
  const TriangleMesh surface = test::joined(make_sphere(1.0, 24), bubble);
  const LatticeMesh lm = build_lattice_mesh(surface, h);
  const MaterialParts parts = material_parts(lm, surface);
  EXPECT_EQ(parts.split_elements(), 0);
  const ElementSolid solid = clip_solid_to_elements(lm, surface);
  Index holed = 0;
  for (Index e = 0; e < parts.num_elements(); ++e) {
    if (parts.num_parts(e) != 1) continue;
    EXPECT_NEAR(parts.part_volume[parts.first_part[at(e)]], solid.volume[e], 1e-9 * lm.lattice.tet_volume());
    holed += solid.volume[e] < lm.lattice.tet_volume() * (1.0 - 1e-6) && parts.corner_part[at(e)][0] >= 0 &&
                     parts.corner_part[at(e)][1] >= 0 && parts.corner_part[at(e)][2] >= 0 &&
                     parts.corner_part[at(e)][3] >= 0
                 ? 1
                 : 0;
  }
  EXPECT_EQ(holed, 1);  // the element holding the bubble: all corners inside, some air
}

// A mesh that is not conforming (an element given twice: its faces are
// each in three elements) is refused with an error, not walked past.
TEST(MaterialParts, AFaceInThreeElementsIsAnError) {
  const double h = 0.2;
  const TriangleMesh surface = moved(make_sphere(0.5, 24), tilt(0.3), {0.013, -0.021, 0.007});
  LatticeMesh lm = build_lattice_mesh(surface, h);
  const Index ne = lm.mesh.num_elements();
  Index inner = 0;  // an element with a neighbour across every face
  const Tets neighbours = face_neighbours(lm.mesh.tets);
  while (inner < ne && (neighbours.row(inner).array() < 0).any()) ++inner;
  ASSERT_LT(inner, ne);
  lm.mesh.tets.conservativeResize(ne + 1, 4);
  lm.mesh.tets.row(ne) = lm.mesh.tets.row(inner);
  lm.tet_keys.push_back(lm.tet_keys[at(inner)]);
  try {
    (void)material_parts(lm, surface);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), ::testing::HasSubstr("shared by more than two elements"));
  }
}

// The same parts for any number of threads.
TEST(MaterialParts, SameOnOneAndTwoThreads) {
  const double h = 0.2;
  const Eigen::Matrix3d R = tilt(0.3);
  const TriangleMesh surface = test::joined(moved(make_sphere(0.5, 24), R, {0.013, -0.021, 0.007}),
                                            moved(make_sphere(0.5, 24), R, {1.0 + h / 3.0, -0.021, 0.007}));
  const LatticeMesh lm = build_lattice_mesh(surface, h);
  auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return material_parts(lm, surface);
  };
  const MaterialParts one = run(1), two = run(2);
  EXPECT_GT(one.split_elements(), 0);
  EXPECT_EQ(one.first_part, two.first_part);
  EXPECT_EQ(one.pair_triangle, two.pair_triangle);
  EXPECT_EQ(one.pair_part, two.pair_part);
  EXPECT_EQ(one.corner_part, two.corner_part);
  EXPECT_EQ(one.degenerate, two.degenerate);
  ASSERT_EQ(one.part_volume.size(), two.part_volume.size());
  for (Index p = 0; p < one.part_volume.size(); ++p) EXPECT_EQ(one.part_volume[p], two.part_volume[p]);
  ASSERT_EQ(one.part_centroid.rows(), two.part_centroid.rows());
  EXPECT_TRUE((one.part_centroid.array() == two.part_centroid.array()).all());
  // The copies: the face joins run in parallel, their union in face order.
  EXPECT_GT(one.duplicated_nodes(), 0);
  EXPECT_EQ(one.part_nodes, two.part_nodes);
  EXPECT_EQ(one.copy_node, two.copy_node);
}

}  // namespace
}  // namespace goo
