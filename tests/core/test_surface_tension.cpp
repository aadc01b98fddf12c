#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <numbers>
#include <random>

#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "core/surface_tension.h"
#include "io/surface_mesh_io.h"
#include "tests/common/finite_differences.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

constexpr SurfaceTensionForm kForms[] = {SurfaceTensionForm::area_gradient, SurfaceTensionForm::paper};

std::vector<std::pair<std::string, TriangleMesh>> closed_surfaces() {
  std::vector<std::pair<std::string, TriangleMesh>> out;
  out.emplace_back("torus", make_torus(1.0, 0.3, 24, 12));
  TriangleMesh bumpy = make_sphere(1.0, 20);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-0.05, 0.05);
  for (Index v = 0; v < bumpy.num_vertices(); ++v)
    for (int k = 0; k < 3; ++k) bumpy.vertices(v, k) += u(rng);
  out.emplace_back("random", bumpy);
  for (const char* file : {"bunny00.off", "armadillo.off"})
    if (std::filesystem::exists(test::asset(file))) out.emplace_back(file, io::read_surface_mesh(test::asset(file)));
  return out;
}

// Both forms: every force is a difference that cancels over a closed
// surface, so the net force is round-off.
TEST(SurfaceTension, NetForceOnAClosedSurfaceIsZero) {
  for (const auto& [name, surface] : closed_surfaces()) {
    const SurfaceTopology topology = SurfaceTopology::build(surface.triangles, surface.num_vertices());
    for (const SurfaceTensionForm form : kForms) {
      SCOPED_TRACE(name + (form == SurfaceTensionForm::paper ? " paper" : " area gradient"));
      Points f;
      surface_tension_forces(surface, topology, 0.07, form, f);
      const double scale = f.rowwise().norm().sum();
      ASSERT_GT(scale, 0.0);
      EXPECT_LT(f.colwise().sum().norm(), 1e-13 * scale);
    }
  }
}

TEST(SurfaceTension, AreaGradientIsMinusTheDerivativeOfSigmaTimesArea) {
  TriangleMesh surface = closed_surfaces()[1].second;
  const SurfaceTopology topology = SurfaceTopology::build(surface.triangles, surface.num_vertices());
  const double sigma = 0.07;
  Points f;
  surface_tension_forces(surface, topology, sigma, SurfaceTensionForm::area_gradient, f);
  std::vector<Index> coordinates;
  for (const Index v : {Index{0}, Index{7}, surface.num_vertices() / 2, surface.num_vertices() - 1})
    for (int k = 0; k < 3; ++k) coordinates.push_back(3 * v + k);
  const auto energy = [&](const Points& vertices) {
    TriangleMesh moved = surface;
    moved.vertices = vertices;
    return surface_energy(moved, sigma);
  };
  const Eigen::VectorXd gradient = -Eigen::Map<const Eigen::VectorXd>(f.data(), f.size());
  // Central differences: error O(step²) + round-off ε E / step ≈ 1e-11.
  EXPECT_LE(test::check_derivative(energy, surface.vertices, gradient, 1e-6, test::ErrorNorm::max_entry, coordinates).error,
            1e-8 * sigma);
}

// On a sphere of radius R both forms approach the mean-curvature force:
// 2σH = 2σ/R per unit area, inward. Error measured as the area-weighted
// mean of the per-vertex pressure's relative error, on refined spheres.
TEST(SurfaceTension, BothFormsConvergeToTheMeanCurvatureForceOnSpheres) {
  const double R = 0.8, sigma = 0.05;
  for (const SurfaceTensionForm form : kForms) {
    SCOPED_TRACE(form == SurfaceTensionForm::paper ? "paper" : "area gradient");
    std::vector<double> errors;
    for (const int segments : {12, 24, 48, 96}) {
      const TriangleMesh sphere = make_sphere(R, segments);
      const SurfaceTopology topology = SurfaceTopology::build(sphere.triangles, sphere.num_vertices());
      Points f;
      surface_tension_forces(sphere, topology, sigma, form, f);
      // Vertex areas: a third of each incident triangle.
      Eigen::VectorXd area = Eigen::VectorXd::Zero(sphere.num_vertices());
      for (Index t = 0; t < sphere.num_triangles(); ++t) {
        const auto [a, b, c] = sphere.corners(t);
        const double A = 0.5 * (b - a).cross(c - a).norm();
        for (int k = 0; k < 3; ++k) area[sphere.triangles(t, k)] += A / 3.0;
      }
      double weighted = 0.0;
      for (Index v = 0; v < sphere.num_vertices(); ++v) {
        const Eigen::Vector3d inward = -sphere.vertices.row(v).transpose().normalized();
        const double pressure = f.row(v).dot(inward) / area[v];
        weighted += area[v] * std::abs(pressure - 2.0 * sigma / R) / (2.0 * sigma / R);
      }
      errors.push_back(weighted / area.sum());
    }
    for (std::size_t i = 1; i < errors.size(); ++i) EXPECT_LT(errors[i], errors[i - 1]) << "level " << i;
    EXPECT_LT(errors.back(), 0.01);
  }
}

// The umbrella step moves a vertex towards the weighted mean of its
// neighbours: a vertex whose neighbours all lie in its face's plane stays in
// that plane (exactly: the weighted sum of in-plane offsets), a bump shrinks.
TEST(SurfaceTension, SmoothingKeepsPlanesAndShrinksABump) {
  TriangleMesh box = make_box({1.0, 1.0, 1.0}, 4);
  const SurfaceTopology box_topology = SurfaceTopology::build(box.triangles, box.num_vertices());
  const Points before_box = box.vertices;
  smooth_surface(box.vertices, box_topology, 0.5);
  int interior = 0;
  for (Index v = 0; v < box.num_vertices(); ++v) {
    // Inside the top face: |x|, |y| < 0.5 on z = 0.5.
    if (before_box(v, 2) != 0.5 || std::abs(before_box(v, 0)) >= 0.5 || std::abs(before_box(v, 1)) >= 0.5) continue;
    ++interior;
    EXPECT_EQ(box.vertices(v, 2), 0.5) << "vertex " << v;
  }
  EXPECT_EQ(interior, 9);

  TriangleMesh sphere = make_sphere(1.0, 16);
  const SurfaceTopology topology = SurfaceTopology::build(sphere.triangles, sphere.num_vertices());
  sphere.vertices.row(5) *= 1.3;
  const double before = sphere.vertices.row(5).norm();
  smooth_surface(sphere.vertices, topology, 0.5);
  EXPECT_LT(sphere.vertices.row(5).norm(), before - 0.05);
}

// Brackbill's capillary bound √(ρ h³ / (2π σ)), and no bound without tension.
TEST(SurfaceTension, CapillaryTimeStep) {
  EXPECT_DOUBLE_EQ(surface_tension_time_step(1000.0, 0.1, 0.07), std::sqrt(1000.0 * 1e-3 / (2.0 * std::numbers::pi * 0.07)));
  EXPECT_EQ(surface_tension_time_step(1000.0, 0.1, 0.0), std::numeric_limits<double>::infinity());
}

TEST(SurfaceTension, SameBitsForAnyThreadCount) {
  const TriangleMesh surface = make_sphere(1.0, 64);
  const SurfaceTopology topology = SurfaceTopology::build(surface.triangles, surface.num_vertices());
  auto run = [&](int threads, SurfaceTensionForm form) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Points f;
    surface_tension_forces(surface, topology, 0.07, form, f);
    return f;
  };
  for (const SurfaceTensionForm form : kForms) EXPECT_TRUE(run(1, form) == run(2, form));
}

}  // namespace
}  // namespace goo
