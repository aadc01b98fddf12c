#include "meshing/lattice_slicing.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

#include "meshing/convex_clip.h"

namespace goo {
namespace {

using Face = LatticeSlicer::Face;
using Piece = LatticeSlicer::Piece;

/// The planes s(u) = u_a + sign u_b = k, and a basis (e1, e2) of the plane
/// with e1 × e2 along +∇s, to order a cut's points counter-clockwise.
struct Family {
  int a, b;
  double sign;
  Eigen::Vector3d e1, e2;
  [[nodiscard]] double s(const Eigen::Vector3d& u) const { return u[a] + sign * u[b]; }
};

std::array<Family, 6> make_families() {
  std::array<Family, 6> out;
  int i = 0;
  for (const auto& [a, b] : {std::pair{0, 1}, std::pair{1, 2}, std::pair{0, 2}})
    for (const double sign : {1.0, -1.0}) {
      const Eigen::Vector3d n = (Eigen::Vector3d::Unit(a) + sign * Eigen::Vector3d::Unit(b)).normalized();
      const Eigen::Vector3d e1 = n.unitOrthogonal();
      out[static_cast<std::size_t>(i++)] = {a, b, sign, e1, n.cross(e1)};
    }
  return out;
}

const std::array<Family, 6> kFamilies = make_families();

void push(Face& face, const Eigen::Vector3d& p) {
  if (face.size < Face::kCapacity) face.v[static_cast<std::size_t>(face.size++)] = p;
}

/// The block's range of s: u lies in [0, cells] along each axis.
std::pair<double, double> block_range(const Family& family, const Eigen::Vector3i& cells) {
  const auto ca = static_cast<double>(cells[family.a]), cb = static_cast<double>(cells[family.b]);
  return family.sign > 0.0 ? std::pair{0.0, ca + cb} : std::pair{-cb, ca};
}

/// The least and greatest s over points [begin, end).
template <class It>
std::pair<double, double> extent(const Family& family, It begin, It end) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (It p = begin; p != end; ++p) {
    const double s = family.s(*p);
    lo = std::min(lo, s);
    hi = std::max(hi, s);
  }
  return {lo, hi};
}

/// Splits `in` by the plane s = k into `below` (s ≤ k) and `above` (s ≥ k),
/// each closed by the cut as a new face. Distances within `tolerance` count
/// as on the plane (such a vertex goes to both parts); a face lying on it is
/// dropped (the cut replaces it). Each vertex's distance and each edge's
/// crossing are computed once, for all the faces that share them (the
/// crossings found again through `table`, the slicer's, reused split to
/// split).
void split(const Piece& in, const Family& family, double k, double tolerance, Piece& below, Piece& above,
           LatticeSlicer::Crossings& table) {
  constexpr std::uint8_t kNone = 0xff;
  below.num_vertices = above.num_vertices = below.num_faces = above.num_faces = 0;
  std::array<double, Piece::kVertices> d;
  std::array<std::uint8_t, Piece::kVertices> to_below, to_above;
  // The cut's vertices, as their indices in both parts.
  std::array<std::array<std::uint8_t, 2>, Piece::kVertices> cut;
  int cut_size = 0;
  auto add = [](Piece& piece, const Eigen::Vector3d& p) -> std::uint8_t {
    if (piece.num_vertices == Piece::kVertices) return kNone;
    piece.v[static_cast<std::size_t>(piece.num_vertices)] = p;
    return static_cast<std::uint8_t>(piece.num_vertices++);
  };
  for (int i = 0; i < in.num_vertices; ++i) {
    const auto at = static_cast<std::size_t>(i);
    const double di = family.s(in.v[at]) - k;
    d[at] = std::abs(di) <= tolerance ? 0.0 : di;
    to_below[at] = d[at] <= 0.0 ? add(below, in.v[at]) : kNone;
    to_above[at] = d[at] >= 0.0 ? add(above, in.v[at]) : kNone;
    if (d[at] == 0.0 && cut_size < Piece::kVertices) cut[static_cast<std::size_t>(cut_size++)] = {to_below[at], to_above[at]};
  }
  // Crossings of edges, from their lower-index end: one point an edge.
  struct Crossing {
    std::uint8_t lo, hi, below, above;
  };
  std::array<Crossing, Piece::kVertices> crossings;
  int num_crossings = 0;
  // Each edge's crossing is found again from its other face: looked up by
  // the edge (LatticeSlicer::Crossings).
  table.next();
  auto crossing = [&](std::uint8_t i, std::uint8_t j) -> Crossing {
    const std::uint8_t lo = std::min(i, j), hi = std::max(i, j);
    const std::size_t key = std::size_t{lo} * Piece::kVertices + hi;
    if (table.stamp[key] == table.generation) return crossings[table.index[key]];
    const double dl = d[lo], dh = d[hi];
    const Eigen::Vector3d x = in.v[lo] + (in.v[hi] - in.v[lo]) * (dl / (dl - dh));
    const Crossing made = {lo, hi, add(below, x), add(above, x)};
    if (num_crossings < Piece::kVertices) {
      table.stamp[key] = table.generation;
      table.index[key] = static_cast<std::uint8_t>(num_crossings);
      crossings[static_cast<std::size_t>(num_crossings++)] = made;
    }
    if (cut_size < Piece::kVertices) cut[static_cast<std::size_t>(cut_size++)] = {made.below, made.above};
    return made;
  };
  auto push = [](Piece& piece, std::uint8_t vertex) {
    const auto f = static_cast<std::size_t>(piece.num_faces);
    if (vertex != kNone && piece.face_size[f] < Piece::kFaceVertices) piece.face[f][piece.face_size[f]++] = vertex;
  };
  for (int f = 0; f < in.num_faces; ++f) {
    const auto& face = in.face[static_cast<std::size_t>(f)];
    const int n = in.face_size[static_cast<std::size_t>(f)];
    bool off = false;
    for (int i = 0; i < n; ++i) off |= d[face[static_cast<std::size_t>(i)]] != 0.0;
    if (!off) continue;  // on the plane: the cut replaces it
    if (below.num_faces == Piece::kFaces || above.num_faces == Piece::kFaces) break;
    below.face_size[static_cast<std::size_t>(below.num_faces)] = 0;
    above.face_size[static_cast<std::size_t>(above.num_faces)] = 0;
    for (int i = 0; i < n; ++i) {
      const std::uint8_t a = face[static_cast<std::size_t>(i)],
                         b = face[static_cast<std::size_t>(i + 1 < n ? i + 1 : 0)];
      if (d[a] <= 0.0) push(below, to_below[a]);
      if (d[a] >= 0.0) push(above, to_above[a]);
      if ((d[a] < 0.0 && d[b] > 0.0) || (d[a] > 0.0 && d[b] < 0.0)) {
        const Crossing x = crossing(a, b);
        push(below, x.below);
        push(above, x.above);
      }
    }
    if (below.face_size[static_cast<std::size_t>(below.num_faces)] >= 3) ++below.num_faces;
    if (above.face_size[static_cast<std::size_t>(above.num_faces)] >= 3) ++above.num_faces;
  }
  if (cut_size < 3 || below.num_faces == 0 || above.num_faces == 0) return;
  // The cap: the cut's vertices counter-clockwise about ∇s (the outward
  // normal of the part below), by a pseudo-angle about their mean (monotone
  // in the angle, no trigonometry).
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < cut_size; ++i) centre += below.v[cut[static_cast<std::size_t>(i)][0]];
  centre /= static_cast<double>(cut_size);
  struct Around {  // no initialisers: only the cut's first cut_size are written and read
    double angle;
    int index;
    bool operator<(const Around& o) const { return angle < o.angle || (angle == o.angle && index < o.index); }
  };
  std::array<Around, Piece::kVertices> around;
  for (int i = 0; i < cut_size; ++i) {
    const Eigen::Vector3d r = below.v[cut[static_cast<std::size_t>(i)][0]] - centre;
    const double x = r.dot(family.e1), y = r.dot(family.e2);
    const double norm = std::abs(x) + std::abs(y);
    const double t = norm > 0.0 ? y / norm : 0.0;  // in [−1, 1] along the diamond
    around[static_cast<std::size_t>(i)] = {x >= 0.0 ? t : (y >= 0.0 ? 2.0 - t : -2.0 - t), i};
  }
  std::sort(around.begin(), around.begin() + cut_size);
  if (below.num_faces < Piece::kFaces) {
    const auto f = static_cast<std::size_t>(below.num_faces++);
    below.face_size[f] = 0;
    for (int i = 0; i < cut_size && below.face_size[f] < Piece::kFaceVertices; ++i)
      below.face[f][below.face_size[f]++] = cut[static_cast<std::size_t>(around[static_cast<std::size_t>(i)].index)][0];
  }
  if (above.num_faces < Piece::kFaces) {
    const auto f = static_cast<std::size_t>(above.num_faces++);
    above.face_size[f] = 0;
    for (int i = cut_size - 1; i >= 0 && above.face_size[f] < Piece::kFaceVertices; --i)
      above.face[f][above.face_size[f]++] = cut[static_cast<std::size_t>(around[static_cast<std::size_t>(i)].index)][1];
  }
}

