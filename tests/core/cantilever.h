#pragma once
// Static equilibrium of a clamped body under gravity by Newton's method, with
// goo's elastic forces and a tangent assembled from dP/dF: the check that the
// finite elements converge to beam theory.
#include <Eigen/SparseCholesky>
#include <vector>

#include "core/body.h"
#include "core/elastic_forces.h"

namespace goo::test {

/// ∂vec(F)/∂(x0, x1, x2, x3) of a linear tetrahedron (9×12): F = Ds Dm⁻¹.
inline Eigen::Matrix<double, 9, 12> deformation_gradient_jacobian(const Eigen::Matrix3d& Dm_inv) {
  Eigen::Matrix<double, 9, 12> G = Eigen::Matrix<double, 9, 12>::Zero();
  for (int j = 0; j < 3; ++j)      // column of F
    for (int i = 0; i < 3; ++i) {  // row of F
      for (int k = 0; k < 3; ++k) {
        G(i + 3 * j, 3 * (k + 1) + i) += Dm_inv(k, j);
        G(i + 3 * j, i) -= Dm_inv(k, j);
      }
    }
  return G;
}

/// Moves the free nodes of `body` to equilibrium under gravity g (−z) with
/// `clamped` nodes fixed; returns the final residual norm.
inline double solve_static(Body& body, const std::vector<bool>& clamped, double g, int iterations = 8) {
  const IsotropicEnergy energy(body.material);
  const Index nn = body.num_nodes();
  std::vector<Index> dof(static_cast<std::size_t>(nn), -1);
  Index free = 0;
  for (Index n = 0; n < nn; ++n)
    if (!clamped[static_cast<std::size_t>(n)]) dof[static_cast<std::size_t>(n)] = free++;
  ElasticForces forces;
  Points f;
  double residual = 0.0;
  for (int it = 0; it < iterations; ++it) {
    forces.evaluate(body, body.positions, 0.0, f);
    Eigen::VectorXd r(3 * free);
    for (Index n = 0; n < nn; ++n) {
      const Index d = dof[static_cast<std::size_t>(n)];
      if (d < 0) continue;
      r.segment<3>(3 * d) = f.row(n).transpose() + body.masses[n] * Eigen::Vector3d(0.0, 0.0, -g);
    }
    residual = r.norm();
    std::vector<Eigen::Triplet<double>> triplets;
    for (Index e = 0; e < body.num_elements(); ++e) {
      const Eigen::Matrix<double, 9, 12> G = deformation_gradient_jacobian(body.Dm_inv[static_cast<std::size_t>(e)]);
      const Eigen::Matrix3d F = deformation_gradient(body, body.positions, e);
      const Eigen::Matrix<double, 12, 12> K =
          body.rest_volumes[e] * G.transpose() * first_piola_derivative(energy, svd3(F)) * G;
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) {
          const Index da = dof[static_cast<std::size_t>(body.tets(e, a))],
                      db = dof[static_cast<std::size_t>(body.tets(e, b))];
          if (da < 0 || db < 0) continue;
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) triplets.emplace_back(3 * da + i, 3 * db + j, K(3 * a + i, 3 * b + j));
        }
    }
    Eigen::SparseMatrix<double> K(3 * free, 3 * free);
    K.setFromTriplets(triplets.begin(), triplets.end());
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(K);
    const Eigen::VectorXd dx = solver.solve(r);  // K dx = f_int + f_ext
    for (Index n = 0; n < nn; ++n) {
      const Index d = dof[static_cast<std::size_t>(n)];
      if (d >= 0) body.positions.row(n) += dx.segment<3>(3 * d).transpose();
    }
  }
  return residual;
}

}  // namespace goo::test
