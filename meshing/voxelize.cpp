#include "meshing/voxelize.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/parallel.h"
#include "meshing/exact_predicates.h"

namespace goo {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
/// Triangles per parallel task.
constexpr std::size_t kChunk = 256;

struct Crossing {
  Index triangle;
  int sign;          // sign of the normal's z: +1 where the ray leaves the solid going up
  double z;          // floating-point height of the crossing
  double tolerance;  // bound on |z − exact height|; ∞ when z cannot be trusted
};

/// One grid of columns: the corners (offset 0) or the centres (offset ½).
struct ColumnGrid {
  double offset;
  Eigen::Vector3i count;  // columns in x, y; nodes per column in z
};

/// Side of p + (ε, ε²) relative to the directed xy edge u → v: +1 left.
int side_with_tiebreak(const Eigen::Vector3d& u, const Eigen::Vector3d& v, const Eigen::Vector3d& p) {
  const int s = exact::orient_xy(u, v, p);
  if (s != 0) return s;
  // orient(u, v, p + δ) = (v_x − u_x) ε² − (v_y − u_y) ε; differences of
  // doubles have exact signs.
  if (v.y() != u.y()) return v.y() > u.y() ? -1 : 1;
  return v.x() > u.x() ? 1 : -1;
}

/// Whether the crossing of its triangle lies above the node p + (ε, ε², ε³).
/// The triangle's corners are read only where the float height cannot tell.
bool crossing_above(const Crossing& c, const TriangleMesh& surface, const Eigen::Vector3d& p) {
  const double dz = c.z - p.z();
  if (std::abs(dz) > c.tolerance) return dz > 0.0;
  const auto [a, b, cc] = surface.corners(c.triangle);
  const int o = exact::orient_3d(a, b, cc, p);
  // p below the plane (so the crossing above it) when (p − a)·n has the sign
  // opposite to n_z.
  if (o != 0) return o == -c.sign;
  // p on the plane: the plane at (x + ε, y + ε²) lies at height
  // −(n_x ε + n_y ε²)/n_z relative to p, the node at +ε³.
  const int nx = exact::orient_yz(a, b, cc), ny = exact::orient_zx(a, b, cc);
  if (nx != 0) return -nx * c.sign > 0;
  if (ny != 0) return -ny * c.sign > 0;
  return false;  // a horizontal plane through p: the node sits ε³ above it
}

}  // namespace

