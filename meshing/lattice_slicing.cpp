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

/// The planes s(u) = u_a + sign u_b = k.
struct Family {
  int a, b;
  double sign;
  [[nodiscard]] double s(const Eigen::Vector3d& u) const { return u[a] + sign * u[b]; }
};

std::array<Family, 6> make_families() {
  std::array<Family, 6> out;
  int i = 0;
  for (const auto& [a, b] : {std::pair{0, 1}, std::pair{1, 2}, std::pair{0, 2}})
    for (const double sign : {1.0, -1.0}) out[static_cast<std::size_t>(i++)] = {a, b, sign};
  return out;
}

const std::array<Family, 6> kFamilies = make_families();

void push(Face& face, const Eigen::Vector3d& p) {
  if (face.size < Face::kCapacity) face.v[static_cast<std::size_t>(face.size++)] = p;
}

/// floor(x) for x of magnitude below 2⁶³ (the callers' x lies in the
/// block's range of s, under 2³²): the bits of std::floor, the conversion
/// toward zero moved down where it rounded up.
double floor_in_block(double x) {
  const double t = static_cast<double>(static_cast<std::int64_t>(x));
  return t > x ? t - 1.0 : t;
}

/// `to` made a copy of `from`, moving only the vertices in use.
void copy_face(const Face& from, Face& to) {
  to.size = from.size;
  for (int i = 0; i < from.size; ++i) to.v[static_cast<std::size_t>(i)] = from.v[static_cast<std::size_t>(i)];
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

/// Vertex i's neighbours in a positively oriented tetrahedron,
/// counter-clockwise seen from outside, from its faces (kTetFaces, each
/// counter-clockwise seen from outside): walking a face a → b → c leaves b
/// along the edge before the one it came by, so c comes just before a
/// about b.
std::array<std::array<std::uint8_t, 3>, 4> make_tet_neighbours() {
  std::array<std::array<std::uint8_t, 3>, 4> out{};
  for (int b = 0; b < 4; ++b) {
    std::array<int, 4> before{-1, -1, -1, -1};  // before[a]: the neighbour just before a about b
    for (const auto& f : kTetFaces)
      for (int t = 0; t < 3; ++t)
        if (f[t] == b) before[static_cast<std::size_t>(f[(t + 2) % 3])] = f[(t + 1) % 3];
    const int first = b == 0 ? 1 : 0;
    auto& n = out[static_cast<std::size_t>(b)];
    n[0] = static_cast<std::uint8_t>(first);
    n[2] = static_cast<std::uint8_t>(before[static_cast<std::size_t>(first)]);
    n[1] = static_cast<std::uint8_t>(before[n[2]]);
  }
  return out;
}

const std::array<std::array<std::uint8_t, 3>, 4> kTetNeighbours = make_tet_neighbours();

/// back[i][m]: where vertex i is among the neighbours of kTetNeighbours[i][m].
std::array<std::array<std::uint8_t, 3>, 4> make_tet_back() {
  std::array<std::array<std::uint8_t, 3>, 4> out{};
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t m = 0; m < 3; ++m) {
      const auto& n = kTetNeighbours[kTetNeighbours[i][m]];
      out[i][m] = static_cast<std::uint8_t>(n[0] == i ? 0 : n[1] == i ? 1 : 2);
    }
  return out;
}

const std::array<std::array<std::uint8_t, 3>, 4> kTetBack = make_tet_back();

