#pragma once
// The body-centred-cubic lattice (Labelle & Shewchuk 2007; W&T sec. 5): two
// cubic grids of spacing h, corners o + (i, j, k) h and centres
// o + (i + ½, j + ½, k + ½) h. A lattice tetrahedron is two face-adjacent
// cell centres plus one edge of their shared face: 12 per cell, all
// congruent (edges h, h and four of h√3/2; volume h³/12).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>

#include "core/types.h"

namespace goo {

/// A finite block of the lattice: `cells` cells from `origin`. Node and
/// tetrahedron keys are 64-bit so that a lattice may be far larger than the
/// mesh cut from it.
class BccLattice {
 public:
  using Key = std::int64_t;
  /// The largest block along an axis (lattice coordinates are clamped to
  /// ±2³⁰ before they become cells).
  static constexpr int kMaxCellsPerAxis = 1 << 30;

  /// Throws Error for a spacing that is not positive and finite, or cells
  /// outside [1, kMaxCellsPerAxis] along an axis.
  BccLattice(const Eigen::Vector3d& origin, double spacing, const Eigen::Vector3i& cells);

  [[nodiscard]] const Eigen::Vector3d& origin() const { return origin_; }
  [[nodiscard]] double spacing() const { return h_; }
  [[nodiscard]] const Eigen::Vector3i& cells() const { return cells_; }

  // ---- nodes: corners first, then centres
  [[nodiscard]] Key num_nodes() const { return num_corners_ + cells_.cast<Key>().prod(); }
  [[nodiscard]] Key corner_key(const Eigen::Vector3i& ijk) const;  ///< 0 ≤ ijk ≤ cells
  [[nodiscard]] Key centre_key(const Eigen::Vector3i& ijk) const;  ///< 0 ≤ ijk < cells
  [[nodiscard]] bool is_centre(Key node) const { return node >= num_corners_; }
  [[nodiscard]] Eigen::Vector3d position(Key node) const;
  /// A node's place in space order: corner (i, j, k), then the centre of
  /// cell (i, j, k), cells x fastest. Meshes number their nodes in this
  /// order, so an element's four nodes lie near each other in the node
  /// arrays as elements lie near each other in theirs (in key order the
  /// corners and the centres formed two halves, and every element read
  /// both: a loop over elements split between threads then read and wrote
  /// the other thread's node data at every element).
  [[nodiscard]] Key space_order(Key node) const;

  // ---- tetrahedra: 12 per cell, keyed by (lower cell of the centre pair, axis, edge)
  /// Number of tetrahedron keys (12 per cell; keys whose upper cell falls
  /// outside the block are not tetrahedra of it: see valid()).
  [[nodiscard]] Key num_tet_keys() const { return 12 * cells_.cast<Key>().prod(); }
  /// Key of the tetrahedron joining the centres of `cell` and cell + e_axis
  /// with edge `edge` (0..3) of their shared face.
  [[nodiscard]] Key tet_key(const Eigen::Vector3i& cell, int axis, int edge) const;
  /// Whether both centres of the tetrahedron lie in the block.
  [[nodiscard]] bool valid(Key tet) const;
  /// Its four nodes, positively oriented: det[x1−x0, x2−x0, x3−x0] > 0.
  [[nodiscard]] std::array<Key, 4> tet_nodes(Key tet) const;
  /// The same for the tetrahedron tet_key(cell, axis, edge), without
  /// decoding a key.
  [[nodiscard]] std::array<Key, 4> tet_nodes(const Eigen::Vector3i& cell, int axis, int edge) const;
  /// The four corners of the face `cell` shares with cell + e_axis, in
  /// order around it: the tetrahedron (cell, axis, edge) has corners edge
  /// and edge + 1 (mod 4) of them (tet_nodes' last two, in some order).
  [[nodiscard]] std::array<Key, 4> face_corners(const Eigen::Vector3i& cell, int axis) const;
  /// Their positions (position() of each, bit for bit).
  [[nodiscard]] std::array<Eigen::Vector3d, 4> tet_positions(const Eigen::Vector3i& cell, int axis, int edge) const;
  /// Dm⁻¹ of a tetrahedron: every lattice tetrahedron is one of 12 shapes.
  [[nodiscard]] const Eigen::Matrix3d& Dm_inv(Key tet) const { return Dm_inv_[static_cast<std::size_t>(tet % 12)]; }
  /// h³ / 12.
  [[nodiscard]] double tet_volume() const { return h_ * h_ * h_ / 12.0; }

  /// The tetrahedron containing p, in constant time: cell, then the pyramid
  /// from the cell centre to the face the offset points at most (largest
  /// |component|), then the quadrant of that face cut by its diagonals. Ties
  /// (p on a shared face) pick one of the tetrahedra that contain p. Empty if
  /// that tetrahedron is not in the block.
  [[nodiscard]] std::optional<Key> locate(const Eigen::Vector3d& p) const;
  /// The same for a point in lattice units, q = (p − origin) / spacing
  /// (locate(p) is locate_units of that q, bit for bit).
  [[nodiscard]] std::optional<Key> locate_units(const Eigen::Vector3d& q) const;

