#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "core/primitives.h"
#include "meshing/lattice_mesh.h"
#include "meshing/remesh_trigger.h"

namespace goo {
namespace {

Body lattice_body() {
  const LatticeMesh lm = build_lattice_mesh(make_sphere(0.5, 16), 0.2);
  return make_body(lm.mesh, Material{});
}

TEST(RemeshTrigger, RigidMotionAndUniformScaleNeverTrigger) {
  const Body body = lattice_body();
  const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> bary(0, 4);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, 1, 0.2).normalized()).toRotationMatrix();
  Points x = body.rest_positions;
  for (Index n = 0; n < body.num_nodes(); ++n) x.row(n) = (2.5 * R * x.row(n).transpose()).transpose();
  const RemeshCheck check = check_remesh(body, x, bary);
  EXPECT_FALSE(check.due);
  EXPECT_EQ(check.inverted, 0);
  // κ is invariant under rotation and scale: the growth is 1 to round-off.
  EXPECT_NEAR(check.worst_growth, 1.0, 1e-12);
}

TEST(RemeshTrigger, ConditionGrowthPastThreeTriggersAndNamesTheElement) {
  const Body body = lattice_body();
  const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> bary(0, 4);
  // Stretching x by s multiplies κ of a lattice tetrahedron by at most s;
  // 2.5 keeps every element below 3, 8 pushes some past it.
  for (const double s : {2.5, 8.0}) {
    Points x = body.rest_positions;
    x.col(0) *= s;
    const RemeshCheck check = check_remesh(body, x, bary);
    EXPECT_EQ(check.due, s > 3.0) << s;
    EXPECT_LE(check.worst_growth, s + 1e-9);
    if (check.due) {
      EXPECT_GE(check.element, 0);
    }
  }
  Points inverted = body.rest_positions;
  inverted.row(body.tets(0, 0)) = inverted.row(body.tets(0, 1)) * 2.0 - inverted.row(body.tets(0, 0));
  const RemeshCheck check = check_remesh(body, inverted, bary);
  EXPECT_TRUE(check.due);
  // The elements around the moved node that turned, by the triple product.
  Index turned = 0;
  for (Index e = 0; e < body.num_elements(); ++e) {
    const Eigen::Vector3d a = inverted.row(body.tets(e, 0));
    const Eigen::Vector3d b = inverted.row(body.tets(e, 1)), c = inverted.row(body.tets(e, 2)), d = inverted.row(body.tets(e, 3));
    if ((b - a).dot((c - a).cross(d - a)) <= 0.0) ++turned;
  }
  EXPECT_GE(turned, 1);
  EXPECT_EQ(check.inverted, turned);
}

TEST(RemeshTrigger, BarycentricBelowMinusPointTwoTriggers) {
  const Body body = lattice_body();
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> bary(2, 4);
  bary << 0.3, 0.3, 0.59, -0.19, 0.25, 0.25, 0.25, 0.25;
  EXPECT_FALSE(check_remesh(body, body.rest_positions, bary).due);
  bary(1, 2) = -0.21;
  const RemeshCheck check = check_remesh(body, body.rest_positions, bary);
  EXPECT_TRUE(check.due);
  EXPECT_EQ(check.vertex, 1);
}

}  // namespace
}  // namespace goo
