#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>

#include "core/error.h"
#include "core/primitives.h"
#include "core/surface_check.h"
#include "tests/common/test_common.h"
#include "tests/core/mesh_fixtures.h"

namespace goo {
namespace {

using ::testing::HasSubstr;

TEST(SurfaceCheck, ValidClosedMeshHasNoDefect) {
  const SurfaceReport r = analyze_surface(test::octahedron());
  EXPECT_FALSE(r.first_defect.has_value()) << *r.first_defect;
  EXPECT_TRUE(r.closed());
  EXPECT_TRUE(r.manifold());
  EXPECT_TRUE(r.consistently_oriented());
  EXPECT_EQ(r.num_edges, 12);
  EXPECT_EQ(r.euler_characteristic(), 2);
  EXPECT_EQ(r.components, 1);
}

TEST(SurfaceCheck, OpenMeshNamesABoundaryEdge) {
  TriangleMesh mesh = test::octahedron();
  mesh.triangles.conservativeResize(7, 3);  // drop the last triangle (0, 3, 5)
  const SurfaceReport r = analyze_surface(mesh);
  ASSERT_TRUE(r.first_defect.has_value());
  EXPECT_THAT(*r.first_defect, HasSubstr("not closed"));
  EXPECT_THAT(*r.first_defect, HasSubstr("(0, 3)"));
  EXPECT_EQ(r.boundary_edges, 3);
  EXPECT_FALSE(r.closed());
}

TEST(SurfaceCheck, EdgeSharedByFourTrianglesIsNonManifold) {
  // Two tetrahedra that share only the edge (0, 1).
  const TriangleMesh mesh =
      test::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, -1, 0}, {0, 0, -1}},
                      {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 4, 1}, {0, 1, 5}, {0, 5, 4}, {1, 4, 5}});
  const SurfaceReport r = analyze_surface(mesh);
  ASSERT_TRUE(r.first_defect.has_value());
  EXPECT_THAT(*r.first_defect, HasSubstr("edge (0, 1) is shared by 4 triangles"));
  EXPECT_EQ(r.nonmanifold_edges, 1);
  EXPECT_EQ(r.boundary_edges, 0);
}

TEST(SurfaceCheck, TetrahedraTouchingAtAVertexAreEdgeManifoldButNotManifold) {
  const TriangleMesh mesh =
      test::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-1, 0, 0}, {0, -1, 0}, {0, 0, -1}},
                      {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 4, 5}, {0, 6, 4}, {0, 5, 6}, {4, 6, 5}});
  const SurfaceReport r = analyze_surface(mesh);
  EXPECT_FALSE(r.first_defect.has_value()) << *r.first_defect;
  EXPECT_TRUE(r.edge_manifold());
  EXPECT_FALSE(r.manifold());
  EXPECT_EQ(r.nonmanifold_vertices, 1);
  EXPECT_EQ(r.components, 2);
  EXPECT_NEAR(r.volume, 2.0 / 6.0, 1e-15);
}

TEST(SurfaceCheck, OneFlippedTriangleIsNamed) {
  for (Index flipped = 0; flipped < 8; ++flipped) {
    TriangleMesh mesh = test::octahedron();
    std::swap(mesh.triangles(flipped, 1), mesh.triangles(flipped, 2));
    const SurfaceReport r = analyze_surface(mesh);
    ASSERT_TRUE(r.first_defect.has_value());
    EXPECT_THAT(*r.first_defect, HasSubstr("triangle " + std::to_string(flipped) + " is flipped"));
    EXPECT_EQ(r.misoriented_triangles, 1);
    EXPECT_TRUE(r.orientable);
  }
}

TEST(SurfaceCheck, KleinBottleIsNotOrientable) {
  const SurfaceReport r = analyze_surface(test::klein_bottle(6, 5));
  ASSERT_TRUE(r.first_defect.has_value());
  EXPECT_THAT(*r.first_defect, HasSubstr("not orientable"));
  EXPECT_FALSE(r.orientable);
  EXPECT_TRUE(r.closed());
  EXPECT_TRUE(r.manifold());
  EXPECT_EQ(r.euler_characteristic(), 0);
}

