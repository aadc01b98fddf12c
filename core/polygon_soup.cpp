#include "core/parallel.h"
#include "core/polygon_soup.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <unordered_map>

#include "core/surface_geometry.h"

namespace goo {
namespace {

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

/// p strictly inside or on the boundary of the counter-clockwise triangle abc.
bool in_triangle(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                 const Eigen::Vector2d& c) {
  return cross2(b - a, p - a) >= 0.0 && cross2(c - b, p - b) >= 0.0 && cross2(a - c, p - c) >= 0.0;
}

/// Maps each vertex to the lowest-index earlier vertex within `tol`, through
/// a hash grid of cell size tol (a partner lies in one of the 27 cells
/// around a vertex).
void weld_within_tolerance(const Points& vertices, const Eigen::AlignedBox3d& box, double tol,
                           std::vector<Index>& representative, Index& merged) {
  auto cell_of = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(static_cast<int>(std::floor((p.x() - box.min().x()) / tol)),
                           static_cast<int>(std::floor((p.y() - box.min().y()) / tol)),
                           static_cast<int>(std::floor((p.z() - box.min().z()) / tol)));
  };
  auto key_of = [](const Eigen::Vector3i& c) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x()) & 0x1fffffU) << 42) |
           (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.y()) & 0x1fffffU) << 21) |
           (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.z()) & 0x1fffffU));
  };
  std::unordered_map<std::uint64_t, std::vector<Index>> grid;
  grid.reserve(static_cast<std::size_t>(vertices.rows()));
  for (Index v = 0; v < static_cast<Index>(vertices.rows()); ++v) {
    const Eigen::Vector3d p = vertices.row(v);
    const Eigen::Vector3i c = cell_of(p);
    Index found = -1;
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find(key_of(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == grid.end()) continue;
          for (const Index w : it->second) {
            const Eigen::Vector3d q = vertices.row(w);
            if ((p - q).norm() <= tol && (found < 0 || w < found)) found = w;
          }
        }
    if (found >= 0) {
      representative[static_cast<std::size_t>(v)] = found;
      ++merged;
    } else {
      representative[static_cast<std::size_t>(v)] = v;
      grid[key_of(c)].push_back(v);
    }
  }
}

}  // namespace

void triangulate_polygon(std::span<const Index> polygon, const Points& vertices, std::vector<Eigen::Vector3i>& out) {
  const std::size_t n = polygon.size();
  if (n < 3) return;
  if (n == 3) {
    out.emplace_back(polygon[0], polygon[1], polygon[2]);
    return;
  }
  // Newell's normal: robust for non-planar and non-convex polygons.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = vertices.row(polygon[i]);
    const Eigen::Vector3d q = vertices.row(polygon[(i + 1) % n]);
    normal += p.cross(q);  // twice the area vector
  }
  // Project onto the plane that drops the normal's largest component, keeping
  // the polygon counter-clockwise in 2D.
  int drop = 0;
  normal.cwiseAbs().maxCoeff(&drop);
  const int u = (drop + 1) % 3, v = (drop + 2) % 3;
  const double sign = normal[drop] >= 0.0 ? 1.0 : -1.0;
  std::vector<Eigen::Vector2d> p2(n);
  for (std::size_t i = 0; i < n; ++i) p2[i] = {vertices(polygon[i], u), sign * vertices(polygon[i], v)};

  std::vector<std::size_t> ring(n);
  for (std::size_t i = 0; i < n; ++i) ring[i] = i;
  while (ring.size() > 3) {
    bool clipped = false;
    const std::size_t m = ring.size();
    for (std::size_t i = 0; i < m && !clipped; ++i) {
      const std::size_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
      if (cross2(p2[b] - p2[a], p2[c] - p2[b]) <= 0.0) continue;  // reflex or flat corner
      bool ear = true;
      for (const std::size_t j : ring) {
        if (j != a && j != b && j != c && in_triangle(p2[j], p2[a], p2[b], p2[c])) {
          ear = false;
          break;
        }
      }
      if (!ear) continue;
      out.emplace_back(polygon[a], polygon[b], polygon[c]);
      ring.erase(ring.begin() + static_cast<std::ptrdiff_t>(i));
      clipped = true;
    }
    if (!clipped) break;  // no ear: finish as a fan below
  }
  for (std::size_t i = 1; i + 1 < ring.size(); ++i)
    out.emplace_back(polygon[ring[0]], polygon[ring[i]], polygon[ring[i + 1]]);
}

Index remove_unreferenced_vertices(TriangleMesh& mesh, std::vector<Index>* new_ids) {
  std::vector<Index> local;
  std::vector<Index>& new_id = new_ids ? *new_ids : local;
  new_id.assign(at(mesh.num_vertices()), -1);
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) new_id[at(mesh.triangles(t, k))] = 0;
  Index kept = 0;
  for (auto& id : new_id)
    if (id == 0) id = kept++;
  const Index removed = mesh.num_vertices() - kept;
  if (removed == 0) return 0;
  Points compact(kept, 3);
  for (Index v = 0; v < mesh.num_vertices(); ++v)
    if (new_id[at(v)] >= 0) compact.row(new_id[at(v)]) = mesh.vertices.row(v);
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) mesh.triangles(t, k) = new_id[at(mesh.triangles(t, k))];
  mesh.vertices = std::move(compact);
  return removed;
}

WeldResult weld_vertices(TriangleMesh& mesh, double relative_tolerance) {
  WeldResult result;
  const Eigen::AlignedBox3d box = bounding_box(mesh.vertices);
  if (box.isEmpty()) return result;
  result.tolerance = relative_tolerance * box.diagonal().norm();
  const double tol = result.tolerance;
  std::vector<Index> representative(at(mesh.num_vertices()));
  if (tol <= 0.0) {
    // Exact duplicates only: key on the coordinates themselves.
    struct Hash {
      std::size_t operator()(const std::array<double, 3>& p) const {
        std::size_t h = 0;
        for (const double x : p) h = h * 0x9e3779b97f4a7c15ULL + std::hash<double>{}(x);
        return h;
      }
    };
    std::unordered_map<std::array<double, 3>, Index, Hash> first;
    first.reserve(at(mesh.num_vertices()));
    for (Index v = 0; v < mesh.num_vertices(); ++v) {
      const auto [it, inserted] = first.try_emplace({mesh.vertices(v, 0), mesh.vertices(v, 1), mesh.vertices(v, 2)}, v);
      representative[at(v)] = it->second;
      if (!inserted) ++result.merged;
    }
  } else {
    weld_within_tolerance(mesh.vertices, box, tol, representative, result.merged);
  }
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) mesh.triangles(t, k) = representative[at(mesh.triangles(t, k))];
  remove_unreferenced_vertices(mesh);
  return result;
}

}  // namespace goo
