#include "core/surface_topology.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>

#include "core/parallel.h"
#include "core/radix_sort.h"

namespace goo {

SurfaceTopology SurfaceTopology::build(const Triangles& triangles, Index num_vertices) {
  SurfaceTopology out;
  const auto nt = static_cast<Index>(triangles.rows());
  out.corner_offsets.assign(at(num_vertices) + 1, 0);
  for (Index t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) ++out.corner_offsets[at(triangles(t, k)) + 1];
  for (std::size_t v = 0; v + 1 < out.corner_offsets.size(); ++v) out.corner_offsets[v + 1] += out.corner_offsets[v];
  out.corners.resize(at(3 * nt));
  std::vector<Index> fill(out.corner_offsets.begin(), out.corner_offsets.end() - 1);
  for (Index t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) out.corners[at(fill[at(triangles(t, k))]++)] = 3 * t + k;

  out.across = triangles_across(triangles);

  out.neighbour_offsets.assign(at(num_vertices) + 1, 0);
  std::vector<Index> around;
  for (Index v = 0; v < num_vertices; ++v) {
    around.clear();
    for (Index c = out.corner_offsets[at(v)]; c < out.corner_offsets[at(v) + 1]; ++c) {
      const Index t = out.corners[at(c)] / 3, k = out.corners[at(c)] % 3;
      around.push_back(triangles(t, (k + 1) % 3));
      around.push_back(triangles(t, (k + 2) % 3));
    }
    std::sort(around.begin(), around.end());
    around.erase(std::unique(around.begin(), around.end()), around.end());
    out.neighbours.insert(out.neighbours.end(), around.begin(), around.end());
    out.neighbour_offsets[at(v) + 1] = static_cast<Index>(out.neighbours.size());
  }
  return out;
}

std::vector<std::array<Index, 4>> sorted_sides(const Triangles& triangles) {
  const auto nt = static_cast<Index>(triangles.rows());
  std::vector<std::array<Index, 4>> sides(at(nt) * 3);
  tbb::parallel_for(tbb::blocked_range<Index>(0, nt, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index t = r.begin(); t != r.end(); ++t)
      for (int k = 0; k < 3; ++k) {
        const Index a = triangles(t, k), b = triangles(t, (k + 1) % 3);
        sides[3 * at(t) + at(k)] = {std::min(a, b), std::max(a, b), t, k};
      }
  });
  radix_sort(sides, [](const std::array<Index, 4>& side) {
    return (static_cast<std::uint64_t>(side[0]) << 32) | static_cast<std::uint64_t>(side[1]);
  });
  return sides;
}

Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor> triangles_across(const Triangles& triangles) {
  Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor> across =
      Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor>::Constant(triangles.rows(), 3, -1);
  const std::vector<std::array<Index, 4>> sides = sorted_sides(triangles);
  for (std::size_t i = 0; i < sides.size();) {
    std::size_t j = i + 1;
    while (j < sides.size() && sides[j][0] == sides[i][0] && sides[j][1] == sides[i][1]) ++j;
    if (j == i + 2) {
      across(sides[i][2], sides[i][3]) = sides[i + 1][2];
      across(sides[i + 1][2], sides[i + 1][3]) = sides[i][2];
    }
    i = j;
  }
  return across;
}

}  // namespace goo
