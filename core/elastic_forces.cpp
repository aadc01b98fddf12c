#include "core/elastic_forces.h"
#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/force_batch.h"
#include "core/node_sums.h"
#include "core/plasticity.h"
#include "core/surface_geometry.h"

namespace goo {

Eigen::Matrix3d deformation_gradient(const Body& body, const Points& x, Index e) {
  return deformation_gradient(body.Dm_inv[at(e)], element_corners(body, x, e));
}

void gather_to_nodes(const NodeIncidence& incidence, const std::vector<Matrix34>& per_element, Points& out) {
  out.resize(static_cast<Index>(incidence.offsets.size() - 1), 3);
  sum_over_corners(
      incidence, Eigen::Vector3d::Zero().eval(),
      [&](Index corner) -> Eigen::Vector3d { return per_element[at(corner / 4)].col(corner % 4); },
      [&](Index n, const Eigen::Vector3d& sum) { out.row(n) = sum.transpose(); });
}

void ElasticForces::evaluate(Body& body, const Points& x, double plastic_dt, Points& f) {
  const Index ne = body.num_elements();
  const NodeIncidence& incidence = body.incidence;
  require_slots(incidence, ne, "elastic forces");
  corner_forces_.resize(4 * at(ne));
  Fe_.resize(at(ne));
  Fp_inv_.resize(at(ne));
  element_dt_squared_.resize(at(ne));
  flowed_.assign(at(ne), 0);
  const IsotropicEnergy energy(body.material);
  const Material& material = body.material;
  const bool plastic = plastic_dt > 0.0 && material.plastic() && material.flow_rate > 0.0;
  const double modulus = energy.lambda() + 2.0 * energy.mu();

  // kSvdLanes elements at a time: the deformations, their SVDs and the
  // forces in the processor's vector lanes (core/force_batch.h: the same
  // bits as one element at a time), the plastic flow and the stress of the
  // model one element at a time.
  const SimdLevel level = simd_level_;
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& range) {
    ForceBatch b;
    for (Index first = range.begin(); first < range.end(); first += kSvdLanes) {
      const int lanes = static_cast<int>(std::min<Index>(kSvdLanes, range.end() - first));
      for (int lane = 0; lane < kSvdLanes; ++lane) {
        // A lane past the range's end holds the unit tetrahedron at rest.
        const bool used = lane < lanes;
        const Index e = used ? first + lane : 0;
        for (int c = 0; c < 4; ++c)
          for (int i = 0; i < 3; ++i) b.x[c][i][lane] = used ? x(body.tets(e, c), i) : (c == i + 1 ? 1.0 : 0.0);
        for (int k = 0; k < 9; ++k) {
          const double identity = k % 4 == 0 ? 1.0 : 0.0;
          b.Dm_inv[k][lane] = used ? body.Dm_inv[at(e)].data()[k] : identity;
          b.Fp[k][lane] = used ? body.Fp[at(e)].data()[k] : identity;
        }
      }
      force_batch_deform(b, level);
      for (int lane = 0; lane < lanes; ++lane) {
        const Index e = first + lane;
        Eigen::Matrix3d& Fp = body.Fp[at(e)];
        Eigen::Matrix3d& Fp_inv = Fp_inv_[at(e)];
        for (int k = 0; k < 9; ++k) Fp_inv.data()[k] = b.Fp_inv[k][lane];
        if (plastic) {
          Svd3 svd;
          for (int k = 0; k < 9; ++k) {
            svd.U.data()[k] = b.svd.U[k][lane];
            svd.V.data()[k] = b.svd.V[k][lane];
          }
          for (int k = 0; k < 3; ++k) svd.sigma[k] = b.svd.sigma[k][lane];
          if (plastic_flow(material, energy, plastic_dt, svd, Fp, body.alpha[e])) {
            Fp_inv = Fp.inverse();
            for (int k = 0; k < 9; ++k) b.Fp_inv[k][lane] = Fp_inv.data()[k];
            for (int k = 0; k < 3; ++k) b.svd.sigma[k][lane] = svd.sigma[k];
            flowed_[at(e)] = 1;
          }
        }
        const Eigen::Vector3d dpsi =
            energy.dpsi(Eigen::Vector3d(b.svd.sigma[0][lane], b.svd.sigma[1][lane], b.svd.sigma[2][lane]));
        for (int k = 0; k < 3; ++k) b.dpsi[k][lane] = dpsi[k];
        const double stress_free_volume = body.rest_volumes[e] * Fp.determinant();
        b.volume[lane] = stress_free_volume;

        // Explicit stability bound (algorithms.md, "Time integration").
        const Eigen::Matrix3d& Dm_inv = body.Dm_inv[at(e)];
        const double grad_sq = Dm_inv.squaredNorm() + Dm_inv.colwise().sum().squaredNorm();
        const double k_e = modulus * stress_free_volume * grad_sq;
        double m_min = body.masses[body.tets(e, 0)];
        for (int k = 1; k < 4; ++k) m_min = std::min(m_min, body.masses[body.tets(e, k)]);
        element_dt_squared_[at(e)] = m_min / k_e;
      }
      for (int lane = lanes; lane < kSvdLanes; ++lane) {
        for (int k = 0; k < 3; ++k) b.dpsi[k][lane] = 0.0;
        b.volume[lane] = 0.0;
      }
      force_batch_forces(b, level);
      for (int lane = 0; lane < lanes; ++lane) {
        const Index e = first + lane;
        for (int c = 0; c < 4; ++c) {
          Eigen::Vector3d& force = corner_forces_[at(incidence.slots[at(4 * e + c)])];
          for (int i = 0; i < 3; ++i) force[i] = b.f[c][i][lane];
        }
        for (int k = 0; k < 9; ++k) Fe_[at(e)].data()[k] = b.Fe[k][lane];
      }
    }
  });
  sum_slots_to_nodes(incidence, corner_forces_, f);
  // min and counting are exact in any order. The root of the least ratio is
  // the least root (√ is correctly rounded and monotonic): one square root
  // instead of one an element.
  critical_dt_ = ne > 0 ? std::sqrt(*std::min_element(element_dt_squared_.begin(), element_dt_squared_.end())) : 0.0;
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
