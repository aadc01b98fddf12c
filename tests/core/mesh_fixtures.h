#pragma once
// Small meshes built in code, for checks whose answer is known by hand.
#include <cmath>
#include <numbers>

#include "core/triangle_mesh.h"

namespace goo::test {

inline TriangleMesh make_mesh(std::initializer_list<std::array<double, 3>> vertices,
                              std::initializer_list<std::array<Index, 3>> triangles) {
  TriangleMesh mesh;
  mesh.vertices.resize(static_cast<Eigen::Index>(vertices.size()), 3);
  mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  Eigen::Index i = 0;
  for (const auto& v : vertices) mesh.vertices.row(i++) << v[0], v[1], v[2];
  i = 0;
  for (const auto& t : triangles) mesh.triangles.row(i++) << t[0], t[1], t[2];
  return mesh;
}

/// The unit right tetrahedron (volume 1/6), outward oriented.
inline TriangleMesh unit_tetrahedron() {
  return make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}});
}

/// The regular octahedron with vertices at ±1 on each axis (volume 4/3),
/// outward oriented.
inline TriangleMesh octahedron() {
  return make_mesh({{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}},
                   {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}});
}

/// A closed, combinatorially non-orientable surface (Klein bottle) on an
/// n×m grid; vertex positions are generic so no triangle is degenerate.
inline TriangleMesh klein_bottle(int n, int m) {
  TriangleMesh mesh;
  mesh.vertices.resize(n * m, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      const double u = 2.0 * std::numbers::pi * i / n, v = 2.0 * std::numbers::pi * j / m;
      mesh.vertices.row(i * m + j) << (3.0 + std::cos(v)) * std::cos(u), (3.0 + std::cos(v)) * std::sin(u),
          std::sin(v) + 0.1 * i;
    }
  // Crossing i = n−1 → 0 reflects j: the identification of a Klein bottle.
  auto id = [&](int i, int j) {
    if (i == n) return static_cast<Index>(((m - j % m) % m));
    return static_cast<Index>(i * m + (j % m));
  };
  mesh.triangles.resize(2 * n * m, 3);
  Eigen::Index t = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < m; ++j) {
      mesh.triangles.row(t++) << id(i, j), id(i + 1, j), id(i + 1, j + 1);
      mesh.triangles.row(t++) << id(i, j), id(i + 1, j + 1), id(i, j + 1);
    }
  return mesh;
}

}  // namespace goo::test
