// Surface tension as an energy in backward Euler: the triangle area
// Hessian, its assembly through the embedding, and the rounding of a cube
// at time steps far above the capillary bound.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "solvers/backward_euler.h"
#include "solvers/embedded_tension.h"
#include "solvers/newmark.h"
#include "solvers/remesh.h"
#include "solvers/sparse_hessian.h"
#include "tests/common/finite_differences.h"
#include "tests/solvers/tense_cube.h"

namespace goo {
namespace {

/// ∂A/∂(a, b, c): ½ n̂ × (c − b) and cyclically.
Eigen::Matrix<double, 9, 1> area_gradient(const Eigen::Matrix<double, 9, 1>& x) {
  const Eigen::Vector3d a = x.segment<3>(0), b = x.segment<3>(3), c = x.segment<3>(6);
  const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
  Eigen::Matrix<double, 9, 1> g;
  g << 0.5 * n.cross(c - b), 0.5 * n.cross(a - c), 0.5 * n.cross(b - a);
  return g;
}

// Central differences of the analytic gradient: error ≈ δ² |∂³A| / 6 +
// ε |∂A| / δ; with unit-sized, well-shaped triangles (|∂³A| ~ 1/|n| ≲ 10)
// and δ = 1e-5 that is below 1e-9, far under the entries (order 1).
TEST(ImplicitTension, TriangleAreaHessianMatchesFiniteDifferences) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    Eigen::Matrix<double, 9, 1> x;
    x << 0, 0, 0, 1, 0, 0, 0, 1, 0;
    for (int i = 0; i < 9; ++i) x[i] += 0.3 * u(rng);
    const Matrix9d H = triangle_area_hessian(x.segment<3>(0), x.segment<3>(3), x.segment<3>(6));
    const Eigen::MatrixXd fd = test::central_differences(area_gradient, x, 1e-5);
    EXPECT_LT((H - fd).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial;
    EXPECT_LT((H - H.transpose()).cwiseAbs().maxCoeff(), 1e-15);
    // Rigid translations do not change the area: H annihilates them.
    for (int k = 0; k < 3; ++k) {
      Eigen::Matrix<double, 9, 1> t = Eigen::Matrix<double, 9, 1>::Zero();
      t[k] = t[3 + k] = t[6 + k] = 1.0;
      EXPECT_LT((H * t).norm(), 1e-13);
    }
  }
  // A degenerate triangle has no Hessian (A is not differentiable there), not NaN.
  const Matrix9d flat = triangle_area_hessian(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                                              2.0 * Eigen::Vector3d::UnitX());
  EXPECT_TRUE(flat.isZero(0.0));
}

/// A small lattice body with its surface embedded and surface tension,
/// deformed at random so that every triangle's corners sit in different
/// elements and the Hessian couples nodes that share no element.
Body tense_body(double sigma) {
  Material m;
  m.youngs_modulus = 1e3;
  m.surface_tension = sigma;
  m.min_mass_fraction = 0.1;
  MeshedBody mb = mesh_body(make_sphere(0.1, 6), m, 0.06);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Index n = 0; n < mb.body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) mb.body.positions(n, k) += 0.01 * u(rng);
  return std::move(mb.body);
}

Eigen::VectorXd surface_gradient(EmbeddedTension& tension, const Body& body, const Points& x) {
  Points f = Points::Zero(body.num_nodes(), 3);
  tension.add_forces(body, x, SurfaceTensionForm::area_gradient, f);
  return -Eigen::Map<const Eigen::VectorXd>(f.data(), f.size());
}

Eigen::MatrixXd assembled_surface_hessian(const Body& body, bool project) {
  const SurfaceNodes nodes = SurfaceNodes::of(body);
  SparseHessian hessian;
  hessian.build(body.tets, body.num_nodes(), nodes.nodes);
  std::vector<Matrix9d> blocks;
  EmbeddedTension::triangle_hessians(body, body.positions, project, blocks);
  hessian.assemble(std::vector<Matrix12>(static_cast<std::size_t>(body.num_elements()), Matrix12::Zero()),
                   Eigen::VectorXd::Zero(3 * body.num_nodes()));
  hessian.add_surface(nodes, blocks);
  const Eigen::SparseMatrix<double> full = hessian.matrix().selfadjointView<Eigen::Lower>();
  return Eigen::MatrixXd(full);
}

