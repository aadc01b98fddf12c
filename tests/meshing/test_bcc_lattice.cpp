#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "meshing/bcc_lattice.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

const BccLattice kLattice(Eigen::Vector3d(-0.3, 0.1, 2.0), 0.25, Eigen::Vector3i(4, 3, 5));

std::vector<BccLattice::Key> all_tets(const BccLattice& lattice) {
  std::vector<BccLattice::Key> out;
  for (BccLattice::Key t = 0; t < lattice.num_tet_keys(); ++t)
    if (lattice.valid(t)) out.push_back(t);
  return out;
}

TEST(BccLattice, TetrahedraAreCongruentPositiveAndMatchTheirDmInverse) {
  const double h = kLattice.spacing();
  // Edges: the centre pair (h), the face edge (h), four centre–corner (h√3/2).
  std::vector<double> expected = {
      h * std::sqrt(3.0) / 2, h * std::sqrt(3.0) / 2, h * std::sqrt(3.0) / 2, h * std::sqrt(3.0) / 2, h, h};
  for (const auto t : all_tets(kLattice)) {
    const auto nodes = kLattice.tet_nodes(t);
    std::array<Eigen::Vector3d, 4> x;
    for (int k = 0; k < 4; ++k) x[static_cast<std::size_t>(k)] = kLattice.position(nodes[static_cast<std::size_t>(k)]);
    std::vector<double> edges;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        edges.push_back((x[static_cast<std::size_t>(i)] - x[static_cast<std::size_t>(j)]).norm());
    std::sort(edges.begin(), edges.end());
    for (std::size_t k = 0; k < 6; ++k) EXPECT_NEAR(edges[k], expected[k], 1e-14) << "tet " << t;
    Eigen::Matrix3d D;
    for (int k = 0; k < 3; ++k) D.col(k) = x[static_cast<std::size_t>(k) + 1] - x[0];
    EXPECT_NEAR(D.determinant() / 6.0, kLattice.tet_volume(), 1e-15) << "tet " << t;
    EXPECT_TRUE(test::matrices_near(kLattice.Dm_inv(t) * D, Eigen::Matrix3d::Identity(), 1e-13));
  }
}

TEST(BccLattice, ATetrahedronsCornersAreItsEdgeOfTheFaceBetweenItsCentres) {
  Index checked = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int k = 0; k < kLattice.cells().z(); ++k)
      for (int j = 0; j < kLattice.cells().y(); ++j)
        for (int i = 0; i < kLattice.cells().x(); ++i) {
          const Eigen::Vector3i cell(i, j, k);
          if (cell[axis] + 1 >= kLattice.cells()[axis]) continue;
          const auto face = kLattice.face_corners(cell, axis);
          // Four distinct corners, each a lattice spacing from the next.
          for (std::size_t q = 0; q < 4; ++q)
            ASSERT_NEAR((kLattice.position(face[q]) - kLattice.position(face[(q + 1) % 4])).norm(), kLattice.spacing(),
                        1e-12);
          for (int edge = 0; edge < 4; ++edge) {
            const auto nodes = kLattice.tet_nodes(cell, axis, edge);
            const std::array<BccLattice::Key, 2> expected = {face[static_cast<std::size_t>(edge)],
                                                             face[static_cast<std::size_t>((edge + 1) % 4)]};
            EXPECT_TRUE((nodes[2] == expected[0] && nodes[3] == expected[1]) ||
                        (nodes[2] == expected[1] && nodes[3] == expected[0]))
                << "cell " << cell.transpose() << " axis " << axis << " edge " << edge;
            ++checked;
          }
        }
  EXPECT_EQ(checked, static_cast<Index>(all_tets(kLattice).size()));
}

