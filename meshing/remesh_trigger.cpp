#include "meshing/remesh_trigger.h"

#include <limits>

#include "core/svd3.h"

namespace goo {

double condition_number(const Eigen::Matrix3d& Ds) {
  const Eigen::Vector3d s = svd3(Ds).sigma;
  if (!(s[2] > 0.0)) return std::numeric_limits<double>::infinity();
  return s[0] / s[2];
}

RemeshCheck check_remesh(const Body& body, const Points& x,
                         const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& bary,
                         const RemeshThresholds& thresholds) {
  RemeshCheck out;
  // Serial: a max and a first index are the same in any order, and this
  // costs one SVD per element, like a force evaluation.
  for (Index e = 0; e < body.num_elements(); ++e) {
    const Eigen::Vector3d x0 = x.row(body.tets(e, 0));
    Eigen::Matrix3d Ds;
    for (int k = 0; k < 3; ++k) Ds.col(k) = x.row(body.tets(e, k + 1)).transpose() - x0;
    const double growth = condition_number(Ds) / body.rest_condition[e];
    if (growth > out.worst_growth) out.worst_growth = growth;
    if (growth > thresholds.condition_growth && out.element < 0) out.element = e;
  }
  for (Eigen::Index v = 0; v < bary.rows(); ++v) {
    if (bary.row(v).minCoeff() < thresholds.min_barycentric) {
      out.vertex = static_cast<Index>(v);
      break;
    }
  }
  out.due = out.element >= 0 || out.vertex >= 0;
  return out;
}

}  // namespace goo
