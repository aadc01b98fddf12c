#include "meshing/exact_mass.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/error.h"
#include "core/parallel.h"
#include "meshing/convex_clip.h"
#include "meshing/lattice_slicing.h"

namespace goo {
namespace {

std::array<Eigen::Vector3d, 4> element_positions(const TetMesh& mesh, Index e) {
  return {mesh.positions.row(mesh.tets(e, 0)).transpose(), mesh.positions.row(mesh.tets(e, 1)).transpose(),
          mesh.positions.row(mesh.tets(e, 2)).transpose(), mesh.positions.row(mesh.tets(e, 3)).transpose()};
}

/// A surface part's integrals in its element.
struct PartIntegrals {
  Index element, triangle;
  ConeIntegrals integrals;
};

}  // namespace

/// For each node, the least distance to the plane of a surface triangle
/// whose bounding box holds the node: 0 where the surface passes through it.
/// A minimum does not depend on the order it is taken in: the same for any
/// number of threads.
std::vector<double> node_surface_distances(const LatticeMesh& lm, const TriangleMesh& surface) {
  const BccLattice& lattice = lm.lattice;
  std::vector<std::atomic<std::uint64_t>> nearest(at(lm.mesh.num_nodes()));
  // The bits of a non-negative double order as the double does.
  for (auto& d : nearest) d.store(std::bit_cast<std::uint64_t>(std::numeric_limits<double>::infinity()));
  const Eigen::Vector3d slack = Eigen::Vector3d::Constant(1e-9 * lattice.spacing());
  tbb::parallel_for(tbb::blocked_range<Index>(0, surface.num_triangles(), kParallelGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      for (Index t = r.begin(); t != r.end(); ++t) {
                        const auto [a, b, c] = surface.corners(t);
                        const Eigen::Vector3d n = (b - a).cross(c - a);
                        if (n.squaredNorm() == 0.0) continue;
                        const Eigen::Vector3d unit = n.normalized();
                        lattice.for_each_node_in(a.cwiseMin(b).cwiseMin(c) - slack, a.cwiseMax(b).cwiseMax(c) + slack,
                                                 [&](BccLattice::Key key) {
                                                   const Index node = lm.node(key);
                                                   if (node < 0) return;
                                                   const std::uint64_t d = std::bit_cast<std::uint64_t>(
                                                       std::abs(unit.dot(lattice.position(key) - a)));
                                                   std::atomic<std::uint64_t>& slot = nearest[at(node)];
                                                   std::uint64_t seen = slot.load(std::memory_order_relaxed);
                                                   while (d < seen && !slot.compare_exchange_weak(seen, d)) {
                                                   }
                                                 });
                      }
                    });
  std::vector<double> out(nearest.size());
  for (std::size_t n = 0; n < out.size(); ++n) out[n] = std::bit_cast<double>(nearest[n].load());
  return out;
}

/// The apex of each element: the vertex farthest from the surface's planes
/// (so never on the surface), the first on a tie.
std::vector<std::uint8_t> element_apexes(const TetMesh& mesh, const std::vector<double>& distance) {
  std::vector<std::uint8_t> out(at(mesh.num_elements()), 0);
  for (Index e = 0; e < mesh.num_elements(); ++e)
    for (int k = 1; k < 4; ++k)
      if (distance[at(mesh.tets(e, k))] > distance[at(mesh.tets(e, out[at(e)]))]) out[at(e)] = static_cast<std::uint8_t>(k);
  return out;
}

ConeIntegrals part_integrals(const std::array<Eigen::Vector3d, 4>& x, int apex, const Polygon& piece) {
  const Eigen::Vector3d& p = x[static_cast<std::size_t>(apex)];
  // tet_planes(x)[apex], alone.
  const auto& face = kTetFaces[apex];
  const Eigen::Vector3d& a = x[static_cast<std::size_t>(face[0])];
  const Eigen::Vector3d normal =
      (x[static_cast<std::size_t>(face[1])] - a).cross(x[static_cast<std::size_t>(face[2])] - a).normalized();
  const Plane opposite{normal, normal.dot(a)};
  const double height = -opposite.distance(p);
  ConeIntegrals integrals;
  integrals.add_cone(p, piece);
  // The piece's shadow on the opposite face, seen from p.
  Polygon shadow = piece;
  for (int i = 0; i < shadow.size; ++i) {
    const Eigen::Vector3d y = piece.v[static_cast<std::size_t>(i)] - p;
    const double along = y.dot(opposite.normal);
    shadow.v[static_cast<std::size_t>(i)] = along > 1e-300 ? Eigen::Vector3d(p + y * (height / along)) : p;
  }
  integrals.add_cone(p, shadow, -1.0);
  return integrals;
}

SurfacePieces slice_surface(const LatticeMesh& lm, const TriangleMesh& surface) {
  const TetMesh& mesh = lm.mesh;
  const Index ne = mesh.num_elements();
  if (static_cast<Index>(lm.node_inside.size()) != mesh.num_nodes())
    throw Error("slice_surface: the lattice mesh has no inside flags for its nodes");
  SurfacePieces out;
  out.apex = element_apexes(mesh, node_surface_distances(lm, surface));
  // Each triangle sliced along the lattice's planes (lattice_slicing.h) into
  // its parts in each element, and each part's integrals taken at once, per
  // chunk of triangles in parallel; then counted into per-element lists.
  constexpr std::size_t kChunk = 256;
  const auto num_triangles = static_cast<std::size_t>(surface.num_triangles());
  std::vector<std::vector<PartIntegrals>> chunks((num_triangles + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t chunk) {
    thread_local LatticeSlicer slicer;  // scratch only: the parts do not depend on the thread
    thread_local std::vector<PolygonPart> parts;
    auto& found = chunks[chunk];
    found.reserve(2 * kChunk);
    for (std::size_t index = chunk * kChunk; index < std::min(num_triangles, (chunk + 1) * kChunk); ++index) {
      const auto t = static_cast<Index>(index);
      Polygon triangle;
      for (int k = 0; k < 3; ++k) triangle.push(surface.vertices.row(surface.triangles(t, k)).transpose());
      const Eigen::Vector3d n = (triangle.v[1] - triangle.v[0]).cross(triangle.v[2] - triangle.v[0]);
      if (n.squaredNorm() == 0.0) continue;  // a degenerate triangle bounds no volume
      slicer.polygon_parts(lm.lattice, triangle, 1e-12, parts);
      // Every surface part lies in a kept element (a kept element is one an
      // inside node or a triangle reaches); a part of round-off size may not.
      for (const PolygonPart& part : parts)
        if (const Index e = lm.element(part.key); e >= 0)
          found.push_back({e, t, part_integrals(element_positions(mesh, e), out.apex[at(e)], part.polygon)});
    }
  });
  // Counting sort by element; chunks in order keep triangles increasing.
  out.first.assign(at(ne) + 1, 0);
  for (const auto& chunk : chunks)
    for (const PartIntegrals& part : chunk) ++out.first[at(part.element) + 1];
  for (std::size_t e = 0; e + 1 < out.first.size(); ++e) out.first[e + 1] += out.first[e];
  out.triangle.resize(at(out.first.back()));
  out.integrals.resize(out.triangle.size());
  std::vector<Index> fill(out.first.begin(), out.first.end() - 1);
  for (const auto& chunk : chunks)
    for (const PartIntegrals& part : chunk) {
      out.triangle[at(fill[at(part.element)])] = part.triangle;
      out.integrals[at(fill[at(part.element)]++)] = part.integrals;
    }
  return out;
}

ElementSolid element_solid(const LatticeMesh& lm, const SurfacePieces& pieces) {
  const TetMesh& mesh = lm.mesh;
  const Index ne = mesh.num_elements();
  ElementSolid out;
  out.volume.resize(ne);
  out.centroid.resize(ne, 3);
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      const auto x = element_positions(mesh, e);
      const int k = pieces.apex[at(e)];
      const Eigen::Vector3d& p = x[static_cast<std::size_t>(k)];
      ConeIntegrals integrals;
      if (lm.node_inside[at(mesh.tets(e, k))]) {
        const double v = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) / 6.0;
        integrals.volume = v;
        integrals.moment = v * (0.25 * (x[0] + x[1] + x[2] + x[3]) - p);
      }
      for (Index c = pieces.first[at(e)]; c < pieces.first[at(e) + 1]; ++c) {
        integrals.volume += pieces.integrals[at(c)].volume;
        integrals.moment += pieces.integrals[at(c)].moment;
      }
      if (integrals.volume > 0.0) {
        out.volume[e] = integrals.volume;
        out.centroid.row(e) = (p + integrals.moment / integrals.volume).transpose();
      } else {
        out.volume[e] = 0.0;
        out.centroid.row(e) = (0.25 * (x[0] + x[1] + x[2] + x[3])).transpose();
      }
    }
  });
  return out;
}

