#include "core/primitives.h"

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <unordered_map>
#include <vector>

#include "core/error.h"
#include "core/polygon_soup.h"

namespace goo {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

/// Collects vertices and triangles, then packs them into a TriangleMesh.
struct Builder {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;

  Index add(const Eigen::Vector3d& p) {
    vertices.push_back(p);
    return static_cast<Index>(vertices.size() - 1);
  }
  /// Quad a-b-c-d, counter-clockwise seen from outside.
  void quad(Index a, Index b, Index c, Index d) {
    triangles.emplace_back(a, b, c);
    triangles.emplace_back(a, c, d);
  }
  TriangleMesh finish() const {
    TriangleMesh mesh;
    mesh.vertices.resize(static_cast<Eigen::Index>(vertices.size()), 3);
    mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
    for (std::size_t i = 0; i < vertices.size(); ++i)
      mesh.vertices.row(static_cast<Eigen::Index>(i)) = vertices[i].transpose();
    for (std::size_t i = 0; i < triangles.size(); ++i)
      mesh.triangles.row(static_cast<Eigen::Index>(i)) = triangles[i].transpose();
    return mesh;
  }
};

void require(bool ok, const std::string& what) {
  if (!ok) throw Error(what);
}

/// Rings of `count` vertices around z; ring r gets the vertex ids
/// first[r] + j. Joins consecutive rings with outward quads.
void join_rings(Builder& b, Index ring0, Index ring1, int count) {
  for (int j = 0; j < count; ++j) {
    const int k = (j + 1) % count;
    b.quad(ring0 + j, ring0 + k, ring1 + k, ring1 + j);
  }
}

}  // namespace

TriangleMesh make_box(const Eigen::Vector3d& size, int subdivisions) {
  require(subdivisions >= 1, fmt::format("box: subdivisions must be at least 1, got {}", subdivisions));
  require((size.array() > 0.0).all() && size.allFinite(),
          fmt::format("box: side lengths must be positive, got ({}, {}, {})", size.x(), size.y(), size.z()));
  Builder b;
  const int n = subdivisions;
  const Eigen::Vector3d half = 0.5 * size;
  // Each face: outward axis `axis` with sign `s`; (u, v) span it so that
  // u × v points outward.
  for (int axis = 0; axis < 3; ++axis) {
    for (const double s : {-1.0, 1.0}) {
      const int u = (axis + (s > 0 ? 1 : 2)) % 3;
      const int v = (axis + (s > 0 ? 2 : 1)) % 3;
      std::vector<Index> grid(static_cast<std::size_t>((n + 1) * (n + 1)));
      for (int i = 0; i <= n; ++i)
        for (int j = 0; j <= n; ++j) {
          Eigen::Vector3d p;
          p[axis] = s * half[axis];
          // The last grid line is the opposite face's plane exactly:
          // −h + (2h·n)/n can differ from h in the last bit (h = 0.05, n = 3).
          p[u] = i == n ? half[u] : -half[u] + size[u] * i / n;
          p[v] = j == n ? half[v] : -half[v] + size[v] * j / n;
          grid[static_cast<std::size_t>(i * (n + 1) + j)] = b.add(p);
        }
      auto id = [&](int i, int j) { return grid[static_cast<std::size_t>(i * (n + 1) + j)]; };
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) b.quad(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
    }
  }
  // Faces share their border vertices, computed by identical expressions:
  // weld the exact duplicates.
  TriangleMesh mesh = b.finish();
  weld_vertices(mesh, 0.0);
  return mesh;
}

TriangleMesh make_sphere(double radius, int segments) {
  require(radius > 0.0 && std::isfinite(radius), fmt::format("sphere: radius must be positive, got {}", radius));
  require(segments >= 3, fmt::format("sphere: segments must be at least 3, got {}", segments));
  const int bands = std::max(2, segments / 2);
  Builder b;
  const Index south = b.add({0.0, 0.0, -radius});
  std::vector<Index> ring_start;
  for (int r = 1; r < bands; ++r) {
    const double theta = std::numbers::pi * r / bands;  // from the south pole
    ring_start.push_back(static_cast<Index>(b.vertices.size()));
    for (int j = 0; j < segments; ++j) {
      const double phi = kTwoPi * j / segments;
      b.add({radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi),
             -radius * std::cos(theta)});
    }
  }
  const Index north = b.add({0.0, 0.0, radius});
  for (int j = 0; j < segments; ++j) {
    const int k = (j + 1) % segments;
    b.triangles.emplace_back(south, ring_start.front() + k, ring_start.front() + j);
    b.triangles.emplace_back(north, ring_start.back() + j, ring_start.back() + k);
  }
  for (std::size_t r = 0; r + 1 < ring_start.size(); ++r) join_rings(b, ring_start[r], ring_start[r + 1], segments);
  return b.finish();
}

