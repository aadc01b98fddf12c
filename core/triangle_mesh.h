#pragma once
// A triangle surface mesh: the input of every simulation and its visible output.
#include <array>

#include "core/types.h"

namespace goo {

struct TriangleMesh {
  Points vertices;      ///< #V×3 positions, metres
  Triangles triangles;  ///< #T×3 vertex ids, counter-clockwise seen from outside

  [[nodiscard]] Index num_vertices() const { return static_cast<Index>(vertices.rows()); }
  [[nodiscard]] Index num_triangles() const { return static_cast<Index>(triangles.rows()); }
  /// Triangle t's three corners, in its winding order.
  [[nodiscard]] std::array<Eigen::Vector3d, 3> corners(Index t) const {
    return {vertices.row(triangles(t, 0)).transpose(), vertices.row(triangles(t, 1)).transpose(),
            vertices.row(triangles(t, 2)).transpose()};
  }
};

}  // namespace goo