ElementSolid clip_solid_to_elements(const LatticeMesh& lm, const TriangleMesh& surface) {
  return element_solid(lm, slice_surface(lm, surface));
}

Eigen::VectorXd exact_node_masses(const LatticeMesh& lm, const ElementSolid& solid, double density,
                                  std::span<const double> det_Fe, double min_mass_fraction) {
  const TetMesh& mesh = lm.mesh;
  const Index ne = mesh.num_elements();
  if (!det_Fe.empty() && static_cast<Index>(det_Fe.size()) != ne)
    throw Error("exact_node_masses: det_Fe must have one value per element");
  Eigen::VectorXd masses = Eigen::VectorXd::Zero(mesh.num_nodes());
  // In element order: deterministic (a few operations per element).
  for (Index e = 0; e < ne; ++e) {
    if (solid.volume[e] <= 0.0) continue;
    const double m = density * solid.volume[e] / (det_Fe.empty() ? 1.0 : det_Fe[at(e)]);
    Eigen::Vector4d b = lm.lattice.barycentric(lm.tet_keys[at(e)], solid.centroid.row(e).transpose());
    if (b.minCoeff() < 0.0) {
      // Round-off at a centroid on a face: no node gets negative mass (its
      // time-step bound takes √m), the weights stay a partition of one.
      b = b.cwiseMax(0.0);
      b /= b.sum();
    }
    for (int k = 0; k < 4; ++k) masses[mesh.tets(e, k)] += b[k] * m;
  }
  const double h = lm.lattice.spacing();
  const double floor = min_mass_fraction * density * h * h * h / 2.0;
  if (floor > 0.0) masses = masses.cwiseMax(floor);
  return masses;
}

}  // namespace goo
