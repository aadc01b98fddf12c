#include "core/parallel.h"
#include "core/surface_check.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/error.h"
#include "core/log.h"
#include "core/surface_geometry.h"
#include "core/union_find.h"

namespace goo {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// One directed edge of a triangle: from corner k to corner k+1 of triangle t.
struct HalfEdge {
  std::uint64_t key;  // (min vertex << 32) | max vertex
  Index triangle;
  std::int8_t corner;
  bool ascending;  // goes from the smaller to the larger vertex id
};

std::optional<std::string> check_coordinates_and_indices(const TriangleMesh& mesh) {
  for (Index v = 0; v < mesh.num_vertices(); ++v) {
    if (!mesh.vertices.row(v).allFinite()) {
      return fmt::format("vertex {} has a non-finite coordinate ({}, {}, {})", v, mesh.vertices(v, 0),
                         mesh.vertices(v, 1), mesh.vertices(v, 2));
    }
  }
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const Index v = mesh.triangles(t, k);
      if (v < 0 || v >= mesh.num_vertices()) {
        return fmt::format("triangle {} references vertex {}, but the mesh has {} vertices", t, v, mesh.num_vertices());
      }
    }
  }
  if (mesh.num_triangles() == 0) return std::string("the mesh has no triangles");
  return std::nullopt;
}

std::optional<std::string> check_degenerate(const TriangleMesh& mesh) {
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    const Index a = mesh.triangles(t, 0), b = mesh.triangles(t, 1), c = mesh.triangles(t, 2);
    if (a == b || b == c || a == c) {
      return fmt::format("triangle {} has a repeated vertex ({}, {}, {})", t, a, b, c);
    }
    const Eigen::Vector3d e1 = mesh.vertices.row(b) - mesh.vertices.row(a);
    const Eigen::Vector3d e2 = mesh.vertices.row(c) - mesh.vertices.row(a);
    // The computed cross product carries a rounding error of a few ε|e1||e2|;
    // a triangle whose |e1 × e2| is below that has no area we can resolve.
    if (e1.cross(e2).norm() <= 8.0 * kEps * e1.norm() * e2.norm()) {
      return fmt::format("triangle {} has zero area (vertices {}, {}, {} are coincident or collinear)", t, a, b, c);
    }
  }
  return std::nullopt;
}

std::vector<HalfEdge> sorted_half_edges(const TriangleMesh& mesh) {
  std::vector<HalfEdge> half_edges;
  half_edges.reserve(at(mesh.num_triangles()) * 3);
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::uint32_t>(mesh.triangles(t, k));
      const auto b = static_cast<std::uint32_t>(mesh.triangles(t, (k + 1) % 3));
      const std::uint64_t key = (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
      half_edges.push_back({key, t, static_cast<std::int8_t>(k), a < b});
    }
  }
  std::sort(half_edges.begin(), half_edges.end(), [](const HalfEdge& x, const HalfEdge& y) {
    return x.key != y.key ? x.key < y.key : (x.triangle != y.triangle ? x.triangle < y.triangle : x.corner < y.corner);
  });
  return half_edges;
}

std::string edge_name(std::uint64_t key) {
  return fmt::format("({}, {})", key >> 32, key & 0xffffffffU);
}

