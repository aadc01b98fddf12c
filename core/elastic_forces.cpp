#include "core/elastic_forces.h"
#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "core/error.h"
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

namespace {

/// The body's arrays force_batch_gather reads.
ForceSources force_sources(const Body& body, const Points& x) {
  ForceSources sources;
  sources.x = x.data();
  sources.masses = body.masses.data();
  sources.tets = body.tets.data();
  sources.Dm_inv = body.Dm_inv.empty() ? nullptr : body.Dm_inv.front().data();
  sources.Fp = body.Fp.empty() ? nullptr : body.Fp.front().data();
  sources.rest_volumes = body.rest_volumes.data();
  return sources;
}

}  // namespace

void ElasticForces::evaluate(Body& body, const Points& x, double plastic_dt, Points& f) {
  const Index ne = body.num_elements();
  const NodeIncidence& incidence = body.incidence;
  require_slots(incidence, ne, "elastic forces");
  if (ne > std::numeric_limits<int>::max() / 9 - kSvdLanes)
    throw Error("elastic forces: " + std::to_string(ne) + " elements, more than the force pass can index");
  corner_forces_.resize(4 * at(ne));
  damping_blocks_.resize(at((ne + kDampingLanes - 1) / kDampingLanes));
  evaluated_elements_ = ne;
  element_dt_squared_.resize(at(ne));
  flowed_.assign(at(ne), 0);
  const IsotropicEnergy energy(body.material);
  const Material& material = body.material;
  const bool plastic = plastic_dt > 0.0 && material.plastic() && material.flow_rate > 0.0;
  ForceModel model;
  model.stress = material.model == ElasticModel::fixed_corotated      ? LaneStress::fixed_corotated
                 : material.model == ElasticModel::stable_neo_hookean ? LaneStress::stable_neo_hookean
                                                                      : LaneStress::given;
  model.mu = energy.mu();
  model.lambda = energy.lambda();
  model.modulus = energy.lambda() + 2.0 * energy.mu();
  model.viscosity = material.viscosity;
  const ForceSources sources = force_sources(body, x);

  // Each lane's plastic flow (reusing its SVD) and the neo-Hookean's stress,
  // one element at a time.
  const auto flow_and_stress = [&](ForceBatch& b, Index first, int lanes) {
    for (int lane = 0; lane < lanes; ++lane) {
      const Index e = first + lane;
      if (plastic) {
        Svd3 svd;
        for (int k = 0; k < 9; ++k) {
          svd.U.data()[k] = b.svd.U[k][lane];
          svd.V.data()[k] = b.svd.V[k][lane];
        }
        for (int k = 0; k < 3; ++k) svd.sigma[k] = b.svd.sigma[k][lane];
        Eigen::Matrix3d& Fp = body.Fp[at(e)];
        if (plastic_flow(material, energy, plastic_dt, svd, Fp, body.alpha[e])) {
          const Eigen::Matrix3d Fp_inv = Fp.inverse();
          for (int k = 0; k < 9; ++k) {
            b.Fp[k][lane] = Fp.data()[k];
            b.Fp_inv[k][lane] = Fp_inv.data()[k];
          }
          for (int k = 0; k < 3; ++k) b.svd.sigma[k][lane] = svd.sigma[k];
          flowed_[at(e)] = 1;
        }
      }
      if (model.stress == LaneStress::given) {
        const Eigen::Vector3d dpsi =
            energy.dpsi(Eigen::Vector3d(b.svd.sigma[0][lane], b.svd.sigma[1][lane], b.svd.sigma[2][lane]));
        for (int k = 0; k < 3; ++k) b.dpsi[k][lane] = dpsi[k];
      }
    }
  };
  // Each corner's force at its place in the incidence, the bounds, and
  // whole rows of damping-block lanes (a constant size: moves of vector
  // registers).
  const auto store = [&](const ForceBatch& b, Index first, int lanes) {
    for (int lane = 0; lane < lanes; ++lane)
      for (int c = 0; c < 4; ++c) {
        Eigen::Vector3d& force = corner_forces_[at(incidence.slots[at(4 * (first + lane) + c)])];
        for (int i = 0; i < 3; ++i) force[i] = b.f[c][i][lane];
      }
    std::copy_n(b.dt_squared, lanes, &element_dt_squared_[at(first)]);
    for (int offset = 0; offset < lanes; offset += kDampingLanes) {
      DampingBlock& block = damping_blocks_[at((first + offset) / kDampingLanes)];
      for (int k = 0; k < 9; ++k) {
        std::memcpy(block.G[k], &b.Fe[k][offset], sizeof(block.G[k]));
        std::memcpy(block.A[k], &b.A[k][offset], sizeof(block.A[k]));
      }
      std::memcpy(block.scale, &b.damping_scale[offset], sizeof(block.scale));
    }
  };

  // kSvdLanes elements at a time: the gathers, the deformations, their
  // SVDs, the polynomial models' stresses, the forces, the stability bounds
  // and what the damping freezes in the processor's vector lanes
  // (core/force_batch.h: the same bits as one element at a time). Batch j
  // holds elements kSvdLanes j onwards, so its lanes fill whole damping
  // blocks.
  static_assert(kSvdLanes % kDampingLanes == 0);
  const SimdLevel level = simd_level_;
  const Index batches = (ne + kSvdLanes - 1) / kSvdLanes;
  tbb::parallel_for(
      tbb::blocked_range<Index>(0, batches, kParallelGrain / kSvdLanes), [&](const tbb::blocked_range<Index>& range) {
        ForceBatch b;
        b.model = model;
        for (Index batch = range.begin(); batch != range.end(); ++batch) {
          const Index first = batch * kSvdLanes;
          const int lanes = static_cast<int>(std::min<Index>(kSvdLanes, ne - first));
          force_batch_gather(sources, first, lanes, b, level);
          force_batch_deform(b, level);
          if (plastic || model.stress == LaneStress::given) flow_and_stress(b, first, lanes);
          force_batch_forces(b, level);
          store(b, first, lanes);
        }
      });
  if (const int used = static_cast<int>(ne % kDampingLanes); used > 0) {
    DampingBlock& last = damping_blocks_.back();  // its lanes past the last element zero
    for (int lane = used; lane < kDampingLanes; ++lane) {
      for (int k = 0; k < 9; ++k) last.G[k][lane] = last.A[k][lane] = 0.0;
      last.scale[lane] = 0.0;
    }
  }
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