  /// Barycentric coordinates of p in a tetrahedron (in tet_nodes order).
  [[nodiscard]] Eigen::Vector4d barycentric(Key tet, const Eigen::Vector3d& p) const;

  /// The cell containing p (may be outside the block; each index is
  /// clamped to ±2³⁰, and a NaN coordinate gives −2³⁰).
  [[nodiscard]] Eigen::Vector3i cell_of(const Eigen::Vector3d& p) const;

  /// How far a box is widened before its cells are found (1e-9 h), so that
  /// a box touching a cell's boundary finds that cell too.
  [[nodiscard]] double near_slack() const { return 1e-9 * h_; }

  /// The first and last cell of the block that the box [lo, hi], widened
  /// by near_slack(), meets: the cells in between along each axis, clamped
  /// to the block.
  [[nodiscard]] std::array<Eigen::Vector3i, 2> cells_near(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) const {
    const Eigen::Vector3d slack = Eigen::Vector3d::Constant(near_slack());
    return {cell_of(lo - slack).array().max(0).matrix(), cell_of(hi + slack).array().min(cells_.array() - 1).matrix()};
  }

  /// Calls f(key, cell, axis, edge) for every valid tetrahedron of the
  /// block that may meet or touch the box [lo, hi] (see below).
  template <class F>
  void for_each_tet_shape_near(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, F&& f) const {
    const auto [lo_cell, hi_cell] = cells_near(lo, hi);
    for (int shape = 0; shape < 12; ++shape) {
      const int axis = shape / 4;
      Eigen::Vector3i c0 = lo_cell, c1 = hi_cell;
      c0[axis] = std::max(0, c0[axis] - 1);
      c1[axis] = std::min(c1[axis], cells_[axis] - 2);  // the upper cell is in the block: valid
      for (int k = c0.z(); k <= c1.z(); ++k)
        for (int j = c0.y(); j <= c1.y(); ++j)
          for (int i = c0.x(); i <= c1.x(); ++i) {
            const Eigen::Vector3i cell(i, j, k);
            f(tet_key(cell, axis, shape % 4), cell, axis, shape % 4);
          }
    }
  }

  /// Calls f(key) for every valid tetrahedron of the block that may meet or
  /// touch the box [lo, hi]: a tetrahedron of axis a keyed by its lower cell spans that
  /// cell across a and reaches the next cell's centre along a, so its lower
  /// cell is in [lo − 1, hi] along a and in [lo, hi] across. A superset:
  /// filter by geometry.
  template <class F>
  void for_each_tet_near(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, F&& f) const {
    for_each_tet_shape_near(lo, hi, [&](Key key, const Eigen::Vector3i&, int, int) { f(key); });
  }

  /// Calls f(key) for every node of the block in the closed box [lo, hi]
  /// (corners first, then centres, each in increasing key order).
  template <class F>
  void for_each_node_in(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, F&& f) const {
    const Eigen::Vector3d ql = (lo - origin_) / h_, qh = (hi - origin_) / h_;
    // Each coordinate clamped to [−1, top + 1] before its conversion (past
    // int's range undefined): a box reaching far out visits the nodes of the
    // block it holds; a NaN bound, none.
    const auto low = [](double x, int top) { return x >= -1.0 ? std::min(x, top + 1.0) : x < -1.0 ? -1.0 : top + 1.0; };
    const auto high = [](double x, int top) {
      return x <= top + 1.0 ? std::max(x, -1.0) : x > top + 1.0 ? top + 1.0 : -1.0;
    };
    for (const double shift : {0.0, 0.5}) {
      const Eigen::Vector3i top = shift == 0.0 ? cells_ : Eigen::Vector3i(cells_.array() - 1);
      Eigen::Vector3i a, b;
      for (int d = 0; d < 3; ++d) {
        a[d] = std::max(0, static_cast<int>(std::ceil(low(ql[d] - shift, top[d]))));
        b[d] = std::min(top[d], static_cast<int>(std::floor(high(qh[d] - shift, top[d]))));
      }
      for (int k = a.z(); k <= b.z(); ++k)
        for (int j = a.y(); j <= b.y(); ++j)
          for (int i = a.x(); i <= b.x(); ++i) f(shift == 0.0 ? corner_key({i, j, k}) : centre_key({i, j, k}));
    }
  }

 private:
  /// Lattice coordinates of tet_nodes(cell, axis, edge): cells of the two
  /// centres, then the two corners.
  [[nodiscard]] std::array<Eigen::Vector3i, 4> tet_node_coordinates(const Eigen::Vector3i& cell, int axis,
                                                                    int edge) const;

  Eigen::Vector3d origin_;
  double h_;
  Eigen::Vector3i cells_;
  Key num_corners_;
  // Per shape (axis, edge): whether the face edge is reversed to keep the
  // tetrahedron positive, and its Dm⁻¹.
  std::array<bool, 12> swap_{};
  std::array<Eigen::Matrix3d, 12> Dm_inv_{};
};

}  // namespace goo