TEST(SurfaceCheck, NonFiniteCoordinateIsNamed) {
  TriangleMesh mesh = test::unit_tetrahedron();
  mesh.vertices(2, 1) = std::numeric_limits<double>::quiet_NaN();
  const SurfaceReport r = analyze_surface(mesh);
  ASSERT_TRUE(r.first_defect.has_value());
  EXPECT_THAT(*r.first_defect, HasSubstr("vertex 2 has a non-finite coordinate"));
  EXPECT_FALSE(r.topology_valid);
}

TEST(SurfaceCheck, OutOfRangeIndexIsNamed) {
  TriangleMesh mesh = test::unit_tetrahedron();
  mesh.triangles(3, 2) = 9;
  const SurfaceReport r = analyze_surface(mesh);
  ASSERT_TRUE(r.first_defect.has_value());
  EXPECT_THAT(*r.first_defect, HasSubstr("triangle 3 references vertex 9, but the mesh has 4 vertices"));
  mesh.triangles(3, 2) = -1;
  EXPECT_THAT(*analyze_surface(mesh).first_defect, HasSubstr("references vertex -1"));
}

TEST(SurfaceCheck, DegenerateTrianglesAreNamed) {
  TriangleMesh repeated = test::unit_tetrahedron();
  repeated.triangles(1, 2) = repeated.triangles(1, 0);
  EXPECT_THAT(*analyze_surface(repeated).first_defect, HasSubstr("triangle 1 has a repeated vertex"));

  // Vertex 3 on the segment 0–1: the triangle (0, 1, 3) has zero area.
  TriangleMesh collinear = test::unit_tetrahedron();
  collinear.vertices.row(3) << 0.5, 0.0, 0.0;
  EXPECT_THAT(*analyze_surface(collinear).first_defect, HasSubstr("triangle 1 has zero area"));
}

TEST(SurfaceCheck, DoubleSidedTriangleEnclosesNoVolume) {
  const TriangleMesh mesh = test::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 1}});
  const SurfaceReport r = analyze_surface(mesh);
  ASSERT_TRUE(r.first_defect.has_value());
  EXPECT_THAT(*r.first_defect, HasSubstr("encloses no volume"));
}

TEST(SurfaceCheck, EmptyMeshHasNoTriangles) {
  EXPECT_THAT(*analyze_surface(TriangleMesh{}).first_defect, HasSubstr("no triangles"));
}

TEST(ValidateSurface, InsideOutMeshIsFlippedAndKeepsItsGeometry) {
  TriangleMesh mesh = test::octahedron();
  flip_orientation(mesh);
  ASSERT_LT(analyze_surface(mesh).volume, 0.0);
  const SurfaceReport r = validate_surface(mesh, "inside_out.off");
  EXPECT_NEAR(r.volume, 4.0 / 3.0, 1e-15);
  EXPECT_TRUE(mesh.triangles == test::octahedron().triangles);
  EXPECT_GT(analyze_surface(mesh).volume, 0.0);
}

TEST(ValidateSurface, ErrorNamesTheSource) {
  TriangleMesh mesh = test::octahedron();
  mesh.triangles.conservativeResize(7, 3);
  try {
    validate_surface(mesh, "scenes/cup.off");
    FAIL() << "an open mesh was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("scenes/cup.off: edge"));
  }
}

TEST(ValidateSurface, HollowShellWithOutwardOuterAndInwardInnerIsValid) {
  TriangleMesh outer = make_sphere(2.0, 24);
  TriangleMesh inner = make_sphere(1.0, 24);
  flip_orientation(inner);  // a cavity faces inward
  TriangleMesh shell = test::joined(outer, inner);
  const SurfaceReport r = validate_surface(shell, "shell");
  EXPECT_EQ(r.components, 2);
  EXPECT_NEAR(r.volume, analyze_surface(outer).volume + analyze_surface(inner).volume, 1e-12);
}

}  // namespace
}  // namespace goo
