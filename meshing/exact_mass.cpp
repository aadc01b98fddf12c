#include "meshing/exact_mass.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/parallel.h"
#include "meshing/convex_clip.h"

namespace goo {
namespace {

std::array<Eigen::Vector3d, 4> element_positions(const TetMesh& mesh, Index e) {
  return {mesh.positions.row(mesh.tets(e, 0)).transpose(), mesh.positions.row(mesh.tets(e, 1)).transpose(),
          mesh.positions.row(mesh.tets(e, 2)).transpose(), mesh.positions.row(mesh.tets(e, 3)).transpose()};
}

/// For each element, the triangles whose bounding box meets its own, in
/// increasing triangle order (compressed rows).
struct ElementTriangles {
  std::vector<Index> offsets;
  std::vector<Index> triangles;
};

ElementTriangles candidate_triangles(const LatticeMesh& lm, const TriangleMesh& surface) {
  const BccLattice& lattice = lm.lattice;
  constexpr std::size_t kChunk = 256;
  const auto num_triangles = static_cast<std::size_t>(surface.num_triangles());
  std::vector<std::vector<std::pair<Index, Index>>> chunks((num_triangles + kChunk - 1) / kChunk);
  const double slack = 1e-9 * lattice.spacing();
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t chunk) {
    auto& found = chunks[chunk];
    for (std::size_t index = chunk * kChunk; index < std::min(num_triangles, (chunk + 1) * kChunk); ++index) {
      const auto t = static_cast<Index>(index);
      Eigen::Vector3d lo = surface.vertices.row(surface.triangles(t, 0)), hi = lo;
      for (int k = 1; k < 3; ++k) {
        lo = lo.cwiseMin(surface.vertices.row(surface.triangles(t, k)).transpose());
        hi = hi.cwiseMax(surface.vertices.row(surface.triangles(t, k)).transpose());
      }
      lattice.for_each_tet_near(lo, hi, [&](BccLattice::Key key) {
        const Index e = lm.element(key);
        if (e < 0) return;
        const auto x = element_positions(lm.mesh, e);
        Eigen::Vector3d tet_lo = x[0], tet_hi = x[0];
        for (const auto& p : x) {
          tet_lo = tet_lo.cwiseMin(p);
          tet_hi = tet_hi.cwiseMax(p);
        }
        if (((tet_lo.array() - slack) > hi.array()).any() || ((tet_hi.array() + slack) < lo.array()).any()) return;
        found.emplace_back(e, t);
      });
    }
  });
  // Counting sort by element; chunks in order keep triangles increasing.
  ElementTriangles out;
  out.offsets.assign(static_cast<std::size_t>(lm.mesh.num_elements()) + 1, 0);
  for (const auto& chunk : chunks)
    for (const auto& [e, t] : chunk) ++out.offsets[at(e) + 1];
  for (std::size_t e = 0; e + 1 < out.offsets.size(); ++e) out.offsets[e + 1] += out.offsets[e];
  out.triangles.resize(at(out.offsets.back()));
  std::vector<Index> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (const auto& chunk : chunks)
    for (const auto& [e, t] : chunk) out.triangles[at(fill[at(e)]++)] = t;
  return out;
}

}  // namespace

ElementSolid clip_solid_to_elements(const LatticeMesh& lm, const TriangleMesh& surface) {
  const TetMesh& mesh = lm.mesh;
  const Index ne = mesh.num_elements();
  if (static_cast<Index>(lm.node_inside.size()) != mesh.num_nodes())
    throw Error("clip_solid_to_elements: the lattice mesh has no inside flags for its nodes");
  const ElementTriangles candidates = candidate_triangles(lm, surface);
  ElementSolid out;
  out.volume.resize(ne);
  out.centroid.resize(ne, 3);
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    std::vector<Polygon> pieces;
    std::vector<Eigen::Vector4d> piece_planes;  // unit normal, offset of each piece's triangle
    for (Index e = r.begin(); e != r.end(); ++e) {
      const auto x = element_positions(mesh, e);
      const auto planes = tet_planes(x);
      pieces.clear();
      piece_planes.clear();
      for (Index c = candidates.offsets[at(e)]; c < candidates.offsets[at(e) + 1]; ++c) {
        const Index t = candidates.triangles[at(c)];
        Polygon piece;
        for (int k = 0; k < 3; ++k) piece.push(surface.vertices.row(surface.triangles(t, k)).transpose());
        const Eigen::Vector3d n = (piece.v[1] - piece.v[0]).cross(piece.v[2] - piece.v[0]);
        if (n.squaredNorm() == 0.0) continue;  // a degenerate triangle bounds no volume
        // Every candidate's plane counts for the apex, clipped away or not: a
        // vertex may touch the surface where nothing of it is inside.
        const Eigen::Vector3d unit = n.normalized();
        piece_planes.emplace_back(unit.x(), unit.y(), unit.z(), unit.dot(piece.v[0]));
        for (const Plane& plane : planes) piece = clip(piece, plane);
        if (piece.size >= 3) pieces.push_back(piece);
      }
      // Apex: the vertex farthest from the candidates' planes, so not on the
      // surface (triangles that are not candidates cannot reach the element).
      int apex = 0;
      double best = -1.0;
      for (int k = 0; k < 4; ++k) {
        double nearest = std::numeric_limits<double>::infinity();
        for (const auto& plane : piece_planes)
          nearest = std::min(nearest, std::abs(plane.head<3>().dot(x[static_cast<std::size_t>(k)]) - plane[3]));
        if (nearest > best) {
          best = nearest;
          apex = k;
        }
      }
      const Eigen::Vector3d& p = x[static_cast<std::size_t>(apex)];
      const Plane& opposite = planes[static_cast<std::size_t>(apex)];
      const double height = -opposite.distance(p);
      ConeIntegrals integrals;
      if (lm.node_inside[at(mesh.tets(e, apex))]) {
        const double v = (x[1] - x[0]).dot((x[2] - x[0]).cross(x[3] - x[0])) / 6.0;
        integrals.volume = v;
        integrals.moment = v * (0.25 * (x[0] + x[1] + x[2] + x[3]) - p);
      }
      for (const Polygon& piece : pieces) {
        integrals.add_cone(p, piece);
        // The piece's shadow on the opposite face, seen from p.
        Polygon shadow = piece;
        for (int i = 0; i < shadow.size; ++i) {
          const Eigen::Vector3d y = piece.v[static_cast<std::size_t>(i)] - p;
          const double along = y.dot(opposite.normal);
          shadow.v[static_cast<std::size_t>(i)] = along > 1e-300 ? Eigen::Vector3d(p + y * (height / along)) : p;
        }
        integrals.add_cone(p, shadow, -1.0);
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