/// Volume of a closed piece: Σ over faces of the cones from one vertex
/// (divergence theorem; the faces through the apex add nothing).
double volume(const Piece& piece) {
  if (piece.num_faces < 4) return 0.0;
  const Eigen::Vector3d& apex = piece.v[0];
  double six_v = 0.0;
  for (int f = 0; f < piece.num_faces; ++f) {
    const auto& face = piece.face[static_cast<std::size_t>(f)];
    const Eigen::Vector3d a = piece.v[face[0]] - apex;
    for (int i = 1; i + 1 < piece.face_size[static_cast<std::size_t>(f)]; ++i)
      six_v += a.dot((piece.v[face[static_cast<std::size_t>(i)]] - apex).cross(piece.v[face[static_cast<std::size_t>(i + 1)]] - apex));
  }
  return six_v / 6.0;
}

}  // namespace

void LatticeSlicer::reserve(std::size_t more) {
  if (pool_.size() < pool_count_ + more) pool_.resize(pool_count_ + more);
}

void LatticeSlicer::overlaps(const BccLattice& lattice, const std::array<Eigen::Vector3d, 4>& x, double tolerance,
                             std::vector<std::pair<BccLattice::Key, double>>& out) {
  out.clear();
  const double h = lattice.spacing();
  std::array<Eigen::Vector3d, 4> u;
  for (std::size_t k = 0; k < 4; ++k) u[k] = (x[k] - lattice.origin()) / h;
  // Pieces live in the pool; the lists hold their indices, so a piece that
  // a family does not cut passes on without a copy.
  pool_count_ = 0;
  reserve(1);
  Piece& tet = pool_[pool_count_++];
  tet.num_vertices = 4;
  tet.num_faces = 4;
  for (std::size_t k = 0; k < 4; ++k) {
    tet.v[k] = u[k];
    tet.face_size[k] = 3;
    for (std::size_t i = 0; i < 3; ++i) tet.face[k][i] = static_cast<std::uint8_t>(kTetFaces[k][i]);
  }
  current_.assign(1, 0);
  for (const Family& family : kFamilies) {
    next_.clear();
    const auto [s_min, s_max] = block_range(family, lattice.cells());
    for (const std::size_t first : current_) {
      // Slice at each plane of the family inside the piece, lowest first:
      // the part below is done with this family, the part above goes on.
      // Parts outside the block's range of s are dropped (so an element
      // reaching far out costs no more than the block), and so is a piece
      // that is not finite.
      std::size_t piece = first;
      const Piece& in = pool_[piece];
      const auto [lo, hi] = extent(family, in.v.begin(), in.v.begin() + in.num_vertices);
      if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= s_min + tolerance || lo >= s_max - tolerance) continue;
      double k = std::floor(lo + tolerance) + 1.0;
      bool below_outside = false;
      if (k <= s_min) {
        k = s_min;
        below_outside = true;
      }
      // The part above the plane k reaches from k to hi: the next plane is k + 1.
      for (;; k += 1.0) {
        if (!(k < hi - tolerance)) {
          next_.push_back(piece);
          break;
        }
        reserve(2);  // before taking references into the pool
        const std::size_t below = pool_count_++, above = pool_count_++;
        split(pool_[piece], family, k, tolerance, pool_[below], pool_[above], crossings_);
        if (pool_[below].num_faces >= 4 && !below_outside) next_.push_back(below);
        below_outside = false;
        if (k >= s_max || pool_[above].num_faces < 4) break;  // above s_max: outside the block
        piece = above;
      }
    }
    std::swap(current_, next_);
  }
  const double h3 = h * h * h;
  for (const std::size_t p : current_) {
    const Piece& piece = pool_[p];
    const double v = volume(piece);
    if (!(v > 0.0)) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i = 0; i < piece.num_vertices; ++i) mean += piece.v[static_cast<std::size_t>(i)];
    const std::optional<BccLattice::Key> key = lattice.locate(lattice.origin() + (h / piece.num_vertices) * mean);
    if (key) out.emplace_back(*key, v * h3);
  }
  std::sort(out.begin(), out.end());
  std::size_t kept = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (kept > 0 && out[kept - 1].first == out[i].first)
      out[kept - 1].second += out[i].second;
    else
      out[kept++] = out[i];
  }
  out.resize(kept);
}