std::vector<std::uint8_t> voxelize(const BccLattice& lattice, const TriangleMesh& surface) {
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(lattice.num_nodes()), 0);
  const double h = lattice.spacing();
  const Eigen::Vector3d o = lattice.origin();
  const Eigen::Vector3i n = lattice.cells();
  const ColumnGrid grids[2] = {{0.0, n + Eigen::Vector3i::Ones()}, {0.5, n}};

  for (const ColumnGrid& grid : grids) {
    const std::size_t columns = static_cast<std::size_t>(grid.count.x()) * static_cast<std::size_t>(grid.count.y());
    // Triangles to the columns they cross: in parallel over fixed chunks of
    // triangles, merged in chunk order, so every column lists its crossings
    // in triangle order whatever the thread count.
    std::vector<std::vector<Crossing>> crossings(columns);
    const auto num_triangles = static_cast<std::size_t>(surface.num_triangles());
    const std::size_t num_chunks = (num_triangles + kChunk - 1) / kChunk;
    std::vector<std::vector<std::pair<std::size_t, Crossing>>> chunks(num_chunks);
    tbb::parallel_for(std::size_t{0}, num_chunks, [&](std::size_t chunk) {
      auto& found = chunks[chunk];
      auto visit = [&](Index t) {
        const auto [a, b, c] = surface.corners(t);
        const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c), hi = a.cwiseMax(b).cwiseMax(c);
        // The columns in the triangle's box, widened by 1e-7 h: far more than
        // the rounding of these quotients, so a column on the box's edge (whose
        // shifted ray may meet the triangle) is never left out. Most
        // triangles, smaller than the spacing, lie between columns.
        constexpr double kMargin = 1e-7;
        const int i0 = std::max(0, static_cast<int>(std::ceil((lo.x() - o.x()) / h - grid.offset - kMargin)));
        const int i1 =
            std::min(grid.count.x() - 1, static_cast<int>(std::floor((hi.x() - o.x()) / h - grid.offset + kMargin)));
        if (i1 < i0) return;
        const int j0 = std::max(0, static_cast<int>(std::ceil((lo.y() - o.y()) / h - grid.offset - kMargin)));
        const int j1 =
            std::min(grid.count.y() - 1, static_cast<int>(std::floor((hi.y() - o.y()) / h - grid.offset + kMargin)));
        if (j1 < j0) return;
        const int sign = exact::orient_xy(a, b, c);
        if (sign == 0) return;  // vertical: the shifted ray never meets it
        const Eigen::Vector3d& u0 = a;
        const Eigen::Vector3d& u1 = sign > 0 ? b : c;
        const Eigen::Vector3d& u2 = sign > 0 ? c : b;
        const Eigen::Vector3d normal = (b - a).cross(c - a);
        const double extent = (hi - lo).norm() + lo.cwiseAbs().maxCoeff() + hi.cwiseAbs().maxCoeff();
        // z = a_z − (n_x (x − a_x) + n_y (y − a_y)) / n_z: its rounding error
        // grows with the slope |n_xy| / |n_z|; steep triangles always go exact.
        const double slope = normal.head<2>().cwiseAbs().sum() / std::abs(normal.z());
        const double tolerance = std::abs(normal.z()) > 1e-6 * normal.norm() ? 64.0 * kEps * (1.0 + slope) * extent
                                                                             : std::numeric_limits<double>::infinity();
        for (int j = j0; j <= j1; ++j)
          for (int i = i0; i <= i1; ++i) {
            const Eigen::Vector3d p(o.x() + (i + grid.offset) * h, o.y() + (j + grid.offset) * h, 0.0);
            if (side_with_tiebreak(u0, u1, p) < 0 || side_with_tiebreak(u1, u2, p) < 0 ||
                side_with_tiebreak(u2, u0, p) < 0)
              continue;
            const double z = a.z() - (normal.x() * (p.x() - a.x()) + normal.y() * (p.y() - a.y())) / normal.z();
            found.emplace_back(
                static_cast<std::size_t>(j) * static_cast<std::size_t>(grid.count.x()) + static_cast<std::size_t>(i),
                Crossing{t, sign, z, tolerance});
          }
      };
      const std::size_t end = std::min(num_triangles, (chunk + 1) * kChunk);
      for (std::size_t t = chunk * kChunk; t < end; ++t) visit(static_cast<Index>(t));
    });
    for (const auto& chunk : chunks)
      for (const auto& [column, crossing] : chunk) crossings[column].push_back(crossing);
    // Columns in parallel: each writes only its own nodes.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, columns, 64), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t col = r.begin(); col != r.end(); ++col) {
        const auto& list = crossings[col];
        if (list.empty()) continue;
        const int i = static_cast<int>(col % static_cast<std::size_t>(grid.count.x()));
        const int j = static_cast<int>(col / static_cast<std::size_t>(grid.count.x()));
        for (int k = 0; k < grid.count.z(); ++k) {
          const Eigen::Vector3d p(o.x() + (i + grid.offset) * h, o.y() + (j + grid.offset) * h,
                                  o.z() + (k + grid.offset) * h);
          int winding = 0;
          for (const Crossing& c : list)
            if (crossing_above(c, surface, p)) winding += c.sign;
          if (winding != 0) {
            const Eigen::Vector3i ijk(i, j, k);
            inside[static_cast<std::size_t>(grid.offset == 0.0 ? lattice.corner_key(ijk) : lattice.centre_key(ijk))] =
                1;
          }
        }
      }
    });
  }
  return inside;
}

}  // namespace goo