/// Topology of a mesh whose indices are valid: edges, components, fans and
/// orientation. Fills the counts of `report` and returns the first defect.
std::optional<std::string> analyze_topology(const TriangleMesh& mesh, SurfaceReport& report) {
  const Index nt = mesh.num_triangles();
  const std::vector<HalfEdge> half_edges = sorted_half_edges(mesh);

  UnionFind components(nt);
  UnionFind fans(3 * nt);  // corners (3t + k) joined across manifold edges
  // Neighbours across manifold edges, and whether crossing keeps orientation.
  std::vector<std::vector<std::pair<Index, bool>>> neighbours(at(nt));
  std::optional<std::string> boundary_defect;
  std::optional<std::string> nonmanifold_defect;

  for (std::size_t i = 0; i < half_edges.size();) {
    std::size_t j = i;
    while (j < half_edges.size() && half_edges[j].key == half_edges[i].key) ++j;
    const std::size_t count = j - i;
    ++report.num_edges;
    for (std::size_t k = i + 1; k < j; ++k) components.unite(half_edges[i].triangle, half_edges[k].triangle);
    if (count == 1) {
      if (report.boundary_edges++ == 0) {
        boundary_defect = fmt::format("edge {} belongs to triangle {} only: the surface is not closed",
                                      edge_name(half_edges[i].key), half_edges[i].triangle);
      }
    } else if (count > 2) {
      if (report.nonmanifold_edges++ == 0) {
        std::string list;
        for (std::size_t k = i; k < j; ++k) list += fmt::format("{}{}", k == i ? "" : ", ", half_edges[k].triangle);
        nonmanifold_defect = fmt::format("edge {} is shared by {} triangles ({}): the surface is not edge-manifold",
                                         edge_name(half_edges[i].key), count, list);
      }
    } else {
      const HalfEdge& h = half_edges[i];
      const HalfEdge& g = half_edges[i + 1];
      // Consistent orientation: the two triangles traverse the edge in
      // opposite directions.
      const bool consistent = h.ascending != g.ascending;
      neighbours[at(h.triangle)].emplace_back(g.triangle, consistent);
      neighbours[at(g.triangle)].emplace_back(h.triangle, consistent);
      // Join the corners at each shared vertex: corners of one vertex that
      // end up in one set form one fan.
      for (int end = 0; end < 2; ++end) {
        const Index vertex = mesh.triangles(h.triangle, (h.corner + end) % 3);
        Index corner_g = -1;
        for (int k = 0; k < 3; ++k)
          if (mesh.triangles(g.triangle, k) == vertex) corner_g = 3 * g.triangle + k;
        fans.unite(3 * h.triangle + (h.corner + end) % 3, corner_g);
      }
    }
    i = j;
  }

  // Fans per vertex: a manifold vertex has one.
  std::vector<Index> first_fan(at(mesh.num_vertices()), -1);
  std::vector<bool> counted(at(mesh.num_vertices()), false);
  for (Index c = 0; c < 3 * nt; ++c) {
    const Index v = mesh.triangles(c / 3, c % 3);
    const Index root = fans.find(c);
    if (first_fan[at(v)] < 0) {
      first_fan[at(v)] = root;
    } else if (first_fan[at(v)] != root && !counted[at(v)]) {
      counted[at(v)] = true;
      ++report.nonmanifold_vertices;
    }
  }

  // Orientation: propagate from the lowest triangle of each component.
  std::vector<std::int8_t> flipped(at(nt), -1);
  std::optional<std::string> orientation_defect;
  Index first_misoriented = nt;
  std::vector<Index> queue;
  for (Index seed = 0; seed < nt; ++seed) {
    if (flipped[at(seed)] >= 0) continue;
    ++report.components;
    std::vector<Index> members;
    flipped[at(seed)] = 0;
    queue.assign(1, seed);
    Index flipped_count = 0;
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const Index t = queue[q];
      members.push_back(t);
      flipped_count += flipped[at(t)];
      for (const auto& [n, consistent] : neighbours[at(t)]) {
        const auto want = static_cast<std::int8_t>(consistent ? flipped[at(t)] : 1 - flipped[at(t)]);
        if (flipped[at(n)] < 0) {
          flipped[at(n)] = want;
          queue.push_back(n);
        } else if (flipped[at(n)] != want && report.orientable) {
          report.orientable = false;
          orientation_defect = fmt::format(
              "the surface is not orientable (around triangles {} and {}): no consistent inside and outside", t, n);
        }
      }
    }
    const auto size = static_cast<Index>(members.size());
    const std::int8_t minority = (2 * flipped_count > size) ? 0 : 1;
    const Index minority_count = minority == 1 ? flipped_count : size - flipped_count;
    report.misoriented_triangles += minority_count;
    for (const Index t : members) {
      if (flipped[at(t)] == minority && minority_count > 0) first_misoriented = std::min(first_misoriented, t);
    }
  }
  if (!orientation_defect && first_misoriented < nt) {
    orientation_defect = fmt::format(
        "triangle {} is flipped: its orientation disagrees with its neighbours' ({} of {} triangles disagree "
        "with the rest of their component)",
        first_misoriented, report.misoriented_triangles, nt);
  }

  if (boundary_defect) {
    return fmt::format("{} ({} boundary edges)", *boundary_defect, report.boundary_edges);
  }
  if (nonmanifold_defect) return nonmanifold_defect;
  return orientation_defect;
}

}  // namespace

SurfaceReport analyze_surface(const TriangleMesh& mesh) {
  SurfaceReport report;
  report.num_vertices = mesh.num_vertices();
  report.num_triangles = mesh.num_triangles();
  report.bounds = bounding_box(mesh.vertices);

  report.first_defect = check_coordinates_and_indices(mesh);
  if (report.first_defect) return report;

  const SurfaceIntegrals integrals = surface_integrals(mesh);
  report.area = integrals.area;
  report.volume = integrals.volume;
  report.centroid = integrals.centroid;
  report.topology_valid = true;

  const std::optional<std::string> degenerate = check_degenerate(mesh);
  const std::optional<std::string> topology = analyze_topology(mesh, report);
  report.first_defect = degenerate ? degenerate : topology;
  if (report.first_defect) return report;

  // Round-off bound of the signed volume: each tetrahedron's determinant has
  // a relative error of a few ε, so |V| below that, relative to Σ|V_t|, is zero.
  CompensatedSum absolute;
  const Eigen::Vector3d r = report.bounds.center();
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    auto [a, b, c] = mesh.corners(t);
    a -= r;
    b -= r;
    c -= r;
    absolute.add(std::abs(a.dot(b.cross(c))) / 6.0);
  }
  if (std::abs(report.volume) <= 16.0 * kEps * absolute.value()) {
    report.first_defect = fmt::format("the surface encloses no volume (signed volume {:.3g} m³)", report.volume);
  }
  return report;
}

void flip_orientation(TriangleMesh& mesh) {
  mesh.triangles.col(1).swap(mesh.triangles.col(2));
}

SurfaceReport validate_surface(TriangleMesh& mesh, std::string_view source) {
  SurfaceReport report = analyze_surface(mesh);
  if (report.first_defect) throw Error(fmt::format("{}: {}", source, *report.first_defect));
  if (report.volume < 0.0) {
    log().warn("{}: the surface is inside-out (volume {:.6g} m³); flipping every triangle", source, report.volume);
    flip_orientation(mesh);
    report.volume = -report.volume;
  }
  return report;
}

}  // namespace goo
