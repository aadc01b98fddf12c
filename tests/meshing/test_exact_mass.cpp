#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>

#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "io/surface_mesh_io.h"
#include "meshing/convex_clip.h"
#include "meshing/exact_mass.h"
#include "tests/meshing/lattice_cases.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using test::Case;

// With the clamp off, node masses carry the solid's exact mass and centre of
// mass: the clipped volumes tile the solid, and b_i at each piece's centroid
// keeps Σ m_i x_i = Σ m_e c_e. Round-off only: 1e-10 relative.
TEST(ExactMass, TotalMassAndCentreOfMassAreTheSolids) {
  const double rho = 1234.0;
  for (const Case& c : test::lattice_cases()) {
    SCOPED_TRACE(c.name);
    const LatticeMesh lm = build_lattice_mesh(c.surface, c.h);
    const ElementSolid solid = clip_solid_to_elements(lm, c.surface);
    const SurfaceIntegrals exact = surface_integrals(c.surface);
    // Each element holds between nothing and all of itself.
    const double tet = lm.lattice.tet_volume();
    EXPECT_GE(solid.volume.minCoeff(), 0.0);
    EXPECT_LE(solid.volume.maxCoeff(), tet * (1.0 + 1e-12));
    EXPECT_NEAR(solid.volume.sum(), exact.volume, 1e-10 * exact.volume);

    const Eigen::VectorXd m = exact_node_masses(lm, solid, rho, {}, 0.0);
    EXPECT_GE(m.minCoeff(), 0.0);
    EXPECT_NEAR(m.sum(), rho * exact.volume, 1e-10 * rho * exact.volume);
    const Eigen::Vector3d centre = (lm.mesh.positions.transpose() * m) / m.sum();
    const double size = bounding_box(c.surface.vertices).diagonal().norm();
    EXPECT_LT((centre - exact.centroid).norm(), 1e-10 * size);
  }
}

// The thin sheet has no inside node, so every gram comes from clipping.
TEST(ExactMass, ThinSheetHasNoInsideNodeButItsFullMass) {
  const Case sheet = test::lattice_cases()[3];
  const LatticeMesh lm = build_lattice_mesh(sheet.surface, sheet.h);
  EXPECT_EQ(std::count(lm.node_inside.begin(), lm.node_inside.end(), 1), 0);
  const ElementSolid solid = clip_solid_to_elements(lm, sheet.surface);
  EXPECT_NEAR(solid.volume.sum(), 1.0 * 0.8 * 0.002, 1e-10 * 0.0016);
}

// An element wholly inside holds its whole volume at its centroid; one wholly
// outside holds nothing.
TEST(ExactMass, WholeElementsAreFullOrEmpty) {
  const TriangleMesh sphere = make_sphere(1.0, 32);
  const LatticeMesh lm = build_lattice_mesh(sphere, 0.25);
  const ElementSolid solid = clip_solid_to_elements(lm, sphere);
  const double tet = lm.lattice.tet_volume();
  int full = 0;
  for (Index e = 0; e < lm.mesh.num_elements(); ++e) {
    double farthest = 0.0, nearest = 1e9;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d x = lm.mesh.positions.row(lm.mesh.tets(e, k));
      farthest = std::max(farthest, x.norm());
      nearest = std::min(nearest, x.norm());
      centroid += 0.25 * x;
    }
    // The polygonal sphere lies between radius cos(π/32)-ish and 1.
    if (farthest < 0.98) {
      ++full;
      EXPECT_NEAR(solid.volume[e], tet, 1e-13 * tet);
      EXPECT_LT((solid.centroid.row(e).transpose() - centroid).norm(), 1e-13);
    } else if (nearest > 1.0) {
      EXPECT_NEAR(solid.volume[e], 0.0, 1e-13 * tet);
    }
  }
  EXPECT_GT(full, 100);
}