TEST(BccLattice, FacesAreSharedByAtMostTwoTetrahedraWithOppositeOrientation) {
  // Conforming: a triangle is a face of one tetrahedron (block boundary) or
  // of two, which see it with opposite outward orientations.
  // Outward faces of a positive tetrahedron (0, 1, 2, 3).
  constexpr int kOutward[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<BccLattice::Key, 3>, std::vector<int>> faces;  // sorted face → parities
  for (const auto t : all_tets(kLattice)) {
    const auto n = kLattice.tet_nodes(t);
    for (const auto& face : kOutward) {
      std::array<BccLattice::Key, 3> f = {n[static_cast<std::size_t>(face[0])], n[static_cast<std::size_t>(face[1])],
                                          n[static_cast<std::size_t>(face[2])]};
      // Parity of the permutation that sorts f (bubble sort swaps).
      int parity = 0;
      for (int pass = 0; pass < 2; ++pass)
        for (std::size_t i = 0; i + 1 < 3; ++i)
          if (f[i] > f[i + 1]) {
            std::swap(f[i], f[i + 1]);
            parity ^= 1;
          }
      faces[f].push_back(parity);
    }
  }
  std::size_t shared = 0;
  for (const auto& [face, parities] : faces) {
    ASSERT_LE(parities.size(), 2U);
    if (parities.size() == 2) {
      ++shared;
      EXPECT_NE(parities[0], parities[1]) << "a shared face seen with the same orientation: overlap";
    }
  }
  EXPECT_GT(shared, faces.size() / 2);
  // Volume: the tetrahedra of the block tile exactly the region between the
  // outermost centres: (n − 1) cells along each centre-pair axis.
  EXPECT_EQ(static_cast<std::size_t>(all_tets(kLattice).size()),
            static_cast<std::size_t>(4 * (3 * 3 * 5 + 4 * 2 * 5 + 4 * 3 * 4)));
}

TEST(BccLattice, LocateFindsTheOnlyTetrahedronContainingARandomPoint) {
  std::mt19937 rng(11);
  const Eigen::Vector3d lo = kLattice.origin() + Eigen::Vector3d::Constant(0.5 * kLattice.spacing());
  const Eigen::Vector3d hi =
      kLattice.origin() + kLattice.spacing() * (kLattice.cells().cast<double>().array() - 0.5).matrix();
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto tets = all_tets(kLattice);
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d p = lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
    const auto found = kLattice.locate(p);
    ASSERT_TRUE(found.has_value());
    EXPECT_EQ(kLattice.locate_units((p - kLattice.origin()) / kLattice.spacing()), found);
    const Eigen::Vector4d b = kLattice.barycentric(*found, p);
    EXPECT_GE(b.minCoeff(), -1e-12) << "p is not in the located tetrahedron";
    EXPECT_NEAR(b.sum(), 1.0, 1e-14);
    // Brute force: exactly one tetrahedron holds p strictly inside.
    int holders = 0;
    for (const auto t : tets) holders += kLattice.barycentric(t, p).minCoeff() > 1e-9 ? 1 : 0;
    EXPECT_EQ(holders, 1) << "the tetrahedra must tile space without gaps or overlaps";
    // The barycentric coordinates reproduce p.
    const auto nodes = kLattice.tet_nodes(*found);
    Eigen::Vector3d back = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) back += b[k] * kLattice.position(nodes[static_cast<std::size_t>(k)]);
    EXPECT_TRUE(test::matrices_near(back, p, 1e-14 * (1.0 + p.norm())));
  }
}

TEST(BccLattice, LocateOnLatticeNodesAndFacesStillContainsThePoint) {
  // Points on corners, centres, and face centres: ties pick a tetrahedron
  // that contains the point (all b ≥ −ε).
  for (BccLattice::Key node = 0; node < kLattice.num_nodes(); ++node) {
    const Eigen::Vector3d p = kLattice.position(node);
    const auto found = kLattice.locate(p);
    if (!found) continue;  // outside the tiled region
    EXPECT_GE(kLattice.barycentric(*found, p).minCoeff(), -1e-14) << "node " << node;
  }
}

// Checks for_each_tet_shape_near(lo, hi) against every valid tetrahedron:
// each one whose bounding box meets the closed box [lo, hi] (touching
// counts) is visited, nothing is visited twice, and every visited key is a
// valid tetrahedron of the block with the cell, axis and edge it was keyed by.
void expect_near_tets_found(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const std::string& what) {
  std::vector<BccLattice::Key> visited;
  kLattice.for_each_tet_shape_near(lo, hi, [&](BccLattice::Key key, const Eigen::Vector3i& cell, int axis, int edge) {
    EXPECT_TRUE(kLattice.valid(key)) << what << ": key " << key;
    EXPECT_EQ(key, kLattice.tet_key(cell, axis, edge)) << what;
    visited.push_back(key);
  });
  std::sort(visited.begin(), visited.end());
  EXPECT_EQ(std::adjacent_find(visited.begin(), visited.end()), visited.end()) << what << ": a tetrahedron twice";
  static const std::vector<BccLattice::Key> tets = all_tets(kLattice);
  for (const BccLattice::Key t : tets) {
    Eigen::Vector3d tet_lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d tet_hi = -tet_lo;
    for (const BccLattice::Key node : kLattice.tet_nodes(t)) {
      tet_lo = tet_lo.cwiseMin(kLattice.position(node));
      tet_hi = tet_hi.cwiseMax(kLattice.position(node));
    }
    if ((tet_lo.array() <= hi.array()).all() && (tet_hi.array() >= lo.array()).all()) {
      EXPECT_TRUE(std::binary_search(visited.begin(), visited.end(), t)) << what << ": tetrahedron " << t << " missed";
    }
  }
}

