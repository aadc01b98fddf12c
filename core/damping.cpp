#include "core/damping.h"
#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace goo {

void Damping::apply(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                    const std::vector<Eigen::Matrix3d>& Fp_inv, const Points& v, Points& out) {
  const Index ne = body.num_elements();
  element_forces_.resize(at(ne));
  const double beta = body.material.viscosity;
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& range) {
    for (Index e = range.begin(); e != range.end(); ++e) {
      const Eigen::Matrix3d& G = Fe[at(e)];
      const Eigen::Matrix3d& Q = Fp_inv[at(e)];
      const Eigen::Matrix3d Fe_dot = deformation_gradient(body, v, e) * Q;  // Ḟe = Vs Dm⁻¹ Fp⁻¹
      const Eigen::Matrix3d E_dot = G.transpose() * Fe_dot;
      const Eigen::Matrix3d P = 2.0 * beta * G * (0.5 * (E_dot + E_dot.transpose())) * Q.transpose();
      const double volume = body.rest_volumes[e] / Q.determinant();  // W det Fp
      const Eigen::Matrix3d H = -volume * P * body.Dm_inv[at(e)].transpose();
      Matrix34& f = element_forces_[at(e)];
      f.col(0) = -H.rowwise().sum();
      f.rightCols<3>() = H;
    }
  });
  gather_to_nodes(body.incidence, element_forces_, out);
}

double max_strain_rate(const Body& body, const Points& v) {
  double rate = 0.0;  // max is exact in any order; serial and cheap (no SVD)
  for (Index e = 0; e < body.num_elements(); ++e) rate = std::max(rate, deformation_gradient(body, v, e).norm());
  return rate;
}

}  // namespace goo