TriangleMesh make_cylinder(double radius, double height, int segments) {
  require(radius > 0.0 && std::isfinite(radius), fmt::format("cylinder: radius must be positive, got {}", radius));
  require(height > 0.0 && std::isfinite(height), fmt::format("cylinder: height must be positive, got {}", height));
  require(segments >= 3, fmt::format("cylinder: segments must be at least 3, got {}", segments));
  const double edge = 2.0 * radius * std::sin(std::numbers::pi / segments);
  const int bands = std::max(1, static_cast<int>(std::lround(height / edge)));
  Builder b;
  std::vector<Index> ring_start;
  for (int r = 0; r <= bands; ++r) {
    ring_start.push_back(static_cast<Index>(b.vertices.size()));
    const double z = -0.5 * height + height * r / bands;
    for (int j = 0; j < segments; ++j) {
      const double phi = kTwoPi * j / segments;
      b.add({radius * std::cos(phi), radius * std::sin(phi), z});
    }
  }
  for (std::size_t r = 0; r + 1 < ring_start.size(); ++r) join_rings(b, ring_start[r], ring_start[r + 1], segments);
  const Index bottom = b.add({0.0, 0.0, -0.5 * height});
  const Index top = b.add({0.0, 0.0, 0.5 * height});
  for (int j = 0; j < segments; ++j) {
    const int k = (j + 1) % segments;
    b.triangles.emplace_back(bottom, ring_start.front() + k, ring_start.front() + j);
    b.triangles.emplace_back(top, ring_start.back() + j, ring_start.back() + k);
  }
  return b.finish();
}

TriangleMesh make_torus(double major, double minor, int major_segments, int minor_segments) {
  require(minor > 0.0 && major > minor && std::isfinite(major),
          fmt::format("torus: need 0 < minor < major, got major {} and minor {}", major, minor));
  require(major_segments >= 3 && minor_segments >= 3,
          fmt::format("torus: segments must be at least 3, got {} and {}", major_segments, minor_segments));
  Builder b;
  for (int i = 0; i < major_segments; ++i) {
    const double phi = kTwoPi * i / major_segments;
    for (int j = 0; j < minor_segments; ++j) {
      const double theta = kTwoPi * j / minor_segments;
      const double rho = major + minor * std::cos(theta);
      b.add({rho * std::cos(phi), rho * std::sin(phi), minor * std::sin(theta)});
    }
  }
  auto id = [&](int i, int j) {
    return static_cast<Index>((i % major_segments) * minor_segments + (j % minor_segments));
  };
  for (int i = 0; i < major_segments; ++i)
    for (int j = 0; j < minor_segments; ++j) b.quad(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
  return b.finish();
}

TriangleMesh split_into_four(const TriangleMesh& mesh, int times) {
  if (times < 0) throw Error(fmt::format("split_into_four: times must be at least 0, got {}", times));
  TriangleMesh out = mesh;
  for (int pass = 0; pass < times; ++pass) {
    const Index nv = out.num_vertices(), nt = out.num_triangles();
    std::unordered_map<std::uint64_t, Index> midpoint;
    midpoint.reserve(static_cast<std::size_t>(3 * nt / 2 + 1));
    std::vector<Eigen::RowVector3d> added;
    auto mid = [&](Index a, Index b) {
      const auto lo = static_cast<std::uint64_t>(std::min(a, b)), hi = static_cast<std::uint64_t>(std::max(a, b));
      const auto [it, inserted] = midpoint.try_emplace((lo << 32) | hi, nv + static_cast<Index>(added.size()));
      if (inserted) added.push_back(0.5 * (out.vertices.row(a) + out.vertices.row(b)));
      return it->second;
    };
    Triangles triangles(4 * nt, 3);
    for (Index t = 0; t < nt; ++t) {
      const Index a = out.triangles(t, 0), b = out.triangles(t, 1), c = out.triangles(t, 2);
      const Index ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      triangles.row(4 * t) << a, ab, ca;
      triangles.row(4 * t + 1) << ab, b, bc;
      triangles.row(4 * t + 2) << ca, bc, c;
      triangles.row(4 * t + 3) << ab, bc, ca;
    }
    Points vertices(nv + static_cast<Index>(added.size()), 3);
    vertices.topRows(nv) = out.vertices;
    for (std::size_t i = 0; i < added.size(); ++i) vertices.row(nv + static_cast<Index>(i)) = added[i];
    out.vertices = std::move(vertices);
    out.triangles = std::move(triangles);
  }
  return out;
}

}  // namespace goo