// The nodes feel −Wᵀ σ∂A/∂x_s, the gradient of σ A(W x); the assembled
// Wᵀ σ∂²A W is its derivative. Corners embedded in different elements
// couple nodes of no common element, and a triangle whose corners share a
// parent repeats nodes: both go through the pattern and the slot lookup.
TEST(ImplicitTension, AssembledSurfaceHessianMatchesFiniteDifferences) {
  const double sigma = 0.5;
  Body body = tense_body(sigma);
  EmbeddedTension tension;
  ASSERT_TRUE(EmbeddedTension::active(body));
  const SurfaceNodes nodes = SurfaceNodes::of(body);
  int repeated = 0, unrelated = 0;  // triangles with repeated nodes; with corners in elements sharing no node
  for (Index t = 0; t < nodes.num_triangles(); ++t) {
    std::set<Index> all, first(nodes.nodes.row(t).data(), nodes.nodes.row(t).data() + 4);
    for (int a = 0; a < 12; ++a) all.insert(nodes.nodes(t, a));
    repeated += all.size() < 12;
    for (int k = 1; k < 3; ++k) {
      bool shares = false;
      for (int j = 0; j < 4; ++j) shares = shares || first.count(nodes.nodes(t, 4 * k + j)) > 0;
      unrelated += !shares;
    }
  }
  EXPECT_GT(repeated, 0);
  EXPECT_GT(unrelated, 0);

  const Eigen::VectorXd g = surface_gradient(tension, body, body.positions);
  const Eigen::MatrixXd H = assembled_surface_hessian(body, false);
  const double delta = 1e-6;  // positions ~0.1 m, triangles ~0.05 m
  const auto energy = [&](const Points& y) { return EmbeddedTension::energy(body, y); };
  const auto gradient = [&](const Points& y) { return surface_gradient(tension, body, y); };
  const double g_error = (test::central_differences(energy, body.positions, delta).transpose() - g).cwiseAbs().maxCoeff();
  const double h_error = (test::central_differences(gradient, body.positions, delta) - H).cwiseAbs().maxCoeff();
  // Scales: gradient entries ~ σ h = 0.03 N, Hessian entries ~ σ = 0.5 N/m;
  // the differences are good to δ² σ/h² ≈ 1e-10 plus round-off ε σ h²/δ ≈ 1e-13.
  EXPECT_LT(g_error, 1e-9 * sigma);
  EXPECT_LT(h_error, 1e-6 * sigma);
  EXPECT_GT(H.cwiseAbs().maxCoeff(), 0.01 * sigma);

  // Projected per triangle, the assembled surface Hessian is positive semi-definite.
  const Eigen::MatrixXd P = assembled_surface_hessian(body, true);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(P);
  EXPECT_GT(eig.eigenvalues().minCoeff(), -1e-12 * eig.eigenvalues().cwiseAbs().maxCoeff());
  // Unprojected, it is not (a curved surface has saddle directions of area).
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> raw(H);
  EXPECT_LT(raw.eigenvalues().minCoeff(), -1e-6 * raw.eigenvalues().cwiseAbs().maxCoeff());
}

using test::sphericity;

/// The cube of the explicit surface-tension flow test (soft, nearly
/// incompressible, damped; σ / (E L) = 0.25), stepped by backward Euler.
struct TenseCube {
  MeshedBody mb;
  BackwardEulerIntegrator integrator;
  TenseCube(double dt, double smoothing = 0.0)
      : mb(mesh_body(make_box({0.2, 0.2, 0.2}, 24), test::tense_cube_material(), 0.05)),
        integrator(settings(dt), {}, Eigen::Vector3d::Zero(),
                   SurfaceTensionSettings{SurfaceTensionForm::area_gradient, smoothing}) {}
  static BackwardEulerSettings settings(double dt) {
    BackwardEulerSettings s;
    s.time_step = dt;
    return s;
  }
  [[nodiscard]] double energy() const {
    const Body& b = mb.body;
    return kinetic_energy(b) + elastic_energy(b, b.positions) + EmbeddedTension::energy(b, b.positions);
  }
};

// Δt = 0.05 s is 30× the explicit step of this cube (1.7 ms, the nearly
// incompressible elastic bound): backward Euler rounds it as the explicit
// flow does (sphericity 0.806 → above 0.85 by 0.5 s, 99% of the volume
// kept), the surface energy falls every step, and the total energy
// (kinetic + elastic + surface) never rises: the step minimises the
// incremental potential, whose value at xⁿ bounds the new energy.
TEST(ImplicitTension, CubeRoundsAtLargeTimeSteps) {
  TenseCube cube(0.05);
  NewmarkSettings explicit_settings;
  explicit_settings.max_time_step = 1.0;
  NewmarkIntegrator probe(explicit_settings, {});
  const double explicit_dt = probe.stable_time_step(cube.mb.body);
  EXPECT_LT(25.0 * explicit_dt, 0.05);
  const double V0 = surface_integrals(cube.mb.surface()).volume;
  double previous = sphericity(cube.mb.surface());
  double energy = cube.energy();
  double surface = EmbeddedTension::energy(cube.mb.body, cube.mb.body.positions);
  for (int step = 1; step <= 10; ++step) {
    const StepReport status = cube.integrator.step(cube.mb.body, 1.0);
    EXPECT_EQ(status.halvings, 0) << "step " << step;
    ASSERT_TRUE(cube.mb.body.positions.allFinite());
    const double now = sphericity(cube.mb.surface());
    EXPECT_GT(now, previous) << "step " << step;
    previous = now;
    const double e = cube.energy(), s = EmbeddedTension::energy(cube.mb.body, cube.mb.body.positions);
    EXPECT_LE(e, energy * (1.0 + 1e-12)) << "step " << step;
    EXPECT_LT(s, surface) << "step " << step;
    energy = e;
    surface = s;
  }
  EXPECT_GT(previous, 0.85);
  EXPECT_GE(surface_integrals(cube.mb.surface()).volume / V0, 0.99);
}

// The triangles' Hessians are computed in parallel and added in triangle
// order: the same bits on 1 and 2 threads, smoothing included.
TEST(ImplicitTension, SameBitsForAnyThreadCount) {
  auto run = [](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    TenseCube cube(0.05, 0.2);
    for (int step = 0; step < 2; ++step) cube.integrator.step(cube.mb.body, 1.0);
    return std::pair(cube.mb.body.positions, cube.mb.body.embedding.bary);
  };
  EXPECT_TRUE(run(1) == run(2));
}

}  // namespace
}  // namespace goo
