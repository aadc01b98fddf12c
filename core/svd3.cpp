#include "core/svd3.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace goo {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// One Jacobi rotation zeroing A(p, q) of the symmetric A, accumulated in V
/// (Golub & Van Loan, Matrix Computations, alg. 8.4.1).
inline void jacobi_rotate(Eigen::Matrix3d& A, Eigen::Matrix3d& V, int p, int q) {
  const double apq = A(p, q);
  const double tau = (A(q, q) - A(p, p)) / (2.0 * apq);
  const double t = (tau >= 0.0 ? 1.0 : -1.0) / (std::abs(tau) + std::sqrt(1.0 + tau * tau));
  const double c = 1.0 / std::sqrt(1.0 + t * t);
  const double s = t * c;
  const int r = 3 - p - q;
  const double arp = A(r, p), arq = A(r, q);
  A(p, p) -= t * apq;
  A(q, q) += t * apq;
  A(p, q) = A(q, p) = 0.0;
  A(r, p) = A(p, r) = c * arp - s * arq;
  A(r, q) = A(q, r) = s * arp + c * arq;
  for (int i = 0; i < 3; ++i) {
    const double vip = V(i, p), viq = V(i, q);
    V(i, p) = c * vip - s * viq;
    V(i, q) = s * vip + c * viq;
  }
}

/// A unit vector orthogonal to the unit vector a.
inline Eigen::Vector3d any_orthogonal(const Eigen::Vector3d& a) {
  int smallest = 0;
  a.cwiseAbs().minCoeff(&smallest);
  return a.cross(Eigen::Vector3d::Unit(smallest)).normalized();
}

}  // namespace

Svd3 svd3(const Eigen::Matrix3d& F_in) {
  // Work on F / max|F_ij| so that FᵀF neither overflows nor underflows for
  // any finite F; σ is scaled back at the end.
  const double scale = F_in.cwiseAbs().maxCoeff();
  if (!(scale > 0.0)) return {Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()};
  const Eigen::Matrix3d F = F_in / scale;
  Eigen::Matrix3d A = F.transpose() * F;
  Eigen::Matrix3d V = Eigen::Matrix3d::Identity();
  // Relative convergence: a_pq is negligible next to √(a_pp a_qq), which
  // keeps small eigenvalues accurate. Quadratic convergence: ≤ 5 sweeps in
  // practice; the cap only guards against NaN input.
  for (int sweep = 0; sweep < 12; ++sweep) {
    bool rotated = false;
    for (const auto& [p, q] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}}) {
      if (std::abs(A(p, q)) > kEps * std::sqrt(std::abs(A(p, p))) * std::sqrt(std::abs(A(q, q))) && A(p, q) != 0.0) {
        jacobi_rotate(A, V, p, q);
        rotated = true;
      }
    }
    if (!rotated) break;
  }
  // Order the eigenvalues (σ²) descending; each swap flips det V.
  Eigen::Vector3d lambda = A.diagonal();
  auto swap = [&](int i, int j) {
    std::swap(lambda[i], lambda[j]);
    V.col(i).swap(V.col(j));
  };
  if (lambda[0] < lambda[1]) swap(0, 1);
  if (lambda[0] < lambda[2]) swap(0, 2);
  if (lambda[1] < lambda[2]) swap(1, 2);
  if (V.determinant() < 0.0) V.col(2) = -V.col(2);

  const Eigen::Matrix3d B = F * V;  // columns σ_i u_i
  Svd3 out;
  out.V = V;
  Eigen::Vector3d u1 = B.col(0);
  const double n1 = u1.norm();
  u1 = n1 > std::numeric_limits<double>::min() ? Eigen::Vector3d(u1 / n1) : Eigen::Vector3d::UnitX();
  Eigen::Vector3d u2 = B.col(1) - u1.dot(B.col(1)) * u1;
  const double n2 = u2.norm();
  u2 = n2 > std::numeric_limits<double>::min() ? Eigen::Vector3d(u2 / n2) : any_orthogonal(u1);
  const Eigen::Vector3d u3 = u1.cross(u2);
  out.U.col(0) = u1;
  out.U.col(1) = u2;
  out.U.col(2) = u3;
  out.sigma = Eigen::Vector3d(u1.dot(B.col(0)), u2.dot(B.col(1)), u3.dot(B.col(2)));
  // The eigenvalue order makes σ1 ≥ σ2 ≥ |σ3| up to round-off; ties can come
  // out an ulp apart in either direction, so make the order exact (a change
  // within the reconstruction error).
  out.sigma[1] = std::max(out.sigma[1], std::abs(out.sigma[2]));
  out.sigma[0] = std::max(out.sigma[0], out.sigma[1]);
  out.sigma *= scale;
  return out;
}

Svd3 svd3_reference(const Eigen::Matrix3d& F) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Svd3 out{svd.matrixU(), svd.singularValues(), svd.matrixV()};
  if (out.U.determinant() < 0.0) {
    out.U.col(2) = -out.U.col(2);
    out.sigma[2] = -out.sigma[2];
  }
  if (out.V.determinant() < 0.0) {
    out.V.col(2) = -out.V.col(2);
    out.sigma[2] = -out.sigma[2];
  }
  return out;
}

}  // namespace goo
