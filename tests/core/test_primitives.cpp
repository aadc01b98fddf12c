#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include "core/error.h"
#include "core/primitives.h"
#include "core/surface_check.h"

namespace goo {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kEps = std::numeric_limits<double>::epsilon();

void expect_valid_closed(const TriangleMesh& mesh, Index euler) {
  const SurfaceReport r = analyze_surface(mesh);
  EXPECT_FALSE(r.first_defect.has_value()) << *r.first_defect;
  EXPECT_TRUE(r.closed());
  EXPECT_TRUE(r.manifold());
  EXPECT_TRUE(r.consistently_oriented());
  EXPECT_GT(r.volume, 0.0) << "not outward oriented";
  EXPECT_EQ(r.components, 1);
  EXPECT_EQ(r.euler_characteristic(), euler);
}

TEST(Primitives, AreClosedOutwardManifoldsOfTheRightTopology) {
  for (const int n : {1, 2, 5}) expect_valid_closed(make_box({1.0, 2.0, 0.5}, n), 2);
  // Sizes whose grid does not land on the far face in floating point
  // (0.1·3/3 = 0.10000000000000002): the faces must still share their borders.
  for (const int n : {3, 6, 7, 12}) expect_valid_closed(make_box({0.1, 0.2, 0.3}, n), 2);
  for (const int n : {3, 4, 7, 32}) expect_valid_closed(make_sphere(0.3, n), 2);
  for (const int n : {3, 8, 33}) expect_valid_closed(make_cylinder(0.2, 1.5, n), 2);
  for (const int n : {3, 16}) expect_valid_closed(make_torus(1.0, 0.25, n, n + 1), 0);
}

TEST(Primitives, SplitIntoFourKeepsTheShapeAndTheTopology) {
  // Midpoint splits are flat: the same surface, with V' = V + E and
  // F' = 4 F (so χ is kept), closed and oriented as before; the torus
  // keeps χ = 0. Volume and area sum the same planes in smaller pieces:
  // equal up to the rounding of the finer sums.
  const TriangleMesh torus = make_torus(1.0, 0.25, 12, 7), sphere = make_sphere(0.3, 8);
  for (const TriangleMesh* mesh : {&torus, &sphere}) {
    const SurfaceReport before = analyze_surface(*mesh);
    TriangleMesh fine = *mesh;
    for (int times = 1; times <= 3; ++times) {
      SCOPED_TRACE(times);
      const TriangleMesh coarse = fine;
      const Index v = fine.num_vertices(), f = fine.num_triangles();
      const Index edges = 3 * f / 2;
      fine = split_into_four(fine);
      EXPECT_EQ(fine.num_triangles(), 4 * f);
      EXPECT_EQ(fine.num_vertices(), v + edges);
      expect_valid_closed(fine, mesh == &torus ? 0 : 2);
      const SurfaceReport r = analyze_surface(fine);
      EXPECT_NEAR(r.volume, before.volume, 1024 * kEps * std::abs(before.volume));
      EXPECT_NEAR(r.area, before.area, 1024 * kEps * before.area);
      // The old vertices stay; the middle child's corners are the midpoints
      // of its parent's edges 01, 12, 20.
      EXPECT_TRUE(fine.vertices.topRows(v) == coarse.vertices);
      std::size_t off_midpoint = 0;
      for (Index t = 0; t < f; ++t)
        for (int k = 0; k < 3; ++k) {
          const Eigen::RowVector3d m =
              0.5 * (coarse.vertices.row(coarse.triangles(t, k)) + coarse.vertices.row(coarse.triangles(t, (k + 1) % 3)));
          if (fine.vertices.row(fine.triangles(4 * t + 3, k)) != m) ++off_midpoint;
        }
      EXPECT_EQ(off_midpoint, 0u);
    }
    EXPECT_TRUE(split_into_four(*mesh, 3).vertices == fine.vertices);
    EXPECT_TRUE(split_into_four(*mesh, 3).triangles == fine.triangles);
  }
  // Each of a triangle's four children keeps its orientation: the normals
  // of a single triangle's children all point along its own.
  TriangleMesh one;
  one.vertices.resize(3, 3);
  one.vertices << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  one.triangles.resize(1, 3);
  one.triangles << 0, 1, 2;
  const TriangleMesh four = split_into_four(one);
  ASSERT_EQ(four.num_triangles(), 4);
  for (Index t = 0; t < 4; ++t) {
    const auto [a, b, c] = four.corners(t);
    EXPECT_DOUBLE_EQ((b - a).cross(c - a).z(), 0.25) << "child " << t;  // a quarter of the area, +z
  }
  EXPECT_THROW(split_into_four(one, -1), Error);
}

TEST(Primitives, BoxIsExactAtEveryResolution) {
  for (const int n : {1, 3, 8}) {
    const SurfaceReport r = analyze_surface(make_box({1.0, 2.0, 3.0}, n));
    // Exact up to the rounding of the few thousand compensated terms.
    EXPECT_NEAR(r.volume, 6.0, 64 * kEps * 6.0);
    EXPECT_NEAR(r.area, 22.0, 64 * kEps * 22.0);
    EXPECT_EQ(r.num_vertices, 6 * n * n + 2);  // V = E − F + 2 with quads split
  }
}

TEST(Primitives, CylinderIsTheExactPrismOverARegularPolygon) {
  for (const int n : {3, 10, 64}) {
    const double r = 0.7, h = 2.0;
    const SurfaceReport s = analyze_surface(make_cylinder(r, h, n));
    const double polygon = 0.5 * n * r * r * std::sin(2.0 * kPi / n);
    const double perimeter = 2.0 * n * r * std::sin(kPi / n);
    EXPECT_NEAR(s.volume, polygon * h, 1e-13 * polygon * h);
    EXPECT_NEAR(s.area, 2.0 * polygon + perimeter * h, 1e-13 * (2.0 * polygon + perimeter * h));
  }
}

/// Observed order of convergence of |measure(n) − exact| when n doubles.
double observed_order(const std::function<double(int)>& measure, double exact, int n) {
  const double coarse = std::abs(measure(n) - exact), fine = std::abs(measure(2 * n) - exact);
  return std::log2(coarse / fine);
}

// Inscribed polyhedra converge at second order: e(n) = c₂ n⁻² + c₄ n⁻⁴ + …,
// so the observed order log₂(e(n)/e(2n)) = 2 + O(n⁻²); at n = 64 the
// correction is ≈ (3/4)(c₄/c₂)/(n² ln 2) ≈ 10⁻³ for c₄/c₂ of order π², so
// 0.05 leaves a wide margin and still fails for first-order convergence.
constexpr double kOrderTolerance = 0.05;

TEST(Primitives, SphereAreaAndVolumeConvergeAtSecondOrder) {
  const double R = 1.3;
  auto volume = [&](int n) { return analyze_surface(make_sphere(R, n)).volume; };
  auto area = [&](int n) { return analyze_surface(make_sphere(R, n)).area; };
  for (const int n : {64, 128}) {
    EXPECT_NEAR(observed_order(volume, 4.0 / 3.0 * kPi * R * R * R, n), 2.0, kOrderTolerance) << n;
    EXPECT_NEAR(observed_order(area, 4.0 * kPi * R * R, n), 2.0, kOrderTolerance) << n;
  }
}

TEST(Primitives, CylinderAndTorusConvergeAtSecondOrder) {
  const double r = 0.4, h = 1.0, R = 1.0, a = 0.3;
  auto cyl_volume = [&](int n) { return analyze_surface(make_cylinder(r, h, n)).volume; };
  auto cyl_area = [&](int n) { return analyze_surface(make_cylinder(r, h, n)).area; };
  auto torus_volume = [&](int n) { return analyze_surface(make_torus(R, a, n, n)).volume; };
  auto torus_area = [&](int n) { return analyze_surface(make_torus(R, a, n, n)).area; };
  for (const int n : {64, 128}) {
    EXPECT_NEAR(observed_order(cyl_volume, kPi * r * r * h, n), 2.0, kOrderTolerance) << n;
    EXPECT_NEAR(observed_order(cyl_area, 2.0 * kPi * r * (r + h), n), 2.0, kOrderTolerance) << n;
    EXPECT_NEAR(observed_order(torus_volume, 2.0 * kPi * kPi * R * a * a, n), 2.0, kOrderTolerance) << n;
    EXPECT_NEAR(observed_order(torus_area, 4.0 * kPi * kPi * R * a, n), 2.0, kOrderTolerance) << n;
  }
}

TEST(Primitives, RefuseImpossibleParameters) {
  using ::testing::HasSubstr;
  EXPECT_THROW(make_box({1.0, -1.0, 1.0}, 2), Error);
  EXPECT_THROW(make_box({1.0, 1.0, 1.0}, 0), Error);
  EXPECT_THROW(make_sphere(0.0, 8), Error);
  EXPECT_THROW(make_sphere(1.0, 2), Error);
  EXPECT_THROW(make_cylinder(1.0, std::numeric_limits<double>::infinity(), 8), Error);
  try {
    make_torus(1.0, 1.5, 8, 8);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("minor < major"));
  }
}

}  // namespace
}  // namespace goo