/// Splits `in` by the plane s = k into `below` (s < k) and `above` (s ≥ k):
/// each vertex goes to its side, each edge with ends on both sides gets a new
/// vertex in each part at the same point, and the new vertices of a part are
/// joined into its cap by walking, from each, the face its edge's kept end
/// leads into until the next new vertex. Distances within `tolerance` count
/// as on the plane (such a vertex goes above, and an edge from it to below
/// is cut at the vertex itself). False if a part would have more than
/// Piece::kVertices vertices or a walk does not close (a graph round-off
/// left inconsistent with a plane): the caller then takes another way.
bool split(const Piece& in, const Family& family, double k, double tolerance, Piece& below, Piece& above) {
  const int n = in.num_vertices;
  std::array<double, Piece::kVertices> d;
  std::array<std::uint8_t, Piece::kVertices> index;  // vertex i's index in its part
  int num_below = 0, num_above = 0;
  for (int i = 0; i < n; ++i) {
    const auto at = static_cast<std::size_t>(i);
    const double di = family.s(in.v[at]) - k;
    d[at] = std::abs(di) <= tolerance ? 0.0 : di;
    if (d[at] < 0.0) {
      index[at] = static_cast<std::uint8_t>(num_below);
      below.v[static_cast<std::size_t>(num_below++)] = in.v[at];
    } else {
      index[at] = static_cast<std::uint8_t>(num_above);
      above.v[static_cast<std::size_t>(num_above++)] = in.v[at];
    }
  }
  const int first_below = num_below, first_above = num_above;
  for (int i = 0; i < n; ++i) {
    const auto at = static_cast<std::size_t>(i);
    const bool is_below = d[at] < 0.0;
    Piece& part = is_below ? below : above;
    int& count = is_below ? num_below : num_above;
    const std::size_t me = index[at];
    for (std::size_t m = 0; m < 3; ++m) {
      const std::uint8_t j = in.next[at][m];
      if ((d[j] < 0.0) == is_below) {
        part.next[me][m] = index[j];
        part.back[me][m] = in.back[at][m];
        continue;
      }
      if (count == Piece::kVertices) return false;
      // The crossing from the lower end, so both parts get the same point.
      const std::size_t lo = is_below ? at : j, hi = is_below ? j : at;
      const auto w = static_cast<std::size_t>(count++);
      part.v[w] = in.v[lo] + (in.v[hi] - in.v[lo]) * (d[lo] / (d[lo] - d[hi]));
      part.next[w][0] = static_cast<std::uint8_t>(me);
      part.back[w][0] = static_cast<std::uint8_t>(m);
      part.next[me][m] = static_cast<std::uint8_t>(w);
      part.back[me][m] = 0;
    }
  }
  below.num_vertices = num_below;
  above.num_vertices = num_above;
  // The caps: from new vertex w, the face through w → its kept end is walked
  // (counter-clockwise from outside) to the next new vertex u; the cap edge
  // u → w closes that face, so u is w's neighbour after the kept end and w
  // is u's before it.
  auto close = [](Piece& part, int first_new) {
    for (int w = first_new; w < part.num_vertices; ++w) {
      const auto ws = static_cast<std::size_t>(w);
      std::size_t at = part.next[ws][0], slot = part.back[ws][0];  // at, reached by its edge `slot`
      for (int steps = 0; at < static_cast<std::size_t>(first_new); ++steps) {
        if (steps == part.num_vertices) return false;
        const std::size_t leave = slot == 0 ? 2 : slot - 1;
        slot = part.back[at][leave];
        at = part.next[at][leave];
      }
      part.next[ws][1] = static_cast<std::uint8_t>(at);
      part.back[ws][1] = 2;
      part.next[at][2] = static_cast<std::uint8_t>(w);
      part.back[at][2] = 1;
    }
    return true;
  };
  return close(below, first_below) && close(above, first_above);
}

