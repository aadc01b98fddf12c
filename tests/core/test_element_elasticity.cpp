// One element's energy, forces, Hessian and damping matrix
// (core/element_elasticity.h): each the derivative of the one before, to
// second order in central differences, for every model, with plastic
// states and inverted elements; and what the solvers build from them.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "core/damping.h"
#include "core/elastic_forces.h"
#include "core/element_elasticity.h"
#include "core/surface_geometry.h"
#include "core/tet_mesh.h"
#include "tests/common/finite_differences.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using test::check_derivative;
using test::second_order;

using test::kModels;
using test::material;

/// One element (the unit corner tetrahedron), its corners moved at random
/// by up to `amount` (possibly inverted), with a random volume-preserving
/// plastic state.
Body random_element(const Material& m, std::mt19937& rng, double amount) {
  Body body = make_body(test::corner_tetrahedron(), m);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Index n = 0; n < 4; ++n)
    for (int k = 0; k < 3; ++k) body.positions(n, k) += amount * u(rng);
  Eigen::Matrix3d P = Eigen::Matrix3d::Identity();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) P(i, j) += 0.1 * u(rng);
  body.Fp[0] = P / std::cbrt(P.determinant());
  return body;
}

// The forces are minus the energy's gradient. Scales: unit corners, E =
// 1e5 Pa, forces ~ E W ~ 1e4 N; central differences with δ = 1e-5 are good
// to δ² |∂³Ψ| ~ 1e-5 N and round-off ε Ψ/δ ~ 1e-6 N, far under 1e-6 of the
// force scale only if the derivative is right; a wrong one is not second order.
TEST(ElementElasticity, ForcesAreMinusTheEnergyGradient) {
  std::mt19937 rng(6);
  for (const ElasticModel model : kModels)
    for (int trial = 0; trial < 10; ++trial) {
      const Body body = random_element(material(model, 1e5, 0.3), rng, trial < 5 ? 0.2 : 0.6);
      const IsotropicEnergy energy(body.material);
      const ElementRest rest = ElementRest::of(body, 0);
      const Matrix34 corners = element_corners(body, body.positions, 0);
      const Matrix34 forces = element_forces(energy, rest, corners);
      const auto value = [&](const Matrix34& c) { return element_energy(energy, rest, c); };
      const Eigen::Matrix<double, 12, 1> gradient = -Eigen::Map<const Eigen::Matrix<double, 12, 1>>(forces.data());
      const double scale = std::max(forces.norm(), body.material.mu() * rest.rest_volume);
      EXPECT_TRUE(second_order(check_derivative(value, corners, gradient, 1e-5), 1e-6 * scale, 1e-9 * scale))
          << "model " << static_cast<int>(model) << " trial " << trial;
    }
}

// The unprojected Hessian is minus the forces' Jacobian (central
// differences: error O(δ²) + ε f/δ).
TEST(ElementElasticity, HessianIsMinusTheForcesJacobian) {
  std::mt19937 rng(1);
  for (const ElasticModel model : kModels) {
    for (int trial = 0; trial < 5; ++trial) {
      const Body body = random_element(material(model, 1e5, 0.3), rng, 0.2);
      const IsotropicEnergy energy(body.material);
      const ElementRest rest = ElementRest::of(body, 0);
      const Matrix34 corners = element_corners(body, body.positions, 0);
      const Matrix12 K = element_hessian(energy, rest, corners, false);
      const auto minus_forces = [&](const Matrix34& c) -> Matrix34 { return -element_forces(energy, rest, c); };
      const double scale = K.norm();
      EXPECT_TRUE(second_order(check_derivative(minus_forces, corners, K, 1e-6, test::ErrorNorm::frobenius),
                               1e-5 * scale, 1e-9 * scale))
          << "model " << static_cast<int>(model) << " trial " << trial;
      EXPECT_LT((K - K.transpose()).norm(), 1e-12 * scale);
    }
  }
}

