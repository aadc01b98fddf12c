// The real models of the tests and benchmarks (scripts/fetch-assets).
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Surface_mesh.h>
#include <gtest/gtest.h>

#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "io/surface_mesh_io.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

/// The volume of the polyhedron exactly as stored (the doubles read from the
/// file), computed by CGAL with exact arithmetic: an oracle independent of
/// goo's code and free of rounding.
double exact_volume(const TriangleMesh& mesh) {
  using Kernel = CGAL::Exact_predicates_exact_constructions_kernel;
  CGAL::Surface_mesh<Kernel::Point_3> sm;
  std::vector<CGAL::Surface_mesh<Kernel::Point_3>::Vertex_index> ids;
  for (Index v = 0; v < mesh.num_vertices(); ++v)
    ids.push_back(sm.add_vertex(Kernel::Point_3(mesh.vertices(v, 0), mesh.vertices(v, 1), mesh.vertices(v, 2))));
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    sm.add_face(ids[static_cast<std::size_t>(mesh.triangles(t, 0))],
                ids[static_cast<std::size_t>(mesh.triangles(t, 1))],
                ids[static_cast<std::size_t>(mesh.triangles(t, 2))]);
  return CGAL::to_double(CGAL::Polygon_mesh_processing::volume(sm));
}

class RealModel : public ::testing::TestWithParam<const char*> {};

TEST_P(RealModel, LoadsAsAClosedManifoldWithAgreeingVolumes) {
  const std::filesystem::path path = test::asset(GetParam());
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " is missing: run scripts/fetch-assets";
  TriangleMesh mesh = io::read_surface_mesh(path);
  const SurfaceReport r = analyze_surface(mesh);
  EXPECT_FALSE(r.first_defect.has_value()) << *r.first_defect;
  EXPECT_TRUE(r.closed());
  EXPECT_TRUE(r.edge_manifold());
  EXPECT_TRUE(r.consistently_oriented());
  EXPECT_GT(r.volume, 0.0);

  // Three independent computations of one number. goo's two are compensated
  // sums of terms with a relative error of a few ε each; with cancellation
  // Σ|V_t|/V of order 10 for these shapes, they land within ~10⁻¹⁴ of the
  // exact value, so 10⁻¹² relative (the bound) holds with room.
  const double exact = exact_volume(mesh);
  EXPECT_NEAR(r.volume, exact, 1e-12 * exact);
  EXPECT_NEAR(enclosed_volume_by_z_flux(mesh), exact, 1e-12 * exact);
}

INSTANTIATE_TEST_SUITE_P(Assets, RealModel,
                         ::testing::Values("bunny00.off", "armadillo.off", "hand.off", "elephant.off"),
                         [](const auto& param_info) {
                           std::string name = param_info.param;
                           return name.substr(0, name.find('.'));
                         });

}  // namespace
}  // namespace goo
