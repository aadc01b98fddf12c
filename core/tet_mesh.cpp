#include "core/tet_mesh.h"

#include <algorithm>
#include <array>
#include <vector>

#include <fmt/format.h>
#include <tbb/parallel_sort.h>

#include <array>
#include <limits>

#include "core/error.h"

namespace goo {

double signed_volume(const Points& x, const Tets& tets, Index e) {
  const Eigen::Vector3d x0 = x.row(tets(e, 0));
  Eigen::Matrix3d D;
  for (int k = 0; k < 3; ++k) D.col(k) = x.row(tets(e, k + 1)).transpose() - x0;
  return D.determinant() / 6.0;
}

TetMesh make_box_tets(const Eigen::Vector3d& size, const Eigen::Vector3i& cells, const Eigen::Vector3d& origin) {
  if (!(cells.array() >= 1).all()) {
    throw Error(
        fmt::format("box tets: cells must be at least 1 per axis, got ({}, {}, {})", cells.x(), cells.y(), cells.z()));
  }
  if (!(size.array() > 0.0).all() || !size.allFinite()) {
    throw Error(fmt::format("box tets: size must be positive, got ({}, {}, {})", size.x(), size.y(), size.z()));
  }
  const Eigen::Vector3i n = cells.array() + 1;
  TetMesh mesh;
  mesh.positions.resize(n.prod(), 3);
  auto id = [&](int i, int j, int k) { return static_cast<Index>(i + n.x() * (j + n.y() * k)); };
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i) {
        const Eigen::Vector3d t(static_cast<double>(i) / cells.x(), static_cast<double>(j) / cells.y(),
                                static_cast<double>(k) / cells.z());
        mesh.positions.row(id(i, j, k)) = (origin + size.cwiseProduct(t)).transpose();
      }
  // Kuhn: one tetrahedron per path 0 → e_a → e_a + e_b → (1,1,1) along the
  // permutations (a, b, c) of the axes; odd permutations are mirrored, so
  // their middle nodes are swapped to keep every element positive.
  const std::array<std::array<int, 3>, 6> permutations = {
      {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}}};
  mesh.tets.resize(6 * cells.prod(), 4);
  Index e = 0;
  for (int k = 0; k < cells.z(); ++k)
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i)
        for (std::size_t p = 0; p < permutations.size(); ++p) {
          Eigen::Vector3i corner(i, j, k);
          std::array<Index, 4> nodes{};
          nodes[0] = id(corner.x(), corner.y(), corner.z());
          for (int step = 0; step < 3; ++step) {
            corner[permutations[p][static_cast<std::size_t>(step)]] += 1;
            nodes[static_cast<std::size_t>(step + 1)] = id(corner.x(), corner.y(), corner.z());
          }
          if (p >= 3) std::swap(nodes[1], nodes[2]);
          mesh.tets.row(e++) << nodes[0], nodes[1], nodes[2], nodes[3];
        }
  return mesh;
}

Index check_and_orient(TetMesh& mesh, std::string_view source) {
  for (Index v = 0; v < mesh.num_nodes(); ++v) {
    if (!mesh.positions.row(v).allFinite()) {
      throw Error(fmt::format("{}: node {} has a non-finite coordinate", source, v));
    }
  }
  if (mesh.num_elements() == 0) throw Error(fmt::format("{}: the mesh has no tetrahedra", source));
  Index reoriented = 0;
  for (Index e = 0; e < mesh.num_elements(); ++e) {
    for (int k = 0; k < 4; ++k) {
      const Index v = mesh.tets(e, k);
      if (v < 0 || v >= mesh.num_nodes()) {
        throw Error(fmt::format("{}: tetrahedron {} references node {}, but the mesh has {} nodes", source, e, v,
                                mesh.num_nodes()));
      }
      for (int l = 0; l < k; ++l)
        if (mesh.tets(e, l) == v) throw Error(fmt::format("{}: tetrahedron {} repeats node {}", source, e, v));
    }
    const double volume = signed_volume(mesh.positions, mesh.tets, e);
    // A zero volume to round-off: |det| below a few ε times the product of
    // the edge lengths that span it.
    double scale = 1.0;
    for (int k = 1; k < 4; ++k)
      scale *= (mesh.positions.row(mesh.tets(e, k)) - mesh.positions.row(mesh.tets(e, 0))).norm();
    if (std::abs(volume) <= 8.0 * std::numeric_limits<double>::epsilon() * scale / 6.0) {
      throw Error(fmt::format("{}: tetrahedron {} has zero volume", source, e));
    }
    if (volume < 0.0) {
      std::swap(mesh.tets(e, 1), mesh.tets(e, 2));
      ++reoriented;
    }
  }
  return reoriented;
}

Tets face_neighbours(const Tets& tets) {
  const auto ne = static_cast<Index>(tets.rows());
  Tets out = Tets::Constant(ne, 4, -1);
  // Faces as sorted node triples; a face met twice joins its two elements.
  std::vector<std::pair<std::array<Index, 3>, Index>> faces;
  faces.reserve(static_cast<std::size_t>(4 * ne));
  for (Index e = 0; e < ne; ++e)
    for (int k = 0; k < 4; ++k) {
      std::array<Index, 3> f{};
      for (int j = 0, i = 0; j < 4; ++j)
        if (j != k) f[static_cast<std::size_t>(i++)] = tets(e, j);
      std::sort(f.begin(), f.end());
      faces.emplace_back(f, 4 * e + k);
    }
  // Keys are distinct (4 e + k), so the order is the same for any thread count.
  tbb::parallel_sort(faces.begin(), faces.end());
  for (std::size_t i = 0; i + 1 < faces.size(); ++i)
    if (faces[i].first == faces[i + 1].first) {
      const Index a = faces[i].second, b = faces[i + 1].second;
      out(a / 4, a % 4) = b / 4;
      out(b / 4, b % 4) = a / 4;
    }
  return out;
}

}  // namespace goo
