#include "core/damping.h"
#include "core/error.h"
#include "core/node_sums.h"
#include "core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <string>

namespace goo {

void Damping::freeze(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                     const std::vector<Eigen::Matrix3d>& Fp_inv) {
  const Index ne = body.num_elements();
  if (Fe.size() != at(ne) || Fp_inv.size() != at(ne))
    throw Error("damping: frozen with " + std::to_string(Fe.size()) + " deformations for a body of " +
                std::to_string(ne) + " elements");
  frozen_elements_ = at(ne);
  // Lanes past the last element stay zero (their forces are never read).
  own_blocks_.resize(at((ne + kDampingLanes - 1) / kDampingLanes));
  if (!own_blocks_.empty()) own_blocks_.back() = DampingBlock{};
  forces_blocks_ = nullptr;
  frozen_ = true;
  const double beta = body.material.viscosity;
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& range) {
    for (Index e = range.begin(); e != range.end(); ++e) {
      const Eigen::Matrix3d& Q = Fp_inv[at(e)];
      const Eigen::Matrix3d A = body.Dm_inv[at(e)] * Q;
      DampingBlock& block = own_blocks_[at(e / kDampingLanes)];
      const int lane = static_cast<int>(e % kDampingLanes);
      for (int k = 0; k < 9; ++k) {
        block.G[k][lane] = Fe[at(e)].data()[k];
        block.A[k][lane] = A.data()[k];
      }
      block.scale[lane] = 2.0 * beta * body.rest_volumes[e] / Q.determinant();  // 2β W det Fp
    }
  });
}

void Damping::freeze(const Body& body, const ElasticForces& forces) {
  if (forces.evaluated_elements() != body.num_elements())
    throw Error("damping: frozen from a force evaluation of " + std::to_string(forces.evaluated_elements()) +
                " elements for a body of " + std::to_string(body.num_elements()));
  frozen_elements_ = at(body.num_elements());
  forces_blocks_ = &forces.damping_blocks();
  frozen_ = true;
}

void Damping::check_frozen(const Body& body) const {
  const auto ne = at(body.num_elements());
  if (!frozen_ || frozen_blocks().size() != (ne + kDampingLanes - 1) / kDampingLanes || frozen_elements_ != ne)
    throw Error("damping: applied to a body it was not frozen for (Damping::freeze after every force evaluation)");
}

namespace {

/// A velocity field: a matrix of nodal velocities, as damping_gather reads it.
struct NodalVelocities {
  const Points& v;
  [[nodiscard]] DampingSources sources(const Tets& tets) const {
    DampingSources s;
    s.v = v.data();
    s.tets = tets.data();
    return s;
  }
};

/// z + β p entry by entry, as Eigen's z.row(n) + β p.row(n) rounds it
/// (damping_gather forms it as it reads the corners).
struct NextDirection {
  const Points& z;
  const Points& p;
  double beta;
  [[nodiscard]] DampingSources sources(const Tets& tets) const {
    DampingSources s;
    s.v = z.data();
    s.p = p.data();
    s.beta = beta;
    s.tets = tets.data();
    return s;
  }
};

}  // namespace

void Damping::apply(const Body& body, const Points& v, Points& out) {
  element_loop(body, NodalVelocities{v}, static_cast<const NodalVelocities*>(nullptr), false, tbb::auto_partitioner());
  const NodeIncidence& incidence = body.incidence;
  out.resize(static_cast<Index>(incidence.offsets.size() - 1), 3);
  sum_over_corners(
      incidence, Eigen::Vector3d::Zero().eval(),
      [&](Index corner) -> const Eigen::Vector3d& { return corner_forces_[at(corner)]; },
      [&](Index n, const Eigen::Vector3d& sum) { out.row(n) = sum.transpose(); });
}

void Damping::element_pass(const Body& body, const Points& v, bool corner_blocks) {
  element_loop(body, NodalVelocities{v}, static_cast<const NodalVelocities*>(nullptr), corner_blocks,
               tbb::static_partitioner());
}

void Damping::element_pass(const Body& body, const Points& v, const Points& w, bool corner_blocks) {
  const NodalVelocities second{w};
  element_loop(body, NodalVelocities{v}, &second, corner_blocks, tbb::static_partitioner());
}

void Damping::element_pass(const Body& body, const Points& z, const Points& p, double beta) {
  element_loop(body, NextDirection{z, p, beta}, static_cast<const NodalVelocities*>(nullptr), false,
               tbb::static_partitioner());
}

void Damping::store_corner_blocks(Index b, Index num_elements, SimdLevel level, DampingDiagonal& diagonal) {
  damping_diagonal(frozen_blocks()[at(b)], diagonal, level);
  const Index first = b * kDampingLanes;
  const int count = static_cast<int>(std::min<Index>(kDampingLanes, num_elements - first));
  for (int lane = 0; lane < count; ++lane) {
    auto& corners = element_blocks_[at(first + lane)];
    for (std::size_t k = 0; k < 4; ++k)
      for (int i = 0; i < 9; ++i) corners[k].data()[i] = diagonal.d[k][i][lane];
  }
}

