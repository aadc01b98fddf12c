// CGAL as a test-only oracle: per-element clipped volumes against
// Polygon_mesh_processing::clip of the surface by each element, in exact
// arithmetic (Epeck), on a small mesh.
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/clip.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/primitives.h"
#include "meshing/exact_mass.h"
#include "meshing/exact_predicates.h"

namespace goo {
namespace {

using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

Mesh to_cgal(const Points& vertices, const Triangles& triangles) {
  Mesh mesh;
  std::vector<Mesh::Vertex_index> v;
  for (Eigen::Index i = 0; i < vertices.rows(); ++i)
    v.push_back(mesh.add_vertex(Kernel::Point_3(vertices(i, 0), vertices(i, 1), vertices(i, 2))));
  for (Eigen::Index t = 0; t < triangles.rows(); ++t)
    mesh.add_face(v[static_cast<std::size_t>(triangles(t, 0))], v[static_cast<std::size_t>(triangles(t, 1))],
                  v[static_cast<std::size_t>(triangles(t, 2))]);
  return mesh;
}

// orient_xy's floating-point filter never returns a wrong sign: points made
// nearly collinear in floating point (c = a + t (b − a), rounded, sometimes
// moved by an ulp), at magnitudes from 1e-6 to 1e6, against the sign of the
// determinant in exact rational arithmetic. Plain rounding gets many of
// them wrong, both ways.
TEST(ExactPredicatesOracle, OrientXyAgreesWithExactArithmetic) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), exponent(-6.0, 6.0), along(-2.0, 3.0);
  int flipped = 0, zeroed = 0, zero = 0;
  for (int trial = 0; trial < 100000; ++trial) {
    const double scale = std::pow(10.0, exponent(rng));
    const Eigen::Vector3d a(scale * unit(rng), scale * unit(rng), 0.0), b(scale * unit(rng), scale * unit(rng), 0.0);
    const double t = trial % 5 == 0 ? 0.5 : along(rng);
    Eigen::Vector3d c = a + t * (b - a);
    if (trial % 2 == 1) c.x() = std::nextafter(c.x(), trial % 4 == 1 ? 1e300 : -1e300);
    const Kernel::FT det = (Kernel::FT(b.x()) - a.x()) * (Kernel::FT(c.y()) - a.y()) -
                           (Kernel::FT(b.y()) - a.y()) * (Kernel::FT(c.x()) - a.x());
    const int expected = static_cast<int>(CGAL::sign(det));
    ASSERT_EQ(exact::orient_xy(a, b, c), expected) << "trial " << trial;
    zero += expected == 0;
    const double rounded = (a.x() - c.x()) * (b.y() - c.y()) - (a.y() - c.y()) * (b.x() - c.x());
    const int rounded_sign = rounded > 0.0 ? 1 : rounded < 0.0 ? -1 : 0;
    if (rounded_sign != expected) ++(rounded_sign == 0 ? zeroed : flipped);
  }
  EXPECT_GT(flipped, 100);
  EXPECT_GT(zero, 100);
}

TEST(ClipOracle, PerElementVolumesAgreeWithCgalClip) {
  // A coarse, generically placed sphere: every element it cuts is checked.
  TriangleMesh sphere = make_sphere(0.5, 10);
  sphere.vertices.rowwise() += Eigen::RowVector3d(0.0137, 0.0291, -0.0173);
  const LatticeMesh lm = build_lattice_mesh(sphere, 0.3);
  const ElementSolid solid = clip_solid_to_elements(lm, sphere);
  const Mesh surface = to_cgal(sphere.vertices, sphere.triangles);
  const double tet = lm.lattice.tet_volume();
  int cut = 0;
  for (Index e = 0; e < lm.mesh.num_elements(); ++e) {
    Points corners(4, 3);
    for (int k = 0; k < 4; ++k) corners.row(k) = lm.mesh.positions.row(lm.mesh.tets(e, k));
    Triangles faces(4, 3);
    faces << 1, 2, 3, 0, 3, 2, 0, 1, 3, 0, 2, 1;  // outward, for a positive tetrahedron
    Mesh clipper = to_cgal(corners, faces);
    Mesh clipped = surface;
    ASSERT_TRUE(PMP::clip(clipped, clipper, CGAL::parameters::clip_volume(true)));
    const double expected = clipped.is_empty() ? 0.0 : CGAL::to_double(PMP::volume(clipped));
    if (expected > 1e-6 * tet && expected < (1.0 - 1e-6) * tet) ++cut;
    EXPECT_NEAR(solid.volume[e], expected, 1e-12 * tet) << "element " << e;
  }
  EXPECT_GT(cut, 20);
}

}  // namespace
}  // namespace goo
