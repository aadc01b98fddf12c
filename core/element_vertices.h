#pragma once
// Each element's embedded surface vertices, ascending: a counting sort of
// the vertices by their parent element (the surface collisions' index of
// the obstacles' candidates and the self-collision rounds' flags).
#include <vector>

#include "core/types.h"

namespace goo {

/// offsets (#E + 1) and vertices (#V): element e's vertices are
/// vertices[offsets[e] … offsets[e + 1] − 1], increasing.
inline void index_element_vertices(const std::vector<Index>& parent, Index num_elements, std::vector<Index>& offsets,
                                   std::vector<Index>& vertices) {
  offsets.assign(static_cast<std::size_t>(num_elements) + 1, 0);
  for (const Index e : parent) ++offsets[static_cast<std::size_t>(e) + 1];
  for (std::size_t e = 0; e + 1 < offsets.size(); ++e) offsets[e + 1] += offsets[e];
  vertices.resize(parent.size());
  std::vector<Index> fill(offsets.begin(), offsets.end() - 1);
  for (std::size_t v = 0; v < parent.size(); ++v)
    vertices[static_cast<std::size_t>(fill[static_cast<std::size_t>(parent[v])]++)] = static_cast<Index>(v);
}

}  // namespace goo
