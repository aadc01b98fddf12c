#include "meshing/bcc_lattice.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace goo {
namespace {

/// The corners (u, v) of a face in its own axes b = a+1, c = a+2, in order
/// around it; edge e joins corner e and corner e+1.
constexpr std::array<std::array<int, 2>, 4> kFaceCorners = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};

/// Nodes of (axis, edge) relative to the lower cell's minimum corner, in
/// units of h, before orientation: lower centre, upper centre, edge ends.
std::array<Eigen::Vector3d, 4> local_nodes(int axis, int edge) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const Eigen::Vector3d centre = Eigen::Vector3d::Constant(0.5);
  std::array<Eigen::Vector3d, 4> out;
  out[0] = centre;
  out[1] = centre + Eigen::Vector3d::Unit(axis);
  for (int k = 0; k < 2; ++k) {
    const auto& uv = kFaceCorners[static_cast<std::size_t>((edge + k) % 4)];
    out[static_cast<std::size_t>(2 + k)] =
        Eigen::Vector3d::Unit(axis) + uv[0] * Eigen::Vector3d::Unit(b) + uv[1] * Eigen::Vector3d::Unit(c);
  }
  return out;
}

/// The cell containing the point at lattice coordinates q. A coordinate
/// past ±2³⁰ cells (a finite point far outside any block, an infinite or NaN
/// one) is clamped to ±2³⁰ first: converting a double beyond int's range is
/// undefined, and a caller's cell ± 1 must not overflow either. Every block
/// is far smaller, so clamped cells are outside it as before. Within ±2³⁰
/// the floor is the conversion toward zero, one less where that rounded
/// up: std::floor's value, without its general path.
Eigen::Vector3i floor_cell(const Eigen::Vector3d& q) {
  constexpr double kFar = 1 << 30;
  const auto floor_clamped = [](double x) {
    const double c = !(x >= -kFar) ? -kFar : (x > kFar ? kFar : x);  // NaN: -2³⁰
    const int t = static_cast<int>(c);
    return static_cast<double>(t) > c ? t - 1 : t;
  };
  return {floor_clamped(q.x()), floor_clamped(q.y()), floor_clamped(q.z())};
}

}  // namespace

BccLattice::BccLattice(const Eigen::Vector3d& origin, double spacing, const Eigen::Vector3i& cells)
    : origin_(origin), h_(spacing), cells_(cells) {
  if (!(spacing > 0.0) || !std::isfinite(spacing))
    throw Error(fmt::format("lattice spacing must be positive, got {}", spacing));
  if (!(cells.array() >= 1).all()) {
    throw Error(fmt::format("a lattice block needs at least one cell per axis, got ({}, {}, {})", cells.x(), cells.y(),
                            cells.z()));
  }
  // Cells are located by clamping lattice coordinates to ±2³⁰ (floor_cell),
  // which a larger block would reach from inside.
  if (!(cells.array() <= kMaxCellsPerAxis).all()) {
    throw Error(fmt::format("a lattice block has at most {} cells per axis, got ({}, {}, {})", kMaxCellsPerAxis,
                            cells.x(), cells.y(), cells.z()));
  }
  num_corners_ = (cells_.cast<Key>().array() + 1).prod();
  for (int axis = 0; axis < 3; ++axis)
    for (int edge = 0; edge < 4; ++edge) {
      auto x = local_nodes(axis, edge);
      Eigen::Matrix3d D;
      for (int k = 0; k < 3; ++k) D.col(k) = x[static_cast<std::size_t>(k) + 1] - x[0];
      const auto shape = static_cast<std::size_t>(4 * axis + edge);
      swap_[shape] = D.determinant() < 0.0;
      if (swap_[shape]) D.col(1).swap(D.col(2));
      Dm_inv_[shape] = D.inverse() / h_;
    }
}

BccLattice::Key BccLattice::corner_key(const Eigen::Vector3i& ijk) const {
  return ijk.x() + (cells_.x() + Key{1}) * (ijk.y() + (cells_.y() + Key{1}) * ijk.z());
}

BccLattice::Key BccLattice::centre_key(const Eigen::Vector3i& ijk) const {
  return num_corners_ + ijk.x() + Key{cells_.x()} * (ijk.y() + Key{cells_.y()} * ijk.z());
}

Eigen::Vector3d BccLattice::position(Key node) const {
  const bool centre = is_centre(node);
  Key rest = centre ? node - num_corners_ : node;
  const Eigen::Matrix<Key, 3, 1> n =
      centre ? cells_.cast<Key>() : Eigen::Matrix<Key, 3, 1>(cells_.cast<Key>().array() + 1);
  const Key i = rest % n.x();
  rest /= n.x();
  const Key j = rest % n.y();
  const Key k = rest / n.y();
  const double shift = centre ? 0.5 : 0.0;
  return origin_ + h_ * Eigen::Vector3d(static_cast<double>(i) + shift, static_cast<double>(j) + shift,
                                        static_cast<double>(k) + shift);
}

BccLattice::Key BccLattice::space_order(Key node) const {
  const bool centre = is_centre(node);
  Key rest = centre ? node - num_corners_ : node;
  if (centre) {  // a centre's cell (i, j, k), as the corner (i, j, k) numbers it
    const Key i = rest % cells_.x();
    rest /= cells_.x();
    const Key j = rest % cells_.y();
    const Key k = rest / cells_.y();
    return 2 * corner_key({static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)}) + 1;
  }
  return 2 * rest;
}