// Projected to positive semi-definite, also for inverted elements; and
// unchanged where the unprojected one was already so (at rest).
TEST(ElementElasticity, ProjectedHessianIsPositiveSemiDefinite) {
  std::mt19937 rng(2);
  int inverted = 0;
  for (const ElasticModel model : kModels)
    for (int trial = 0; trial < 40; ++trial) {
      const Body body = random_element(material(model, 1e5, 0.45), rng, 0.8);
      inverted += signed_volume(body.positions, body.tets, 0) < 0.0;
      const Matrix12 K = element_hessian(IsotropicEnergy(body.material), ElementRest::of(body, 0),
                                         element_corners(body, body.positions, 0), true);
      const double lowest = Eigen::SelfAdjointEigenSolver<Matrix12>(K).eigenvalues().minCoeff();
      EXPECT_GE(lowest, -1e-10 * K.norm());
    }
  EXPECT_GT(inverted, 10);
  const Body rest = make_body(make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(1)),
                              material(ElasticModel::neo_hookean, 1e5, 0.3));
  const IsotropicEnergy energy(rest.material);
  for (Index e = 0; e < rest.num_elements(); ++e) {
    const Matrix34 corners = element_corners(rest, rest.positions, e);
    const Matrix12 raw = element_hessian(energy, ElementRest::of(rest, e), corners, false);
    EXPECT_LT((element_hessian(energy, ElementRest::of(rest, e), corners, true) - raw).norm(), 1e-9 * raw.norm());
  }
}

// C_e is the damping: −Σ C_e v equals the viscous forces of core/damping.h.
TEST(ElementElasticity, DampingMatrixReproducesTheViscousForces) {
  std::mt19937 rng(3);
  Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(2)),
                        material(ElasticModel::fixed_corotated, 1e5, 0.3, 7.0));
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) body.positions(n, k) += 0.01 * u(rng);
  Points v(body.num_nodes(), 3);
  for (Index n = 0; n < body.num_nodes(); ++n) v.row(n) = Eigen::RowVector3d(u(rng), u(rng), u(rng));
  ElasticForces forces;
  Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  Damping damping;
  Points expected;
  damping.freeze(body, forces);
  damping.apply(body, v, expected);
  Points got = Points::Zero(body.num_nodes(), 3);
  for (Index e = 0; e < body.num_elements(); ++e) {
    const Matrix12 C =
        element_damping_matrix(body.material.viscosity, ElementRest::of(body, e), forces.elastic_deformation(e));
    Eigen::Matrix<double, 12, 1> ve;
    for (int k = 0; k < 4; ++k) ve.segment<3>(3 * k) = v.row(body.tets(e, k)).transpose();
    const Eigen::Matrix<double, 12, 1> fe = -C * ve;
    for (int k = 0; k < 4; ++k) got.row(body.tets(e, k)) += fe.segment<3>(3 * k).transpose();
  }
  EXPECT_TRUE(test::matrices_near(got, expected, 1e-12 * expected.cwiseAbs().maxCoeff()));
}

// ElasticForces and elastic_energy are the element functions summed over
// the body: the same numbers, bit for bit, in the incidence order.
TEST(ElementElasticity, TheBodysForcesAndEnergyAreTheElementsSummed) {
  std::mt19937 rng(4);
  Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(2)),
                        material(ElasticModel::stable_neo_hookean, 1e5, 0.4));
  std::uniform_real_distribution<double> u(-0.03, 0.03);
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) body.positions(n, k) += u(rng);
  ElasticForces forces;
  Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  const IsotropicEnergy energy(body.material);
  std::vector<Matrix34> per_element;
  CompensatedSum total;
  for (Index e = 0; e < body.num_elements(); ++e) {
    const Matrix34 corners = element_corners(body, body.positions, e);
    per_element.push_back(element_forces(energy, ElementRest::of(body, e), corners));
    total.add(element_energy(energy, ElementRest::of(body, e), corners));
  }
  Points gathered;
  gather_to_nodes(body.incidence, per_element, gathered);
  EXPECT_TRUE(gathered == f);
  EXPECT_EQ(total.value(), elastic_energy(body, body.positions));
  EXPECT_GT(f.norm(), 0.0);
}

}  // namespace
}  // namespace goo