template <class Partitioner, class Velocity, class Second>
void Damping::element_loop(const Body& body, const Velocity& velocity, const Second* second, bool corner_blocks,
                           const Partitioner& partitioner) {
  const Index ne = body.num_elements();
  check_frozen(body);
  const NodeIncidence& incidence = body.incidence;
  require_slots(incidence, ne, "damping");  // the node sums read corners 4e + k through it
  corner_forces_.resize(4 * at(ne));
  if (second != nullptr) second_corner_forces_.resize(4 * at(ne));
  if (corner_blocks) element_blocks_.resize(at(ne));
  const SimdLevel level = active_simd_level();
  const auto blocks = static_cast<Index>(frozen_blocks().size());
  tbb::parallel_for(
      tbb::blocked_range<Index>(0, blocks, kParallelGrain / kDampingLanes),
      [&](const tbb::blocked_range<Index>& range) {
        DampingLanes lanes{};
        DampingDiagonal diagonal;
        // One block's forces for the velocities x, into `out`.
        auto block_forces = [&](Index b, const auto& x, std::vector<Eigen::Vector3d>& out) {
          const Index first = b * kDampingLanes;
          const int count = static_cast<int>(std::min<Index>(kDampingLanes, ne - first));
          damping_gather(x.sources(body.tets), first, count, lanes, level);
          damping_block(frozen_blocks()[at(b)], lanes, level);
          // Each element's four side by side: the node sums read them
          // scattered. (Written at each node's place in the incidence,
          // the writes scattered instead, one application took 1.1–1.4×
          // as long on two threads: docs/benchmarks.md, session 27.)
          for (int lane = 0; lane < count; ++lane)
            for (int c = 0; c < 4; ++c) {
              Eigen::Vector3d& f = out[at(4 * (first + lane) + c)];
              for (int i = 0; i < 3; ++i) f[i] = lanes.f[c][i][lane];
            }
        };
        for (Index b = range.begin(); b != range.end(); ++b) {
          block_forces(b, velocity, corner_forces_);
          if (second != nullptr) block_forces(b, *second, second_corner_forces_);
          if (corner_blocks) store_corner_blocks(b, ne, level, diagonal);
        }
      },
      partitioner);
}

void Damping::apply(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                    const std::vector<Eigen::Matrix3d>& Fp_inv, const Points& v, Points& out) {
  freeze(body, Fe, Fp_inv);
  apply(body, v, out);
}

void Damping::diagonal_blocks(const Body& body, const std::vector<Eigen::Matrix3d>& Fe,
                              const std::vector<Eigen::Matrix3d>& Fp_inv, std::vector<Eigen::Matrix3d>& out) {
  freeze(body, Fe, Fp_inv);
  diagonal_blocks(body, out);
}

void Damping::diagonal_blocks(const Body& body, std::vector<Eigen::Matrix3d>& out) {
  const Index ne = body.num_elements();
  check_frozen(body);
  element_blocks_.resize(at(ne));
  // Ḟe = Σ_k v_k w_kᵀ with w_k = Fp⁻ᵀ g_k, the columns of Aᵀ (g_k node k's
  // shape-function gradient, rows of Dm⁻¹, g_0 = −Σ): apply's force on node
  // k is −2 W det(Fp) β Fe sym(Feᵀ Ḟe) w_k, whose derivative by v_k is
  // corner k's block, negated: β W det(Fp) (|w|² Fe Feᵀ + (Fe w)(Fe w)ᵀ).
  // Eight elements at a time from the frozen blocks, in the processor's
  // vector lanes (core/damping_batch.h; the same bits at every width).
  const SimdLevel level = active_simd_level();
  const auto blocks = static_cast<Index>(frozen_blocks().size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, blocks, kParallelGrain / kDampingLanes),
                    [&](const tbb::blocked_range<Index>& range) {
                      DampingDiagonal diagonal;
                      for (Index b = range.begin(); b != range.end(); ++b) store_corner_blocks(b, ne, level, diagonal);
                    });
  out.resize(body.incidence.offsets.size() - 1);
  for_each_index(static_cast<Index>(out.size()), [&](Index n) { out[at(n)] = node_block(body.incidence, n); });
}

double max_strain_rate(const Body& body, const Points& v) {
  return max_over_runs(body.num_elements(), 2048, [&](Index begin, Index end) {
    double rate = 0.0;
    for (Index e = begin; e < end; ++e) rate = std::max(rate, deformation_gradient(body, v, e).norm());
    return rate;
  });
}

}  // namespace goo
