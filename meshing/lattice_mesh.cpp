#include "meshing/lattice_mesh.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "core/surface_geometry.h"
#include "meshing/voxelize.h"

namespace goo {
namespace {

BccLattice block_around(const TriangleMesh& surface, double h) {
  if (!(h > 0.0) || !std::isfinite(h)) throw Error(fmt::format("lattice spacing must be positive, got {}", h));
  for (Index v = 0; v < surface.num_vertices(); ++v)
    if (!surface.vertices.row(v).allFinite())
      throw Error(fmt::format("cannot build a lattice around a surface whose vertex {} is not finite", v));
  const Eigen::AlignedBox3d box = bounding_box(surface.vertices);
  if (box.isEmpty()) throw Error("cannot build a lattice around an empty surface");
  const Eigen::Vector3d origin = ((box.min() / h).array().floor() - 2.0).matrix() * h;
  const Eigen::Array3d span = ((box.max() - origin) / h).array().ceil() + 2.0;
  // Checked before the conversion to int (past its range undefined): a
  // surface flung or stretched this far cannot be meshed at this spacing.
  if (!(span <= static_cast<double>(BccLattice::kMaxCellsPerAxis)).all())
    throw Error(
        fmt::format("the surface spans ({:.3g}, {:.3g}, {:.3g}) lattice cells of {} m, more than {} along an axis",
                    span.x(), span.y(), span.z(), h, BccLattice::kMaxCellsPerAxis));
  return BccLattice(origin, h, span.cast<int>().matrix());
}

}  // namespace

bool overlaps_inflated(const std::array<Eigen::Vector3d, 3>& tri, const std::array<Eigen::Vector3d, 4>& tet,
                       double slack, bool edge_axes) {
  auto separated = [&](const Eigen::Vector3d& axis) {
    const double length = axis.norm();
    if (length < 1e-300) return false;
    double t0 = tri[0].dot(axis), t1 = t0, k0 = tet[0].dot(axis), k1 = k0;
    for (const auto& p : tri) {
      t0 = std::min(t0, p.dot(axis));
      t1 = std::max(t1, p.dot(axis));
    }
    for (const auto& p : tet) {
      k0 = std::min(k0, p.dot(axis));
      k1 = std::max(k1, p.dot(axis));
    }
    return t1 + slack * length < k0 || k1 + slack * length < t0;
  };
  const std::array<Eigen::Vector3d, 3> tri_edges = {tri[1] - tri[0], tri[2] - tri[1], tri[0] - tri[2]};
  if (separated(tri_edges[0].cross(tri_edges[1]))) return false;
  static constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  for (const auto& f : kFaces) {
    const Eigen::Vector3d& a = tet[static_cast<std::size_t>(f[0])];
    if (separated((tet[static_cast<std::size_t>(f[1])] - a).cross(tet[static_cast<std::size_t>(f[2])] - a)))
      return false;
  }
  if (!edge_axes) return true;
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (const auto& e : tri_edges)
    for (const auto& te : kEdges) {
      if (separated(e.cross(tet[static_cast<std::size_t>(te[1])] - tet[static_cast<std::size_t>(te[0])]))) return false;
    }
  return true;
}

LatticeMesh build_lattice_mesh(const TriangleMesh& surface, double h) {
  LatticeMesh out{block_around(surface, h), {}, {}, {}, {}, {}, {}};
  const BccLattice& lattice = out.lattice;
  const std::vector<std::uint8_t> inside = voxelize(lattice, surface);
  std::vector<std::uint8_t> keep(static_cast<std::size_t>(lattice.num_tet_keys()), 0);
  // Tetrahedra with an inside node. Per layer of cells, each cell's three
  // pairs of centres (the cell's and the next one's along an axis) and the
  // four corners of the face between them: tetrahedron (cell, axis, edge)
  // has both centres and corners edge and edge + 1 of that face.
  const Eigen::Vector3i cells = lattice.cells();
  const auto is_inside = [&](BccLattice::Key n) { return inside[static_cast<std::size_t>(n)] != 0; };
  tbb::parallel_for(0, cells.z(), [&](int k) {
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i) {
        const Eigen::Vector3i cell(i, j, k);
        const bool centre = is_inside(lattice.centre_key(cell));
        for (int axis = 0; axis < 3; ++axis) {
          if (cell[axis] + 1 >= cells[axis]) continue;  // not valid: the upper centre is outside the block
          const bool centres = centre || is_inside(lattice.centre_key(cell + Eigen::Vector3i::Unit(axis)));
          std::array<bool, 4> corner{};
          const auto face = lattice.face_corners(cell, axis);
          for (std::size_t q = 0; q < 4; ++q) corner[q] = is_inside(face[q]);
          for (int edge = 0; edge < 4; ++edge)
            if (centres || corner[static_cast<std::size_t>(edge)] || corner[static_cast<std::size_t>((edge + 1) % 4)])
              keep[static_cast<std::size_t>(lattice.tet_key(cell, axis, edge))] = 1;
        }
      }
  });
  // Tetrahedra overlapping a triangle. Each triangle is binned into the
  // cells its box, widened by the slack, meets (those for_each_tet_shape_near
  // looks around it, clamped to the block). A tetrahedron keyed by cell c
  // and axis a is near exactly the triangles binned in c or c + e_a, so each
  // tetrahedron without an inside node is tested against those alone, and
  // only until one overlaps it: the same tetrahedra as testing the
  // tetrahedra near every triangle, where each was tested by every triangle
  // near it (docs/benchmarks.md, session 46).
  const double slack = lattice.near_slack();
  const auto num_triangles = static_cast<std::size_t>(surface.num_triangles());
  std::vector<std::array<Eigen::Vector3d, 2>> boxes(num_triangles);
  std::vector<std::array<Eigen::Vector3i, 2>> ranges(num_triangles);
  for_each_index(static_cast<Index>(num_triangles), [&](Index t) {
    const auto [a, b, c] = surface.corners(t);
    const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
    boxes[at(t)] = {lo, hi};
    ranges[at(t)] = lattice.cells_near(lo, hi);
  });
  // The bins: each cell's triangles, ascending (a counting sort).
  const auto cell_index = [&](int i, int j, int k) {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(cells.x()) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(cells.y()) * static_cast<std::size_t>(k));
  };
  auto for_each_binned_cell = [&](std::size_t t, auto&& f) {
    const auto& [lo, hi] = ranges[t];
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) f(cell_index(i, j, k));
  };
  const std::size_t num_cells = cell_index(0, 0, cells.z());
  std::vector<std::size_t> bin_offsets(num_cells + 1, 0);
  for (std::size_t t = 0; t < num_triangles; ++t) for_each_binned_cell(t, [&](std::size_t c) { ++bin_offsets[c + 1]; });
  for (std::size_t c = 0; c < num_cells; ++c) bin_offsets[c + 1] += bin_offsets[c];
  std::vector<Index> binned(bin_offsets[num_cells]);
  {
    std::vector<std::size_t> next(bin_offsets.begin(), bin_offsets.end() - 1);
    for (std::size_t t = 0; t < num_triangles; ++t)
      for_each_binned_cell(t, [&](std::size_t c) { binned[next[c]++] = static_cast<Index>(t); });
  }
  // Per layer of cells, each tetrahedron keyed there that has no inside
  // node: keep[key] is read and set for its own key only, so the layers
  // run in parallel and the result does not depend on the thread count.
  tbb::parallel_for(0, cells.z(), [&](int k) {
    for (int j = 0; j < cells.y(); ++j)
      for (int i = 0; i < cells.x(); ++i) {
        const Eigen::Vector3i cell(i, j, k);
        const std::size_t lower = cell_index(i, j, k);
        for (int shape = 0; shape < 12; ++shape) {
          const int axis = shape / 4, edge = shape % 4;
          if (cell[axis] + 1 >= cells[axis]) continue;  // not valid: the upper centre is outside the block
          const auto key = static_cast<std::size_t>(lattice.tet_key(cell, axis, edge));
          if (keep[key]) continue;
          Eigen::Vector3i above = cell;
          ++above[axis];
          const std::size_t upper = cell_index(above.x(), above.y(), above.z());
          if (bin_offsets[lower] == bin_offsets[lower + 1] && bin_offsets[upper] == bin_offsets[upper + 1]) continue;
          const auto tet = lattice.tet_positions(cell, axis, edge);
          Eigen::Vector3d tet_lo = tet[0], tet_hi = tet[0];
          for (const auto& p : tet) {
            tet_lo = tet_lo.cwiseMin(p);
            tet_hi = tet_hi.cwiseMax(p);
          }
          auto overlapped_in = [&](std::size_t bin) {
            for (std::size_t n = bin_offsets[bin]; n < bin_offsets[bin + 1]; ++n) {
              const auto t = static_cast<Index>(binned[n]);
              const auto& [lo, hi] = boxes[at(t)];
              if (((tet_lo.array() - slack) > hi.array()).any() || ((tet_hi.array() + slack) < lo.array()).any())
                continue;
              if (overlaps_inflated(surface.corners(t), tet, slack)) return true;
            }
            return false;
          };
          if (overlapped_in(lower) || overlapped_in(upper)) keep[key] = 1;
        }
      }
  });
  // Compact numbering: elements in lattice key order, nodes in space order
  // (BccLattice::space_order; deterministic).
  std::vector<Index> node_id(static_cast<std::size_t>(lattice.num_nodes()), -1);
  for (BccLattice::Key t = 0; t < lattice.num_tet_keys(); ++t) {
    if (!keep[static_cast<std::size_t>(t)]) continue;
    out.tet_keys.push_back(t);
    for (const auto n : lattice.tet_nodes(t)) node_id[static_cast<std::size_t>(n)] = 0;
  }
  // Space order by construction: corner (i, j, k), then the centre of cell
  // (i, j, k) where there is one, cells x fastest.
  const auto number = [&](BccLattice::Key n) {
    if (node_id[static_cast<std::size_t>(n)] < 0) return;
    node_id[static_cast<std::size_t>(n)] = static_cast<Index>(out.node_keys.size());
    out.node_keys.push_back(n);
  };
  for (int k = 0; k <= cells.z(); ++k)
    for (int j = 0; j <= cells.y(); ++j)
      for (int i = 0; i <= cells.x(); ++i) {
        number(lattice.corner_key({i, j, k}));
        if (i < cells.x() && j < cells.y() && k < cells.z()) number(lattice.centre_key({i, j, k}));
      }
  out.mesh.positions.resize(static_cast<Eigen::Index>(out.node_keys.size()), 3);
  for (std::size_t i = 0; i < out.node_keys.size(); ++i)
    out.mesh.positions.row(static_cast<Eigen::Index>(i)) = lattice.position(out.node_keys[i]).transpose();
  out.node_inside.resize(out.node_keys.size());
  for (std::size_t i = 0; i < out.node_keys.size(); ++i)
    out.node_inside[i] = inside[static_cast<std::size_t>(out.node_keys[i])];
  out.node_of_key = std::move(node_id);
  out.element_of_key.assign(static_cast<std::size_t>(lattice.num_tet_keys()), -1);
  out.mesh.tets.resize(static_cast<Eigen::Index>(out.tet_keys.size()), 4);
  for (std::size_t e = 0; e < out.tet_keys.size(); ++e) {
    const auto nodes = lattice.tet_nodes(out.tet_keys[e]);
    for (int k = 0; k < 4; ++k)
      out.mesh.tets(static_cast<Eigen::Index>(e), k) =
          out.node_of_key[static_cast<std::size_t>(nodes[static_cast<std::size_t>(k)])];
    out.element_of_key[static_cast<std::size_t>(out.tet_keys[e])] = static_cast<Index>(e);
  }
  return out;
}