TEST(BccLattice, TheTetrahedraNearABoxAreAllThatTouchItInsideAndPastTheBlock) {
  // Boxes across the block's faces and wholly outside it are what the
  // clamps of cells_near and for_each_tet_shape_near serve: the surface's
  // own lattice keeps empty cells around it, so no mesh test reaches them.
  const Eigen::Vector3d size = kLattice.spacing() * kLattice.cells().cast<double>();
  std::mt19937 rng(20261207);
  std::uniform_real_distribution<double> u(-0.5, 1.5);  // in units of the block's size
  for (int trial = 0; trial < 300; ++trial) {
    Eigen::Vector3d a, b;
    for (int k = 0; k < 3; ++k) {
      a[k] = kLattice.origin()[k] + u(rng) * size[k];
      b[k] = kLattice.origin()[k] + u(rng) * size[k];
    }
    expect_near_tets_found(a.cwiseMin(b), a.cwiseMax(b), "random box " + std::to_string(trial));
  }
  // A box that is one point, at every node: on the block's faces and
  // corners too, it touches the last cells only at their boundary.
  for (BccLattice::Key node = 0; node < kLattice.num_nodes(); ++node) {
    const Eigen::Vector3d p = kLattice.position(node);
    expect_near_tets_found(p, p, "node " + std::to_string(node));
  }
  // A slab past each face, touching it.
  const Eigen::Vector3d block_lo = kLattice.origin(), block_hi = kLattice.origin() + size;
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Vector3d lo = block_lo - size, hi = block_hi + size;
    hi[axis] = block_lo[axis];
    expect_near_tets_found(lo, hi, "slab below axis " + std::to_string(axis));
    lo = block_lo - size, hi = block_hi + size;
    lo[axis] = block_hi[axis];
    expect_near_tets_found(lo, hi, "slab above axis " + std::to_string(axis));
  }
}

TEST(BccLattice, PointsAndBoxesFarBeyondIntsRangeOfCellsAreOutsideOrClampedToTheBlock) {
  // A coordinate of 10³⁰⁰ m is 10³⁰² cells out: its cell is clamped before
  // the conversion to int (undefined beyond int's range; on x86 it gave
  // INT_MIN, so a box reaching that far above the block found nothing).
  const double far = 1e300;
  const std::vector<Eigen::Vector3d> points = {Eigen::Vector3d(far, 0, 0), Eigen::Vector3d(0, -far, 0),
                                               Eigen::Vector3d(0, 0, 3e9), Eigen::Vector3d(-3e9, -3e9, -3e9),
                                               Eigen::Vector3d(far, -far, far)};
  for (const Eigen::Vector3d& p : points) {
    EXPECT_FALSE(kLattice.locate(p).has_value()) << p.transpose();
    const Eigen::Vector3i cell = kLattice.cell_of(p);
    for (int k = 0; k < 3; ++k) {
      if (std::abs(p[k]) > 1e6) {
        EXPECT_EQ(cell[k], p[k] > 0 ? 1 << 30 : -(1 << 30)) << p.transpose();
      }
    }
  }
  const Eigen::Vector3d inf = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  EXPECT_EQ(kLattice.cell_of(inf), Eigen::Vector3i::Constant(1 << 30));
  EXPECT_EQ(kLattice.cell_of(-inf), Eigen::Vector3i::Constant(-(1 << 30)));
  EXPECT_EQ(kLattice.cell_of(Eigen::Vector3d::Constant(std::nan(""))), Eigen::Vector3i::Constant(-(1 << 30)));
  // Boxes from far below to far above, and from inside to far above: every
  // tetrahedron they touch is found, each once.
  const Eigen::Vector3d centre = kLattice.origin() + 0.5 * kLattice.spacing() * kLattice.cells().cast<double>();
  expect_near_tets_found(Eigen::Vector3d::Constant(-far), Eigen::Vector3d::Constant(far), "everything");
  expect_near_tets_found(-inf, inf, "infinite");
  expect_near_tets_found(centre, Eigen::Vector3d::Constant(far), "centre to far above");
  expect_near_tets_found(Eigen::Vector3d::Constant(-far), centre, "far below to centre");
  expect_near_tets_found(Eigen::Vector3d(-far, centre.y(), -far), Eigen::Vector3d(far, centre.y(), far), "a plane");
}