void LatticeSlicer::polygon_parts(const BccLattice& lattice, const Polygon& polygon, double tolerance,
                                  std::vector<PolygonPart>& out) {
  out.clear();
  const double h = lattice.spacing();
  polygons_.resize(1);
  Face& first = polygons_[0];
  first.size = 0;
  for (int i = 0; i < polygon.size; ++i) push(first, (polygon.v[static_cast<std::size_t>(i)] - lattice.origin()) / h);
  std::array<double, Face::kCapacity> d{};
  for (const Family& family : kFamilies) {
    // A polygon the family does not cut stays where it is; one it cuts is
    // replaced by its lowest part, the others appended (and not looked at
    // again for this family).
    const std::size_t count = polygons_.size();
    const auto [s_min, s_max] = block_range(family, lattice.cells());
    for (std::size_t index = 0; index < count; ++index) {
      if (polygons_[index].size == 0) continue;
      const auto [lo, hi] =
          extent(family, polygons_[index].v.begin(), polygons_[index].v.begin() + polygons_[index].size);
      // Outside the block's range of s, or not finite: dropped.
      if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= s_min + tolerance || lo >= s_max - tolerance) {
        polygons_[index].size = 0;
        continue;
      }
      double k = std::floor(lo + tolerance) + 1.0;
      bool below_outside = false;
      if (k <= s_min) {
        k = s_min;
        below_outside = true;
      }
      if (!(k < hi - tolerance)) continue;
      Face piece = polygons_[index];
      bool first_part = true;
      for (;; k += 1.0) {
        if (!(k < hi - tolerance)) {
          polygons_.push_back(piece);
          break;
        }
        // Sutherland–Hodgman to both sides at once.
        Face below, above;
        for (int i = 0; i < piece.size; ++i) {
          const double di = family.s(piece.v[static_cast<std::size_t>(i)]) - k;
          d[static_cast<std::size_t>(i)] = std::abs(di) <= tolerance ? 0.0 : di;
        }
        for (int i = 0; i < piece.size; ++i) {
          const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>(i + 1 < piece.size ? i + 1 : 0);
          if (d[a] <= 0.0) push(below, piece.v[a]);
          if (d[a] >= 0.0) push(above, piece.v[a]);
          if ((d[a] < 0.0 && d[b] > 0.0) || (d[a] > 0.0 && d[b] < 0.0)) {
            const Eigen::Vector3d x = edge_crossing(piece.v[a], d[a], piece.v[b], d[b]);
            push(below, x);
            push(above, x);
          }
        }
        if (below.size >= 3 && !below_outside) {
          if (first_part) {
            polygons_[index] = below;
            first_part = false;
          } else {
            polygons_.push_back(below);
          }
        }
        below_outside = false;
        if (k >= s_max || above.size < 3) break;  // above s_max: outside the block
        piece = above;
      }
      if (first_part) polygons_[index].size = 0;  // nothing below the first plane: dropped
    }
  }
  for (const Face& piece : polygons_) {
    if (piece.size < 3 || piece.size > Polygon::kCapacity) continue;  // cannot happen: a part has at most 7 vertices
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i = 0; i < piece.size; ++i) mean += piece.v[static_cast<std::size_t>(i)];
    // Twice the area vector: no area, no part.
    Eigen::Vector3d area = Eigen::Vector3d::Zero();
    for (int i = 1; i + 1 < piece.size; ++i)
      area += (piece.v[static_cast<std::size_t>(i)] - piece.v[0]).cross(piece.v[static_cast<std::size_t>(i + 1)] - piece.v[0]);
    if (area.squaredNorm() == 0.0) continue;
    const std::optional<BccLattice::Key> key = lattice.locate(lattice.origin() + (h / piece.size) * mean);
    if (!key) continue;
    PolygonPart& part = out.emplace_back();
    part.key = *key;
    part.polygon.size = 0;
    for (int i = 0; i < piece.size; ++i) part.polygon.push(lattice.origin() + h * piece.v[static_cast<std::size_t>(i)]);
  }
}

}  // namespace goo