Embedding embed(const LatticeMesh& lm, const Points& vertices) {
  const Index nv = static_cast<Index>(vertices.rows());
  Embedding out;
  out.parent.assign(at(nv), -1);
  out.bary.resize(nv, 4);
  const BccLattice& lattice = lm.lattice;
  tbb::parallel_for(tbb::blocked_range<Index>(0, nv, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index v = r.begin(); v != r.end(); ++v) {
      const Eigen::Vector3d p = vertices.row(v);
      Index best = -1;
      Eigen::Vector4d best_b = Eigen::Vector4d::Constant(-1e300);
      if (const auto key = lattice.locate(p)) {
        if (const Index e = lm.element(*key); e >= 0) {
          best = e;
          best_b = lattice.barycentric(*key, p);
        }
      }
      if (best < 0) {
        // On a face shared with a tetrahedron that was not kept: the kept
        // tetrahedra of the surrounding cells, best containment first.
        const Eigen::Vector3i cell = lattice.cell_of(p);
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const Eigen::Vector3i c = cell + Eigen::Vector3i(di, dj, dk);
              if ((c.array() < 0).any() || (c.array() >= lattice.cells().array()).any()) continue;
              for (int shape = 0; shape < 12; ++shape) {
                const BccLattice::Key key = lattice.tet_key(c, shape / 4, shape % 4);
                const Index e = lm.element(key);
                if (e < 0) continue;
                const Eigen::Vector4d b = lattice.barycentric(key, p);
                if (b.minCoeff() > best_b.minCoeff() || (b.minCoeff() == best_b.minCoeff() && e < best)) {
                  best = e;
                  best_b = b;
                }
              }
            }
      }
      if (best < 0) throw Error(fmt::format("surface vertex {} lies outside the lattice mesh", v));
      out.parent[at(v)] = best;
      out.bary.row(v) = best_b.transpose();
    }
  });
  return out;
}

}  // namespace goo