TEST(BccLattice, NodesInBoxesFarBeyondIntsRangeAreTheBlocksOrNone) {
  // The nodes for_each_node_in visits, against every node's position
  // tested against the box: boxes reaching 10³⁰⁰ m out or infinite visit the
  // block's nodes they hold (their bounds clamped before the conversion to
  // int, undefined beyond its range), boxes wholly outside or with a NaN
  // bound none.
  auto visited = [](const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    std::vector<BccLattice::Key> out;
    kLattice.for_each_node_in(lo, hi, [&](BccLattice::Key n) { out.push_back(n); });
    std::sort(out.begin(), out.end());
    return out;
  };
  auto held = [](const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
    std::vector<BccLattice::Key> out;
    for (BccLattice::Key n = 0; n < kLattice.num_nodes(); ++n) {
      const Eigen::Vector3d p = kLattice.position(n);
      if ((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all()) out.push_back(n);
    }
    return out;
  };
  const double far = 1e300, inf = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d centre = kLattice.origin() + 0.5 * kLattice.spacing() * kLattice.cells().cast<double>();
  const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> boxes = {
      {Eigen::Vector3d::Constant(-far), Eigen::Vector3d::Constant(far)},
      {Eigen::Vector3d::Constant(-inf), Eigen::Vector3d::Constant(inf)},
      {centre, Eigen::Vector3d::Constant(far)},
      {Eigen::Vector3d(-far, centre.y(), -3e9), Eigen::Vector3d(3e9, centre.y() + 0.3, far)},
      {Eigen::Vector3d::Constant(far), Eigen::Vector3d::Constant(inf)},
      {Eigen::Vector3d::Constant(-inf), Eigen::Vector3d::Constant(-far)}};
  for (const auto& [lo, hi] : boxes)
    EXPECT_EQ(visited(lo, hi), held(lo, hi)) << lo.transpose() << " to " << hi.transpose();
  EXPECT_GT(held(boxes[0].first, boxes[0].second).size(), 0U);
  const Eigen::Vector3d nan = Eigen::Vector3d::Constant(std::nan(""));
  EXPECT_TRUE(visited(nan, nan).empty());
  EXPECT_TRUE(visited(centre, nan).empty());
  EXPECT_TRUE(visited(nan, centre).empty());
}

TEST(BccLattice, OutsideTheBlockThereIsNoTetrahedron) {
  EXPECT_FALSE(kLattice.locate(kLattice.origin() - Eigen::Vector3d::Constant(0.01)).has_value());
  EXPECT_FALSE(kLattice.locate(Eigen::Vector3d(std::nan(""), 0, 0)).has_value());
  EXPECT_THROW(BccLattice(Eigen::Vector3d::Zero(), -1.0, Eigen::Vector3i::Ones()), Error);
}

// A block larger than the clamp of lattice coordinates (±2³⁰ cells) is
// refused with an error that names the cells; the largest allowed is built.
TEST(BccLattice, ABlockPastTheClampIsRefused) {
  const int most = BccLattice::kMaxCellsPerAxis;
  EXPECT_NO_THROW(BccLattice(Eigen::Vector3d::Zero(), 1.0, Eigen::Vector3i(most, 1, 1)));
  for (const Eigen::Vector3i& cells : {Eigen::Vector3i(most + 1, 1, 1), Eigen::Vector3i(1, 1, most + 1),
                                       Eigen::Vector3i(1, std::numeric_limits<int>::max(), 1)}) {
    try {
      const BccLattice lattice(Eigen::Vector3d::Zero(), 1.0, cells);
      ADD_FAILURE() << "no error for " << cells.transpose();
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("at most 1073741824 cells per axis"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace goo