/// Volume of a closed piece: Σ over faces of the cones from one vertex
/// (divergence theorem), each face walked once, from the first of its
/// edges met unwalked.
double volume(const Piece& piece) {
  const int n = piece.num_vertices;
  if (n < 4) return 0.0;
  const Eigen::Vector3d& apex = piece.v[0];
  std::array<std::uint8_t, Piece::kVertices> walked{};  // bit m: the edge along next[i][m] walked
  double six_v = 0.0;
  for (std::size_t i = 1; i < static_cast<std::size_t>(n); ++i)  // faces through the apex add nothing
    for (std::size_t m = 0; m < 3; ++m) {
      if (walked[i] & (1U << m)) continue;
      walked[i] = static_cast<std::uint8_t>(walked[i] | (1U << m));
      const Eigen::Vector3d a = piece.v[i] - apex;
      std::size_t b = piece.next[i][m], slot = piece.back[i][m];
      Eigen::Vector3d pb = piece.v[b] - apex;
      for (int steps = 0; steps < n; ++steps) {
        const std::size_t leave = slot == 0 ? 2 : slot - 1;
        walked[b] = static_cast<std::uint8_t>(walked[b] | (1U << leave));
        const std::size_t c = piece.next[b][leave];
        if (c == i) break;
        slot = piece.back[b][leave];
        const Eigen::Vector3d pc = piece.v[c] - apex;
        six_v += a.dot(pb.cross(pc));
        b = c;
        pb = pc;
      }
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
  for (std::size_t k = 0; k < 4; ++k) {
    tet.v[k] = u[k];
    tet.next[k] = kTetNeighbours[k];
    tet.back[k] = kTetBack[k];
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
      // The first plane above lo: s_min when lo is below the block.
      bool below_outside = lo + tolerance < s_min;
      double k = below_outside ? s_min : floor_in_block(lo + tolerance) + 1.0;
      // The part above the plane k reaches from k to hi: the next plane is k + 1.
      for (;; k += 1.0) {
        if (!(k < hi - tolerance)) {
          next_.push_back(piece);
          break;
        }
        reserve(2);  // before taking references into the pool
        const std::size_t below = pool_count_++, above = pool_count_++;
        if (!split(pool_[piece], family, k, tolerance, pool_[below], pool_[above])) {
          ++fallbacks_;
          overlaps_by_clipping(lattice, x, tolerance, out);
          return;
        }
        if (!below_outside) next_.push_back(below);
        below_outside = false;
        if (k >= s_max) break;  // above s_max: outside the block
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
    const std::optional<BccLattice::Key> key = lattice.locate_units(mean / piece.num_vertices);
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

void overlaps_by_clipping(const BccLattice& lattice, const std::array<Eigen::Vector3d, 4>& x, double tolerance,
                          std::vector<std::pair<BccLattice::Key, double>>& out) {
  out.clear();
  for (const Eigen::Vector3d& p : x)
    if (!p.allFinite()) return;
  const Eigen::Vector3d lo = x[0].cwiseMin(x[1]).cwiseMin(x[2]).cwiseMin(x[3]);
  const Eigen::Vector3d hi = x[0].cwiseMax(x[1]).cwiseMax(x[2]).cwiseMax(x[3]);
  lattice.for_each_tet_near(lo, hi, [&](BccLattice::Key key) {
    const auto nodes = lattice.tet_nodes(key);
    const std::array<Eigen::Vector3d, 4> t = {lattice.position(nodes[0]), lattice.position(nodes[1]),
                                              lattice.position(nodes[2]), lattice.position(nodes[3])};
    const double v = tet_overlap_volume(t, x, tolerance * lattice.spacing());
    if (v > 0.0) out.emplace_back(key, v);
  });
  std::sort(out.begin(), out.end());
}

void LatticeSlicer::polygon_parts(const BccLattice& lattice, const Polygon& polygon, double tolerance,
                                  std::vector<PolygonPart>& out) {
  out.clear();
  const double h = lattice.spacing();
  const Eigen::Vector3d& origin = lattice.origin();
  // The polygons live in polygons_[0, count): a slot is reused from call to
  // call, and each copy moves only the vertices in use.
  std::size_t count = 1;
  reserve_polygons(count);
  Face& first = polygons_[0];
  first.size = 0;
  for (int i = 0; i < polygon.size; ++i) push(first, (polygon.v[static_cast<std::size_t>(i)] - origin) / h);
  std::array<double, Face::kCapacity> d{};
  std::array<Face, 2> ahead;  // the part above the last plane, and the next one
  Face below;
  for (const Family& family : kFamilies) {
    // A polygon the family does not cut stays where it is; one it cuts is
    // replaced by its lowest part, the others appended (and not looked at
    // again for this family).
    const std::size_t before = count;
    const auto [s_min, s_max] = block_range(family, lattice.cells());
    for (std::size_t index = 0; index < before; ++index) {
      if (polygons_[index].size == 0) continue;
      const auto [lo, hi] =
          extent(family, polygons_[index].v.begin(), polygons_[index].v.begin() + polygons_[index].size);
      // Outside the block's range of s, or not finite: dropped.
      if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= s_min + tolerance || lo >= s_max - tolerance) {
        polygons_[index].size = 0;
        continue;
      }
      // The first plane above lo: s_min when lo is below the block.
      bool below_outside = lo + tolerance < s_min;
      double k = below_outside ? s_min : floor_in_block(lo + tolerance) + 1.0;
      if (!(k < hi - tolerance)) continue;
      // The piece being cut: the polygon in its slot for the first plane,
      // then the part above the last plane (the slot may by then hold the
      // lowest part).
      const Face* piece = &polygons_[index];
      std::size_t turn = 0;
      bool first_part = true;
      for (;; k += 1.0) {
        if (!(k < hi - tolerance)) {
          reserve_polygons(count + 1);
          copy_face(*piece, polygons_[count++]);
          break;
        }
        // Sutherland–Hodgman to both sides at once.
        Face& above = ahead[turn];
        turn ^= 1U;
        below.size = 0;
        above.size = 0;
        for (int i = 0; i < piece->size; ++i) {
          const double di = family.s(piece->v[static_cast<std::size_t>(i)]) - k;
          d[static_cast<std::size_t>(i)] = std::abs(di) <= tolerance ? 0.0 : di;
        }
        for (int i = 0; i < piece->size; ++i) {
          const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>(i + 1 < piece->size ? i + 1 : 0);
          if (d[a] <= 0.0) push(below, piece->v[a]);
          if (d[a] >= 0.0) push(above, piece->v[a]);
          if ((d[a] < 0.0 && d[b] > 0.0) || (d[a] > 0.0 && d[b] < 0.0)) {
            const Eigen::Vector3d x = edge_crossing(piece->v[a], d[a], piece->v[b], d[b]);
            push(below, x);
            push(above, x);
          }
        }
        if (below.size >= 3 && !below_outside) {
          if (first_part) {
            copy_face(below, polygons_[index]);
            first_part = false;
          } else {
            reserve_polygons(count + 1);
            copy_face(below, polygons_[count++]);
          }
        }
        below_outside = false;
        if (k >= s_max || above.size < 3) break;  // above s_max: outside the block
        piece = &above;
      }
      if (first_part) polygons_[index].size = 0;  // nothing below the first plane: dropped
    }
  }
  for (std::size_t index = 0; index < count; ++index) {
    const Face& piece = polygons_[index];
    if (piece.size < 3 || piece.size > Polygon::kCapacity) continue;  // cannot happen: a part has at most 7 vertices
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int i = 0; i < piece.size; ++i) mean += piece.v[static_cast<std::size_t>(i)];
    // Twice the area vector: no area, no part.
    Eigen::Vector3d area = Eigen::Vector3d::Zero();
    for (int i = 1; i + 1 < piece.size; ++i)
      area += (piece.v[static_cast<std::size_t>(i)] - piece.v[0]).cross(piece.v[static_cast<std::size_t>(i + 1)] - piece.v[0]);
    if (area.squaredNorm() == 0.0) continue;
    // Located as locate(p) would be, p the mean in world units: a part lying
    // on a lattice face keeps the tetrahedron that rounding gives it there.
    const Eigen::Vector3d p = origin + (h / piece.size) * mean;
    const std::optional<BccLattice::Key> key = lattice.locate_units((p - origin) / h);
    if (!key) continue;
    PolygonPart& part = out.emplace_back();
    part.key = *key;
    part.polygon.size = piece.size;
    for (int i = 0; i < piece.size; ++i)
      part.polygon.v[static_cast<std::size_t>(i)] = origin + h * piece.v[static_cast<std::size_t>(i)];
  }
}

void LatticeSlicer::reserve_polygons(std::size_t count) {
  if (polygons_.size() < count) polygons_.resize(std::max<std::size_t>(2 * count, 16));
}

}  // namespace goo