TEST(ExactMass, ElasticVolumeChangeAndClampScaleMasses) {
  const TriangleMesh sphere = make_sphere(1.0, 24);
  const LatticeMesh lm = build_lattice_mesh(sphere, 0.2);
  const ElementSolid solid = clip_solid_to_elements(lm, sphere);
  const double rho = 1000.0;
  const Eigen::VectorXd plain = exact_node_masses(lm, solid, rho, {}, 0.0);
  // m = ρ V / det Fe: the material was stretched to V, so it weighs less.
  const std::vector<double> det(static_cast<std::size_t>(lm.mesh.num_elements()), 1.25);
  EXPECT_TRUE(test::matrices_near(exact_node_masses(lm, solid, rho, det, 0.0), plain / 1.25, 1e-15 * plain.maxCoeff()));
  // The clamp raises light nodes to the fraction of a full node's mass, ρ h³/2,
  // and leaves the others alone.
  const double full = rho * 0.2 * 0.2 * 0.2 / 2.0;
  EXPECT_NEAR(plain.maxCoeff(), full, 1e-12 * full);
  const Eigen::VectorXd clamped = exact_node_masses(lm, solid, rho, {}, 0.3);
  for (Index n = 0; n < lm.mesh.num_nodes(); ++n)
    EXPECT_DOUBLE_EQ(clamped[n], std::max(plain[n], 0.3 * full)) << "node " << n;
  EXPECT_LT(plain.minCoeff(), 0.3 * full);
}

TEST(ExactMass, SameBitsForAnyThreadCount) {
  const TriangleMesh sphere = make_sphere(1.0, 40);
  const LatticeMesh lm = build_lattice_mesh(sphere, 0.1);
  ElementSolid one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = clip_solid_to_elements(lm, sphere);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = clip_solid_to_elements(lm, sphere);
  }
  EXPECT_TRUE(one.volume == two.volume);
  EXPECT_TRUE(one.centroid == two.centroid);
}