BccLattice::Key BccLattice::tet_key(const Eigen::Vector3i& cell, int axis, int edge) const {
  const Key linear = cell.x() + Key{cells_.x()} * (cell.y() + Key{cells_.y()} * cell.z());
  return 12 * linear + 4 * axis + edge;
}

namespace {
struct Decoded {
  Eigen::Vector3i cell;
  int axis, edge;
};
Decoded decode(BccLattice::Key tet, const Eigen::Vector3i& cells) {
  const auto shape = static_cast<int>(tet % 12);
  BccLattice::Key linear = tet / 12;
  Decoded d;
  d.axis = shape / 4;
  d.edge = shape % 4;
  d.cell.x() = static_cast<int>(linear % cells.x());
  linear /= cells.x();
  d.cell.y() = static_cast<int>(linear % cells.y());
  d.cell.z() = static_cast<int>(linear / cells.y());
  return d;
}
}  // namespace

bool BccLattice::valid(Key tet) const {
  if (tet < 0 || tet >= num_tet_keys()) return false;
  const Decoded d = decode(tet, cells_);
  return d.cell[d.axis] + 1 < cells_[d.axis];
}

std::array<BccLattice::Key, 4> BccLattice::tet_nodes(Key tet) const {
  const Decoded d = decode(tet, cells_);
  return tet_nodes(d.cell, d.axis, d.edge);
}

std::array<Eigen::Vector3i, 4> BccLattice::tet_node_coordinates(const Eigen::Vector3i& cell, int axis, int edge) const {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  std::array<Eigen::Vector3i, 4> out;
  out[0] = cell;
  out[1] = cell + Eigen::Vector3i::Unit(axis);
  for (int k = 0; k < 2; ++k) {
    const auto& uv = kFaceCorners[static_cast<std::size_t>((edge + k) % 4)];
    out[static_cast<std::size_t>(2 + k)] =
        cell + Eigen::Vector3i::Unit(axis) + uv[0] * Eigen::Vector3i::Unit(b) + uv[1] * Eigen::Vector3i::Unit(c);
  }
  if (swap_[static_cast<std::size_t>(4 * axis + edge)]) std::swap(out[2], out[3]);
  return out;
}

std::array<BccLattice::Key, 4> BccLattice::face_corners(const Eigen::Vector3i& cell, int axis) const {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  std::array<Key, 4> out;
  for (std::size_t q = 0; q < 4; ++q)
    out[q] = corner_key(cell + Eigen::Vector3i::Unit(axis) + kFaceCorners[q][0] * Eigen::Vector3i::Unit(b) +
                        kFaceCorners[q][1] * Eigen::Vector3i::Unit(c));
  return out;
}

std::array<BccLattice::Key, 4> BccLattice::tet_nodes(const Eigen::Vector3i& cell, int axis, int edge) const {
  const auto ijk = tet_node_coordinates(cell, axis, edge);
  return {centre_key(ijk[0]), centre_key(ijk[1]), corner_key(ijk[2]), corner_key(ijk[3])};
}

std::array<Eigen::Vector3d, 4> BccLattice::tet_positions(const Eigen::Vector3i& cell, int axis, int edge) const {
  const auto ijk = tet_node_coordinates(cell, axis, edge);
  // position()'s expression, so the same bits.
  auto at = [&](const Eigen::Vector3i& n, double shift) -> Eigen::Vector3d {
    return origin_ + h_ * Eigen::Vector3d(static_cast<double>(Key{n.x()}) + shift, static_cast<double>(Key{n.y()}) + shift,
                                          static_cast<double>(Key{n.z()}) + shift);
  };
  return {at(ijk[0], 0.5), at(ijk[1], 0.5), at(ijk[2], 0.0), at(ijk[3], 0.0)};
}

Eigen::Vector3i BccLattice::cell_of(const Eigen::Vector3d& p) const {
  return floor_cell((p - origin_) / h_);
}

std::optional<BccLattice::Key> BccLattice::locate(const Eigen::Vector3d& p) const {
  return locate_units((p - origin_) / h_);
}

std::optional<BccLattice::Key> BccLattice::locate_units(const Eigen::Vector3d& q) const {
  if (!q.allFinite()) return std::nullopt;
  const Eigen::Vector3i cell = floor_cell(q);  // cell_of(p), bit for bit
  if ((cell.array() < 0).any() || (cell.array() >= cells_.array()).any()) return std::nullopt;
  const Eigen::Vector3d d = q - cell.cast<double>() - Eigen::Vector3d::Constant(0.5);
  int axis = 0;
  d.cwiseAbs().maxCoeff(&axis);
  Eigen::Vector3i lower = cell;
  if (d[axis] < 0.0) lower[axis] -= 1;  // the pyramid toward the lower face
  if (lower[axis] < 0 || lower[axis] + 1 >= cells_[axis]) return std::nullopt;
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  int edge = 0;
  if (std::abs(d[b]) >= std::abs(d[c])) {
    edge = d[b] >= 0.0 ? 1 : 3;  // the face edge at u = 1 or u = 0
  } else {
    edge = d[c] >= 0.0 ? 2 : 0;  // at v = 1 or v = 0
  }
  return tet_key(lower, axis, edge);
}

Eigen::Vector4d BccLattice::barycentric(Key tet, const Eigen::Vector3d& p) const {
  const Eigen::Vector3d x0 = position(tet_nodes(tet)[0]);
  const Eigen::Vector3d l = Dm_inv(tet) * (p - x0);
  return {1.0 - l.sum(), l.x(), l.y(), l.z()};
}

}  // namespace goo
