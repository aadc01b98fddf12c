#pragma once
// Adjacency of a closed triangle surface, built once per topology and
// reused by every per-vertex gather (surface tension, smoothing, upkeep).
#include <array>
#include <vector>

#include "core/types.h"

namespace goo {

struct SurfaceTopology {
  /// Triangle corners (3 t + k) at each vertex, increasing: gathers sum in
  /// this fixed order, so they are bitwise identical for any thread count.
  std::vector<Index> corner_offsets, corners;
  /// The triangle across edge k (from corner k to corner k + 1) of each
  /// triangle (triangles_across); −1 on a boundary or non-manifold edge.
  Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor> across;
  /// Each vertex's neighbours (vertices sharing an edge), increasing.
  std::vector<Index> neighbour_offsets, neighbours;

  static SurfaceTopology build(const Triangles& triangles, Index num_vertices);
  [[nodiscard]] Index num_vertices() const { return static_cast<Index>(corner_offsets.size()) - 1; }
};

/// Every side of every triangle as (min end, max end, triangle, corner k:
/// from corner k to corner k + 1), sorted by all four: the runs of equal
/// ends are the edges, each run's first side that of its lowest triangle.
/// Filled in parallel and radix sorted by edge (stable over the fill's
/// order): the same array for any thread count.
std::vector<std::array<Index, 4>> sorted_sides(const Triangles& triangles);

/// The triangle across edge k (from corner k to corner k + 1) of each
/// triangle, from sorted_sides: an edge met by exactly two triangles joins
/// them; −1 on an edge met once (a boundary) or more than twice (not
/// manifold, where no one neighbour is the right one).
Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor> triangles_across(const Triangles& triangles);

}  // namespace goo