// Per element, the solid of a box is the box ∩ element: the sum of the
// element's overlaps with the box's six Kuhn tetrahedra (an independent
// computation: polyhedron clipping, no surface, no inside flags). Boxes on
// lattice corner planes, on cell-centre planes, and in general position.
TEST(ExactMass, PerElementVolumesOfBoxesMatchPolyhedronClipping) {
  const double h = 0.25;
  for (const Eigen::Vector3d& lo : {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(0.125, 0.125, 0.125),
                                    Eigen::Vector3d(0.0131, -0.0277, 0.0419)}) {
    SCOPED_TRACE(lo.transpose());
    const Eigen::Vector3d size(1.0, 0.75, 1.25);
    TriangleMesh box = make_box(size, 4);
    box.vertices.rowwise() += (lo + 0.5 * size).transpose();
    const LatticeMesh lm = build_lattice_mesh(box, h);
    const ElementSolid solid = clip_solid_to_elements(lm, box);
    std::array<Eigen::Vector3d, 8> corner;
    for (std::size_t i = 0; i < 8; ++i)
      corner[i] = lo + Eigen::Vector3d((i & 1) ? size.x() : 0.0, (i & 2) ? size.y() : 0.0, (i & 4) ? size.z() : 0.0);
    const std::size_t paths[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
    for (Index e = 0; e < lm.mesh.num_elements(); ++e) {
      std::array<Eigen::Vector3d, 4> x;
      for (int k = 0; k < 4; ++k) x[static_cast<std::size_t>(k)] = lm.mesh.positions.row(lm.mesh.tets(e, k));
      double expected = 0.0;
      for (const auto& path : paths) {
        std::array<Eigen::Vector3d, 4> t = {corner[path[0]], corner[path[1]], corner[path[2]], corner[path[3]]};
        if ((t[1] - t[0]).dot((t[2] - t[0]).cross(t[3] - t[0])) < 0.0) std::swap(t[1], t[2]);
        expected += tet_overlap_volume(x, t, 1e-12 * h);
      }
      ASSERT_NEAR(solid.volume[e], expected, 1e-12 * lm.lattice.tet_volume()) << "element " << e;
    }
  }
}

// ---- the clipping kernels

std::array<Eigen::Vector3d, 4> regular_tet(double scale, const Eigen::Vector3d& shift) {
  return {shift, shift + scale * Eigen::Vector3d::UnitX(), shift + scale * Eigen::Vector3d::UnitY(),
          shift + scale * Eigen::Vector3d::UnitZ()};
}

TEST(ConvexClip, TetOverlapOfIdenticalTouchingAndNestedTets) {
  const auto a = regular_tet(1.0, Eigen::Vector3d::Zero());
  const double tol = 1e-12;
  EXPECT_NEAR(tet_overlap_volume(a, a, tol), 1.0 / 6.0, 1e-15);
  // Sharing a face from opposite sides: no volume.
  const std::array<Eigen::Vector3d, 4> mirror = {a[0], a[2], a[1], Eigen::Vector3d(0.0, 0.0, -1.0)};
  EXPECT_EQ(tet_overlap_volume(a, mirror, tol), 0.0);
  // Sharing a face from the same side.
  const std::array<Eigen::Vector3d, 4> flat = {a[0], a[1], a[2], Eigen::Vector3d(0.0, 0.0, 0.5)};
  EXPECT_NEAR(tet_overlap_volume(a, flat, tol), 0.5 / 6.0, 1e-15);
  EXPECT_NEAR(tet_overlap_volume(flat, a, tol), 0.5 / 6.0, 1e-15);
  // Half-size corner copy: nested.
  const auto small = regular_tet(0.5, Eigen::Vector3d::Zero());
  EXPECT_NEAR(tet_overlap_volume(a, small, tol), 1.0 / 48.0, 1e-15);
  EXPECT_NEAR(tet_overlap_volume(small, a, tol), 1.0 / 48.0, 1e-15);
  // Far apart.
  EXPECT_EQ(tet_overlap_volume(a, regular_tet(1.0, Eigen::Vector3d(3.0, 0.0, 0.0)), tol), 0.0);
}

// Overlaps of a tetrahedron with the six Kuhn tetrahedra of a cube that
// contains part of it add up to the part inside the cube: here, the corner
// tetrahedron x + y + z ≤ 1.5 cut by the unit cube [0, 1]³ loses three
// corners of volume 0.5³/6 each.
TEST(ConvexClip, TetOverlapsOverAPartitionAddUp) {
  const auto big = regular_tet(1.5, Eigen::Vector3d::Zero());
  const std::array<Eigen::Vector3d, 8> c = {
      Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 1, 0),
      Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(0, 1, 1), Eigen::Vector3d(1, 1, 1)};
  // Kuhn: 0 → 7 through every monotone path.
  const int paths[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7}, {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
  double total = 0.0;
  for (const auto& path : paths) {
    std::array<Eigen::Vector3d, 4> t = {c[static_cast<std::size_t>(path[0])], c[static_cast<std::size_t>(path[1])],
                                        c[static_cast<std::size_t>(path[2])], c[static_cast<std::size_t>(path[3])]};
    if ((t[1] - t[0]).dot((t[2] - t[0]).cross(t[3] - t[0])) < 0.0) std::swap(t[1], t[2]);
    total += tet_overlap_volume(t, big, 1e-12);
    EXPECT_NEAR(tet_overlap_volume(t, big, 1e-12), tet_overlap_volume(big, t, 1e-12), 1e-15);
  }
  EXPECT_NEAR(total, 1.5 * 1.5 * 1.5 / 6.0 - 3.0 * 0.125 / 6.0, 1e-14);
}

TEST(ConvexClip, PointTriangleDistanceByRegion) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_DOUBLE_EQ(point_triangle_distance({0.2, 0.2, 0.5}, a, b, c), 0.5);   // face
  EXPECT_DOUBLE_EQ(point_triangle_distance({-1.0, -1.0, 0.0}, a, b, c), std::sqrt(2.0));  // vertex a
  EXPECT_DOUBLE_EQ(point_triangle_distance({0.5, -2.0, 0.0}, a, b, c), 2.0);  // edge ab
  EXPECT_DOUBLE_EQ(point_triangle_distance({1.0, 1.0, 0.0}, a, b, c), std::sqrt(0.5));  // edge bc
  EXPECT_DOUBLE_EQ(point_triangle_distance({3.0, 0.0, 4.0}, a, b, c), std::sqrt(4.0 + 16.0));  // vertex b
}

}  // namespace
}  // namespace goo
