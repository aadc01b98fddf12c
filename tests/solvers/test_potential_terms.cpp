// The terms of the implicit potential (solvers/potential_terms.h), each
// through the interface backward Euler sums them by: its forces are minus
// the gradient of its value, and its Hessian parts, assembled as the
// integrator assembles them, are minus the derivative of its forces.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>

#include "core/primitives.h"
#include "solvers/potential_terms.h"
#include "solvers/remesh.h"
#include "tests/common/finite_differences.h"
#include "tests/solvers/tense_cube.h"

namespace goo {
namespace {

/// A 0.2 m cube meshed on the lattice, viscous, with surface tension, its
/// nodes moved up to 1 cm at random (deformed, no element inverted).
Body deformed_body() {
  Material m = test::tense_cube_material();
  m.youngs_modulus = 1e4;
  Body body = mesh_body(make_box({0.2, 0.2, 0.2}, 3), m, 0.1).body;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> offset(-0.01, 0.01);
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) body.positions(n, k) += offset(random);
  return body;
}

/// H = Σ_e blocks (by the element's nodes) + diagonal + Σ_t Wₜᵀ Hₜ Wₜ.
Eigen::MatrixXd dense_hessian(const Body& body, const HessianParts& parts) {
  const Index nn = body.num_nodes();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3 * nn, 3 * nn);
  for (std::size_t e = 0; e < parts.elements.size(); ++e)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        H.block<3, 3>(3 * body.tets(static_cast<Index>(e), a), 3 * body.tets(static_cast<Index>(e), b)) +=
            parts.elements[e].block<3, 3>(3 * a, 3 * b);
  H.diagonal() += parts.diagonal;
  if (!parts.triangles.empty()) {
    const SurfaceNodes surface = SurfaceNodes::of(body);
    for (Index t = 0; t < surface.num_triangles(); ++t)
      for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j)
          H.block<3, 3>(3 * surface.nodes(t, i), 3 * surface.nodes(t, j)) +=
              surface.weights(t, i) * surface.weights(t, j) *
              parts.triangles[at(t)].block<3, 3>(3 * (i / 4), 3 * (j / 4));
  }
  return H;
}

struct Case {
  std::string name;
  std::function<std::unique_ptr<PotentialTerm>(Body&)> make;
};

class EveryTerm : public ::testing::TestWithParam<Case> {};

TEST_P(EveryTerm, ForcesAreMinusTheGradientAndTheHessianTheirDerivative) {
  Body body = deformed_body();
  const std::unique_ptr<PotentialTerm> term = GetParam().make(body);
  const Points y = body.positions;
  auto forces = [&](const Points& at) {
    Points f = Points::Zero(body.num_nodes(), 3);
    term->add_forces(at, f);
    return f;
  };
  const Points f = forces(y);
  const Eigen::VectorXd gradient = -test::detail::flatten(f);
  std::vector<Matrix12> elements;
  Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(3 * body.num_nodes());
  std::vector<Matrix9d> triangles;
  HessianParts parts{elements, diagonal, triangles, false};
  if (GetParam().name == "damping") {  // it adds to the elastic blocks: start them at zero
    elements.assign(at(body.num_elements()), Matrix12::Zero());
  }
  term->add_hessian(y, parts);
  const Eigen::MatrixXd H = dense_hessian(body, parts);
  ASSERT_GT(gradient.cwiseAbs().maxCoeff(), 0.0);
  ASSERT_GT(H.cwiseAbs().maxCoeff(), 0.0) << "every term here has a Hessian but the load";

  // Elements ~0.1 m: a step δ = 1e-5 m leaves a truncation error
  // ~(δ/h)² = 1e-8 of the derivative's scale. Round-off: the value and
  // the forces are sums over elements and nodes, each good to ε of its
  // size; their differences lose ε Σ|terms| / δ, bounded here by
  // 2⁸ ε (|V| + |g| L) / δ with L = 0.2 m the body's size.
  const double delta = 1e-5, size = 0.2, eps = std::numeric_limits<double>::epsilon();
  auto value = [&](const Points& at) { return term->value(at); };
  const double g_scale = gradient.cwiseAbs().maxCoeff();
  const double g_round_off = 256.0 * eps * (std::abs(term->value(y)) + g_scale * size) / delta;
  const test::DerivativeCheck g = test::check_derivative(value, y, gradient, delta);
  EXPECT_TRUE(test::second_order(g, 1e-6 * g_scale + g_round_off, g_round_off)) << "gradient scale " << g_scale;
  auto minus_forces = [&](const Points& at) { return Points(-forces(at)); };
  const double h_scale = H.cwiseAbs().maxCoeff();
  const double h_round_off = 256.0 * eps * (g_scale + h_scale * size) / delta;
  const test::DerivativeCheck h = test::check_derivative(minus_forces, y, H, delta);
  EXPECT_TRUE(test::second_order(h, 1e-6 * h_scale + h_round_off, h_round_off)) << "Hessian scale " << h_scale;
}

INSTANTIATE_TEST_SUITE_P(
    PotentialTerms, EveryTerm,
    ::testing::Values(
        Case{"elasticity", [](Body& b) -> std::unique_ptr<PotentialTerm> {
               static ElasticForces forces;
               return std::make_unique<ElasticityTerm>(b, forces);
             }},
        Case{"tension", [](Body& b) -> std::unique_ptr<PotentialTerm> {
               static EmbeddedTension tension;
               return std::make_unique<TensionTerm>(b, tension);
             }},
        Case{"inertia",
             [](Body& b) -> std::unique_ptr<PotentialTerm> {
               Points target = b.rest_positions;
               target.col(2).array() -= 0.02;
               return std::make_unique<InertiaTerm>(b, target, 0.01);
             }},
        Case{"damping",
             [](Body& b) -> std::unique_ptr<PotentialTerm> {
               return std::make_unique<DampingTerm>(b, b.rest_positions, 0.01);
             }}),
    [](const auto& param_info) { return param_info.param.name; });

// The load has no Hessian; its forces are m g at every node, and its value
// the work's negative, exactly linear in y.
TEST(PotentialTerms, TheLoadIsTheWorkOfAConstantForce) {
  Body body = deformed_body();
  const Eigen::Vector3d g(0.3, -1.0, -9.81);
  LoadTerm load(body, g);
  Points f = Points::Zero(body.num_nodes(), 3);
  load.add_forces(body.positions, f);
  double work = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    EXPECT_EQ(f.row(n), (body.masses[n] * g).transpose());
    work += body.masses[n] * g.dot(body.positions.row(n).transpose());
  }
  EXPECT_EQ(load.value(body.positions), -work);
  Points moved = body.positions;
  moved.rowwise() += Eigen::RowVector3d(0.0, 0.0, 1.0);
  EXPECT_NEAR(load.value(moved) - load.value(body.positions), -body.masses.sum() * g.z(),
              1e-12 * body.masses.sum() * g.norm());
  std::vector<Matrix12> elements;
  Eigen::VectorXd diagonal = Eigen::VectorXd::Zero(3 * body.num_nodes());
  std::vector<Matrix9d> triangles;
  HessianParts parts{elements, diagonal, triangles, false};
  load.add_hessian(body.positions, parts);
  EXPECT_TRUE(elements.empty() && triangles.empty() && diagonal.isZero(0.0));
}

}  // namespace
}  // namespace goo
