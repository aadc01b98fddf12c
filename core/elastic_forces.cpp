#include "core/elastic_forces.h"
#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/plasticity.h"
#include "core/surface_geometry.h"

namespace goo {

Eigen::Matrix3d deformation_gradient(const Body& body, const Points& x, Index e) {
  return deformation_gradient(body.Dm_inv[at(e)], element_corners(body, x, e));
}

void gather_to_nodes(const NodeIncidence& incidence, const std::vector<Matrix34>& per_element, Points& out) {
  const auto num_nodes = static_cast<Index>(incidence.offsets.size() - 1);
  out.resize(num_nodes, 3);
  tbb::parallel_for(tbb::blocked_range<Index>(0, num_nodes, kParallelGrain),
                    [&](const tbb::blocked_range<Index>& range) {
                      for (Index n = range.begin(); n != range.end(); ++n) {
                        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
                        for (Index c = incidence.offsets[at(n)]; c < incidence.offsets[at(n) + 1]; ++c) {
                          const Index corner = incidence.corners[at(c)];
                          sum += per_element[at(corner / 4)].col(corner % 4);
                        }
                        out.row(n) = sum.transpose();
                      }
                    });
}

void ElasticForces::evaluate(Body& body, const Points& x, double plastic_dt, Points& f) {
  const Index ne = body.num_elements();
  element_forces_.resize(at(ne));
  Fe_.resize(at(ne));
  Fp_inv_.resize(at(ne));
  element_dt_squared_.resize(at(ne));
  flowed_.assign(at(ne), 0);
  const IsotropicEnergy energy(body.material);
  const Material& material = body.material;
  const bool plastic = plastic_dt > 0.0 && material.plastic() && material.flow_rate > 0.0;
  const double modulus = energy.lambda() + 2.0 * energy.mu();

  // The SVDs kSvdLanes elements at a time in the processor's vector lanes
  // (core/svd3_batch.h: the same bits as one at a time), the rest of each
  // element's work one element at a time.
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& range) {
    const auto elastic_deformation = [&](Index e) {
      Fp_inv_[at(e)] = body.Fp[at(e)].inverse();
      return Eigen::Matrix3d(deformation_gradient(body, x, e) * Fp_inv_[at(e)]);
    };
    for_each_svd3(range.begin(), range.end(), elastic_deformation, [&](Index e, Svd3& svd) {
      const Eigen::Matrix3d& Dm_inv = body.Dm_inv[at(e)];
      Eigen::Matrix3d& Fp = body.Fp[at(e)];
      if (plastic && plastic_flow(material, energy, plastic_dt, svd, Fp, body.alpha[e])) {
        Fp_inv_[at(e)] = Fp.inverse();
        flowed_[at(e)] = 1;
      }
      const double stress_free_volume = body.rest_volumes[e] * Fp.determinant();
      element_forces_[at(e)] = element_forces(energy, svd, Fp_inv_[at(e)], Dm_inv, stress_free_volume);
      Fe_[at(e)] = svd.U * svd.sigma.asDiagonal() * svd.V.transpose();

      // Explicit stability bound (algorithms.md, "Time integration").
      const double grad_sq = Dm_inv.squaredNorm() + Dm_inv.colwise().sum().squaredNorm();
      const double k_e = modulus * stress_free_volume * grad_sq;
      double m_min = body.masses[body.tets(e, 0)];
      for (int k = 1; k < 4; ++k) m_min = std::min(m_min, body.masses[body.tets(e, k)]);
      element_dt_squared_[at(e)] = m_min / k_e;
    });
  });
  gather_to_nodes(body.incidence, element_forces_, f);
  // min and counting are exact in any order. The root of the least ratio is
  // the least root (√ is correctly rounded and monotonic): one square root
  // instead of one an element.
  critical_dt_ =
      ne > 0 ? std::sqrt(*std::min_element(element_dt_squared_.begin(), element_dt_squared_.end())) : 0.0;
  plastic_count_ = static_cast<Index>(std::count(flowed_.begin(), flowed_.end(), 1));
}

double elastic_energy(const Body& body, const Points& x) {
  const IsotropicEnergy energy(body.material);
  CompensatedSum total;
  for (Index e = 0; e < body.num_elements(); ++e)
    total.add(element_energy(energy, ElementRest::of(body, e), element_corners(body, x, e)));
  return total.value();
}

}  // namespace goo
