#include <gtest/gtest.h>

#include <random>

#include "core/error.h"
#include "core/obstacles.h"
#include "core/primitives.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Eigen::Vector3d random_point(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return {u(rng), u(rng), u(rng)};
}

/// The closest point x − d n is on the surface (distance 0 there), and the
/// normal is the distance's gradient (central differences, away from
/// creases).
void expect_consistent(const Shape& shape, const Eigen::Vector3d& x, double tol) {
  const SignedDistance sd = shape.signed_distance(x);
  EXPECT_NEAR(sd.normal.norm(), 1.0, 1e-12);
  EXPECT_NEAR(shape.signed_distance(x - sd.distance * sd.normal).distance, 0.0, tol) << x.transpose();
}

TEST(Obstacles, AnalyticShapesGiveExactDistances) {
  const auto sphere = make_sphere_shape(0.5);
  EXPECT_DOUBLE_EQ(sphere->signed_distance({0.0, 0.0, 2.0}).distance, 1.5);
  EXPECT_DOUBLE_EQ(sphere->signed_distance({0.0, 0.2, 0.0}).distance, -0.3);
  const auto box = make_box_shape({1.0, 2.0, 3.0});
  EXPECT_DOUBLE_EQ(box->signed_distance({0.0, 0.0, 4.0}).distance, 1.0);         // above a face
  EXPECT_DOUBLE_EQ(box->signed_distance({4.0, 6.0, 0.0}).distance, 5.0);         // beyond an edge: 3-4-5
  EXPECT_DOUBLE_EQ(box->signed_distance({0.5, 0.0, 0.0}).distance, -0.5);        // inside, nearest face x
  EXPECT_TRUE(box->signed_distance({0.5, 0.0, 0.0}).normal.isApprox(Eigen::Vector3d::UnitX()));
  const auto cylinder = make_cylinder_shape(1.0, 2.0);
  EXPECT_DOUBLE_EQ(cylinder->signed_distance({3.0, 0.0, 0.0}).distance, 2.0);    // side
  EXPECT_DOUBLE_EQ(cylinder->signed_distance({0.0, 0.0, -2.5}).distance, 0.5);   // cap
  EXPECT_DOUBLE_EQ(cylinder->signed_distance({4.0, 0.0, 6.0}).distance, 5.0);    // rim: 3-4-5
  EXPECT_NEAR(cylinder->signed_distance({0.0, 0.5, 1.9}).distance, -0.1, 1e-15);  // inside, nearest the cap
  const auto floor = make_half_space({0.0, 0.0, 2.0}, 0.25);
  EXPECT_DOUBLE_EQ(floor->signed_distance({7.0, -3.0, 1.0}).distance, 0.75);
  std::mt19937 rng(1);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d x = random_point(rng, 4.0);
    for (const Shape* s : {sphere.get(), box.get(), cylinder.get(), floor.get()}) expect_consistent(*s, x, 1e-12);
  }
}

// A box given as a triangle mesh is the box: the mesh obstacle's distances
// and normals equal the analytic ones.
TEST(Obstacles, MeshShapeMatchesTheAnalyticBox) {
  const Eigen::Vector3d half(0.5, 0.75, 0.25);
  const auto analytic = make_box_shape(half);
  const auto mesh = make_mesh_shape(make_box(2.0 * half, 3), "box.off");
  std::mt19937 rng(2);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d x = random_point(rng, 1.5);
    const SignedDistance a = analytic->signed_distance(x), m = mesh->signed_distance(x);
    ASSERT_NEAR(m.distance, a.distance, 1e-12) << x.transpose();
    // Normals agree where the closest feature is a face (not equidistant).
    if (std::abs(a.distance) > 1e-3) {
      const Eigen::Vector3d q = x.cwiseAbs() - half;
      std::array<double, 3> sorted = {q.x(), q.y(), q.z()};
      std::sort(sorted.begin(), sorted.end());
      if (a.distance > 0.0 || sorted[2] - sorted[1] > 1e-6) {
        EXPECT_LT((m.normal - a.normal).norm(), 1e-9) << x.transpose();
      }
    }
  }
  // On the surface: distance 0.
  EXPECT_EQ(mesh->signed_distance({0.5, 0.1, 0.05}).distance, 0.0);
  EXPECT_TRUE(mesh->bounds().isApprox(analytic->bounds()));
}

TEST(Obstacles, MeshShapeRefusesAnOpenMesh) {
  TriangleMesh open = make_box({1.0, 1.0, 1.0}, 1);
  open.triangles.conservativeResize(open.num_triangles() - 1, 3);
  EXPECT_TRUE(test::throws_error_containing([&] { (void)make_mesh_shape(open, "press.obj"); }, "press.obj"));
}

TEST(Obstacles, RigidMotionInterpolatesAndItsVelocityIsTheDerivative) {
  RigidMotion::Key a, b, c;
  a.time = 0.0;
  b.time = 1.0;
  b.translation = {1.0, 0.0, 0.5};
  b.rotation = Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ());
  c.time = 3.0;
  c.translation = {1.0, 2.0, 0.5};
  c.rotation = Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitX());
  const RigidMotion motion({a, b, c});
  EXPECT_FALSE(motion.is_static());
  EXPECT_TRUE(motion.transform(-1.0).isApprox(motion.transform(0.0)));
  EXPECT_TRUE(motion.transform(5.0).translation().isApprox(c.translation));
  EXPECT_TRUE(motion.transform(0.5).translation().isApprox(Eigen::Vector3d(0.5, 0.0, 0.25)));
  Obstacle obstacle{"press", make_sphere_shape(0.1), motion, 0.0};
  const Eigen::Vector3d p(0.3, -0.2, 0.7);  // a point of the obstacle's frame
  for (const double t : {0.25, 0.9, 1.5, 2.7}) {
    const double eps = 1e-6;
    const Eigen::Vector3d fd = (motion.transform(t + eps) * p - motion.transform(t - eps) * p) / (2.0 * eps);
    EXPECT_LT((obstacle.velocity(motion.transform(t) * p, t) - fd).norm(), 1e-8) << "t = " << t;
  }
  EXPECT_EQ(obstacle.velocity(p, 4.0), Eigen::Vector3d::Zero());
  // Queries happen in the moving frame.
  EXPECT_NEAR(obstacle.query(motion.transform(2.0) * Eigen::Vector3d(0.0, 0.0, 0.3), 2.0).distance, 0.2, 1e-12);
  EXPECT_THROW(RigidMotion({b, a}), Error);
}

}  // namespace
}  // namespace goo
