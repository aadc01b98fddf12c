#include "core/svd3.h"

#include <Eigen/SVD>

#include "core/svd3_lanes.h"

namespace goo {
Svd3 svd3(const Eigen::Matrix3d& F) {
  using lanes::Mat3;
  using lanes::ScalarOps;
  Mat3<double> f, u, v;
  for (int k = 0; k < 9; ++k) f.m[k] = F.data()[k];
  Svd3 out;
  lanes::svd3_lanes<ScalarOps>(f, u, out.sigma.data(), v);
  for (int k = 0; k < 9; ++k) {
    out.U.data()[k] = u.m[k];
    out.V.data()[k] = v.m[k];
  }
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
