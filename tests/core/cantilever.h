#pragma once
// Static equilibrium of a clamped body under gravity by Newton's method, with
// goo's elastic forces and a tangent assembled from dP/dF: the check that the
// finite elements converge to beam theory.
#include <Eigen/SparseCholesky>
#include <Eigen/SparseLU>
#include <vector>

#include "core/body.h"
#include "core/elastic_forces.h"

namespace goo::test {

/// Beam theory's tip deflection of a cantilever of length L and square
/// section h (ν = 0) under its weight, m: Euler–Bernoulli's q L⁴ / (8 E I),
/// q = ρ g h², I = h⁴/12, plus Timoshenko's shear term q L² / (2 κ G A),
/// κ = 5/6, G = E/2 (0.8% more at h/L = 0.1).
inline double cantilever_tip_reference(double E, double rho, double g, double h, double L) {
  const double q = rho * g * h * h, I = h * h * h * h / 12.0;
  return q * L * L * L * L / (8.0 * E * I) + q * L * L / (2.0 * (5.0 / 6.0) * (E / 2.0) * h * h);
}

/// The mean downward displacement of the nodes whose rest x is L, m.
inline double tip_deflection(const Body& body, double L) {
  double sum = 0.0;
  int count = 0;
  for (Index v = 0; v < body.num_nodes(); ++v)
    if (body.rest_positions(v, 0) == L) {
      sum += body.rest_positions(v, 2) - body.positions(v, 2);
      ++count;
    }
  return sum / count;
}

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

/// Degrees of freedom of the free nodes (−1 for clamped ones); `free` their count.
inline std::vector<Index> free_dofs(const Body& body, const std::vector<bool>& clamped, Index& free) {
  std::vector<Index> dof(static_cast<std::size_t>(body.num_nodes()), -1);
  free = 0;
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (!clamped[static_cast<std::size_t>(n)]) dof[static_cast<std::size_t>(n)] = free++;
  return dof;
}

/// r = f_int + f_ext over the free nodes, and the tangent stiffness K
/// (from dP/dF) as triplets.
inline Eigen::VectorXd static_residual(Body& body, const std::vector<Index>& dof, Index free, double g,
                                       std::vector<Eigen::Triplet<double>>& triplets) {
  const IsotropicEnergy energy(body.material);
  ElasticForces forces;
  Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  Eigen::VectorXd r(3 * free);
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Index d = dof[static_cast<std::size_t>(n)];
    if (d < 0) continue;
    r.segment<3>(3 * d) = f.row(n).transpose() + body.masses[n] * Eigen::Vector3d(0.0, 0.0, -g);
  }
  triplets.clear();
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
  return r;
}

/// Moves the free nodes of `body` to equilibrium under gravity g (−z) with
/// `clamped` nodes fixed; returns the final residual norm.
inline double solve_static(Body& body, const std::vector<bool>& clamped, double g, int iterations = 8) {
  Index free = 0;
  const std::vector<Index> dof = free_dofs(body, clamped, free);
  double residual = 0.0;
  std::vector<Eigen::Triplet<double>> triplets;
  for (int it = 0; it < iterations; ++it) {
    const Eigen::VectorXd r = static_residual(body, dof, free, g, triplets);
    residual = r.norm();
    Eigen::SparseMatrix<double> K(3 * free, 3 * free);
    K.setFromTriplets(triplets.begin(), triplets.end());
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(K);
    const Eigen::VectorXd dx = solver.solve(r);  // K dx = f_int + f_ext
    for (Index n = 0; n < body.num_nodes(); ++n) {
      const Index d = dof[static_cast<std::size_t>(n)];
      if (d >= 0) body.positions.row(n) += dx.segment<3>(3 * d).transpose();
    }
  }
  return residual;
}

/// The same with every node keeping its volume, V_i(x) = ¼ Σ_{e∋i} V_e(x)
/// equal to its rest value (the constraints of core/volume_projection.h),
/// by Newton on the saddle-point system [K Gᵀ; G 0] [Δx; p] = [r; −C]
/// (the constraints' curvature left out of K: a quasi-Newton method that
/// converges linearly), solved by sparse LU, until no node moves by more
/// than `step_tolerance` (m). Returns the iterations taken.
inline int solve_static_incompressible(Body& body, const std::vector<bool>& clamped, double g,
                                       double step_tolerance = 1e-10, int max_iterations = 60) {
  Index free = 0;
  const std::vector<Index> dof = free_dofs(body, clamped, free);
  const Index nn = body.num_nodes();
  Eigen::VectorXd rest_node = Eigen::VectorXd::Zero(nn);
  for (Index e = 0; e < body.num_elements(); ++e)
    for (int k = 0; k < 4; ++k) rest_node[body.tets(e, k)] += 0.25 * body.rest_volumes[e];
  Eigen::VectorXd pressure = Eigen::VectorXd::Zero(nn);
  std::vector<Eigen::Triplet<double>> triplets;
  int it = 0;
  while (it < max_iterations) {
    ++it;
    Eigen::VectorXd r = static_residual(body, dof, free, g, triplets);
    Eigen::VectorXd C = -rest_node;
    for (Index e = 0; e < body.num_elements(); ++e) {
      const auto x = [&](int k) { return Eigen::Vector3d(body.positions.row(body.tets(e, k)).transpose()); };
      const Eigen::Vector3d d1 = x(1) - x(0), d2 = x(2) - x(0), d3 = x(3) - x(0);
      Eigen::Matrix<double, 3, 4> grad;
      grad.col(1) = d2.cross(d3) / 6.0;
      grad.col(2) = d3.cross(d1) / 6.0;
      grad.col(3) = d1.cross(d2) / 6.0;
      grad.col(0) = -(grad.col(1) + grad.col(2) + grad.col(3));
      const double volume = d1.dot(grad.col(1));
      for (int a = 0; a < 4; ++a) {
        const Index i = body.tets(e, a);
        C[i] += 0.25 * volume;
        for (int k = 0; k < 4; ++k) {
          const Index d = dof[static_cast<std::size_t>(body.tets(e, k))];
          if (d < 0) continue;
          for (int c = 0; c < 3; ++c) {
            // G (row 3·free + i) and Gᵀ; the pressure's force −Gᵀp joins r.
            triplets.emplace_back(3 * free + i, 3 * d + c, 0.25 * grad(c, k));
            triplets.emplace_back(3 * d + c, 3 * free + i, 0.25 * grad(c, k));
            r[3 * d + c] -= 0.25 * grad(c, k) * pressure[i];
          }
        }
      }
    }
    Eigen::SparseMatrix<double> A(3 * free + nn, 3 * free + nn);
    A.setFromTriplets(triplets.begin(), triplets.end());
    Eigen::VectorXd rhs(3 * free + nn);
    rhs << r, -C;
    Eigen::SparseLU<Eigen::SparseMatrix<double>> solver;
    solver.compute(A);
    const Eigen::VectorXd step = solver.solve(rhs);  // K Δx + Gᵀ Δp = r, G Δx = −C
    for (Index n = 0; n < nn; ++n) {
      const Index d = dof[static_cast<std::size_t>(n)];
      if (d >= 0) body.positions.row(n) += step.segment<3>(3 * d).transpose();
    }
    pressure += step.tail(nn);
    if (step.head(3 * free).cwiseAbs().maxCoeff() < step_tolerance) break;
  }
  return it;
}

}  // namespace goo::test
