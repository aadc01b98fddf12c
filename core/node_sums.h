#pragma once
// Node sums over the element corners that touch each node, in the
// incidence's fixed order (core/body.h, NodeIncidence): the one loop behind
// every gather of per-element values to nodes, so each is bitwise the same
// for any number of threads.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

#include "core/body.h"
#include "core/error.h"
#include "core/parallel.h"

namespace goo {

/// For every node n, in parallel: store(n, zero + value(i₁, c₁) + value(i₂, c₂)
/// + …) over its corners c = 4 e + k in increasing order, summed left to
/// right; i is the corner's place in the incidence (for values kept in
/// that order).
template <class T, class Value, class Store>
void sum_over_incidence(const NodeIncidence& incidence, const T& zero, Value&& value, Store&& store) {
  const auto num_nodes = static_cast<Index>(incidence.offsets.size() - 1);
  tbb::parallel_for(tbb::blocked_range<Index>(0, num_nodes, kParallelGrain),
                    [&](const tbb::blocked_range<Index>& range) {
                      for (Index n = range.begin(); n != range.end(); ++n) {
                        T sum = zero;
                        for (Index i = incidence.offsets[at(n)]; i < incidence.offsets[at(n) + 1]; ++i)
                          sum += value(i, incidence.corners[at(i)]);
                        store(n, sum);
                      }
                    });
}

/// For every node n, in parallel: store(n, zero + value(c₁) + value(c₂) + …)
/// over its corners c = 4 e + k in increasing order, summed left to right.
template <class T, class Value, class Store>
void sum_over_corners(const NodeIncidence& incidence, const T& zero, Value&& value, Store&& store) {
  sum_over_incidence(
      incidence, zero, [&](Index, Index corner) { return value(corner); }, store);
}

/// Throws unless the incidence's slots are those of `num_elements`
/// elements: a pass that writes at them must not write past its buffer.
inline void require_slots(const NodeIncidence& incidence, Index num_elements, const char* pass) {
  if (incidence.slots.size() != 4 * at(num_elements))
    throw Error(std::string(pass) + ": the body's node incidence is not that of its elements");
}

/// out.row(n) = 0 + values[i₁] + values[i₂] + … over node n's places i in
/// the incidence, in order: per-corner values that a pass over the elements
/// wrote at their places (NodeIncidence::slots), so each node reads its own
/// in sequence. Bit for bit the sums of gathering them corner by corner.
inline void sum_slots_to_nodes(const NodeIncidence& incidence, const std::vector<Eigen::Vector3d>& values,
                               Points& out) {
  out.resize(static_cast<Index>(incidence.offsets.size() - 1), 3);
  sum_over_incidence(
      incidence, Eigen::Vector3d::Zero().eval(), [&](Index slot, Index) { return values[at(slot)]; },
      [&](Index n, const Eigen::Vector3d& sum) { out.row(n) = sum.transpose(); });
}

}  // namespace goo
