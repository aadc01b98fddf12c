#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <limits>

#include "core/primitives.h"
#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "tests/common/test_common.h"
#include "tests/core/mesh_fixtures.h"

namespace goo {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

TEST(SurfaceGeometry, TetrahedronHasAnalyticAreaVolumeAndCentroid) {
  const SurfaceIntegrals s = surface_integrals(test::unit_tetrahedron());
  EXPECT_NEAR(s.volume, 1.0 / 6.0, 8 * kEps);
  EXPECT_NEAR(s.area, 1.5 + std::sqrt(3.0) / 2.0, 8 * kEps);
  EXPECT_TRUE(test::matrices_near(s.centroid, Eigen::Vector3d::Constant(0.25), 8 * kEps));
  EXPECT_NEAR(enclosed_volume_by_z_flux(test::unit_tetrahedron()), 1.0 / 6.0, 8 * kEps);
}

TEST(SurfaceGeometry, ReversedOrientationNegatesVolumeOnly) {
  TriangleMesh mesh = test::octahedron();
  const SurfaceIntegrals before = surface_integrals(mesh);
  flip_orientation(mesh);
  const SurfaceIntegrals after = surface_integrals(mesh);
  EXPECT_NEAR(before.volume, 4.0 / 3.0, 8 * kEps);
  EXPECT_EQ(after.volume, -before.volume);
  EXPECT_EQ(after.area, before.area);
  EXPECT_TRUE(test::matrices_near(after.centroid, before.centroid, 8 * kEps));
}

TEST(SurfaceGeometry, InvariantUnderRigidMotionAndCovariantCentroid) {
  const TriangleMesh torus = make_torus(2.0, 0.5, 48, 24);
  const SurfaceIntegrals ref = surface_integrals(torus);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(10.0, -3.0, 7.5);
  TriangleMesh moved = torus;
  for (Index v = 0; v < moved.num_vertices(); ++v)
    moved.vertices.row(v) = (rotation * torus.vertices.row(v).transpose() + shift).transpose();
  const SurfaceIntegrals s = surface_integrals(moved);
  // Each rotated coordinate carries a rounding error of a few ε times its
  // size (≈ 12 here); volume and area are sums of such terms, compensated.
  EXPECT_NEAR(s.volume, ref.volume, 1e-12 * ref.volume);
  EXPECT_NEAR(s.area, ref.area, 1e-12 * ref.area);
  EXPECT_TRUE(test::matrices_near(s.centroid, rotation * ref.centroid + shift, 1e-12 * 12.0));
  EXPECT_NEAR(enclosed_volume_by_z_flux(moved), s.volume, 1e-12 * s.volume);
}

TEST(SurfaceGeometry, CentroidOfAnOffsetBoxIsItsCentre) {
  TriangleMesh box = make_box({1.0, 2.0, 3.0}, 3);
  box.vertices.rowwise() += Eigen::RowVector3d(0.5, -1.0, 2.0);
  const SurfaceIntegrals s = surface_integrals(box);
  EXPECT_NEAR(s.volume, 6.0, 32 * kEps * 6.0);
  EXPECT_TRUE(test::matrices_near(s.centroid, Eigen::Vector3d(0.5, -1.0, 2.0), 32 * kEps * 4.0));
}

TEST(CompensatedSum, RecoversTermsBelowTheRunningSumsPrecision) {
  CompensatedSum sum;
  sum.add(1.0);
  for (int i = 0; i < 1000; ++i) sum.add(1e-17);  // each alone vanishes next to 1.0
  sum.add(-1.0);
  EXPECT_NEAR(sum.value(), 1e-14, 1e-14 * 1e-10);
}

}  // namespace
}  // namespace goo
