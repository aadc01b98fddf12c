#pragma once
// A triangle surface mesh: the input of every simulation and its visible output.
#include "core/types.h"

namespace goo {

struct TriangleMesh {
  Points vertices;      ///< #V×3 positions, metres
  Triangles triangles;  ///< #T×3 vertex ids, counter-clockwise seen from outside

  [[nodiscard]] Index num_vertices() const { return static_cast<Index>(vertices.rows()); }
  [[nodiscard]] Index num_triangles() const { return static_cast<Index>(triangles.rows()); }
};

}  // namespace goo
