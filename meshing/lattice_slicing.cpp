#include "meshing/lattice_slicing.h"

#include <algorithm>
#include <cmath>
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

/// The crossing of edge pq with the plane, from the endpoints in a fixed
/// (lexicographic) order, so the two faces sharing an edge get the same
/// point, bit for bit, and the cap's duplicates are found by equality.
Eigen::Vector3d crossing(const Eigen::Vector3d& p, double dp, const Eigen::Vector3d& q, double dq) {
  const bool swap = std::lexicographical_compare(q.data(), q.data() + 3, p.data(), p.data() + 3);
  const Eigen::Vector3d& a = swap ? q : p;
  const Eigen::Vector3d& b = swap ? p : q;
  const double da = swap ? dq : dp, db = swap ? dp : dq;
  return a + (b - a) * (da / (da - db));
}

/// The cut's points (each crossing twice, once per face of its edge).
struct Cut {
  static constexpr int kCapacity = 64;
  std::array<Eigen::Vector3d, kCapacity> p;
  int size = 0;
  void push(const Eigen::Vector3d& x) {
    if (size < kCapacity) p[static_cast<std::size_t>(size++)] = x;
  }
};

void assign_face(Face& to, const Face& from) {
  to.size = from.size;
  std::copy(from.v.begin(), from.v.begin() + from.size, to.v.begin());
}

/// Splits `in` by the plane s = k into `below` (s ≤ k) and `above` (s ≥ k),
/// each closed by the cut as a new face. Distances within `tolerance` count
/// as on the plane; a face lying on it is dropped (the cut replaces it).
void split(const Piece& in, const Family& family, double k, double tolerance, Piece& below, Piece& above) {
  below.size = above.size = 0;
  Cut cut;
  std::array<double, Face::kCapacity> d{};
  for (int f = 0; f < in.size; ++f) {
    const Face& face = in.faces[static_cast<std::size_t>(f)];
    bool off = false;
    for (int i = 0; i < face.size; ++i) {
      const double di = family.s(face.v[static_cast<std::size_t>(i)]) - k;
      d[static_cast<std::size_t>(i)] = std::abs(di) <= tolerance ? 0.0 : di;
      off |= di != 0.0 && std::abs(di) > tolerance;
    }
    if (!off) {
      for (int i = 0; i < face.size; ++i) cut.push(face.v[static_cast<std::size_t>(i)]);
      continue;
    }
    Face& lower = below.faces[static_cast<std::size_t>(below.size)];
    Face& upper = above.faces[static_cast<std::size_t>(above.size)];
    lower.size = upper.size = 0;
    for (int i = 0; i < face.size; ++i) {
      const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>((i + 1) % face.size);
      if (d[a] <= 0.0) push(lower, face.v[a]);
      if (d[a] >= 0.0) push(upper, face.v[a]);
      if (d[a] == 0.0) cut.push(face.v[a]);
      if ((d[a] < 0.0 && d[b] > 0.0) || (d[a] > 0.0 && d[b] < 0.0)) {
        const Eigen::Vector3d x = crossing(face.v[a], d[a], face.v[b], d[b]);
        push(lower, x);
        push(upper, x);
        cut.push(x);
      }
    }
    if (lower.size >= 3 && below.size + 1 < Piece::kCapacity) ++below.size;
    if (upper.size >= 3 && above.size + 1 < Piece::kCapacity) ++above.size;
  }
  if (cut.size < 3) return;
  // The cap: the cut's points counter-clockwise about ∇s (the outward normal
  // of the part below), by a pseudo-angle (monotone in the angle, no
  // trigonometry); equal points are adjacent after sorting and kept once.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < cut.size; ++i) centre += cut.p[static_cast<std::size_t>(i)];
  centre /= static_cast<double>(cut.size);
  std::array<std::pair<double, int>, Cut::kCapacity> around;
  for (int i = 0; i < cut.size; ++i) {
    const Eigen::Vector3d r = cut.p[static_cast<std::size_t>(i)] - centre;
    const double x = r.dot(family.e1), y = r.dot(family.e2);
    const double norm = std::abs(x) + std::abs(y);
    const double t = norm > 0.0 ? y / norm : 0.0;  // in [−1, 1] along the diamond
    around[static_cast<std::size_t>(i)] = {x >= 0.0 ? t : (y >= 0.0 ? 2.0 - t : -2.0 - t), i};
  }
  std::sort(around.begin(), around.begin() + cut.size);
  Face cap;
  for (int i = 0; i < cut.size; ++i) {
    const Eigen::Vector3d& p = cut.p[static_cast<std::size_t>(around[static_cast<std::size_t>(i)].second)];
    if (cap.size == 0 || p != cap.v[static_cast<std::size_t>(cap.size - 1)]) push(cap, p);
  }
  if (cap.size >= 3 && cap.v[0] == cap.v[static_cast<std::size_t>(cap.size - 1)]) --cap.size;
  if (cap.size < 3) return;
  if (below.size > 0 && below.size < Piece::kCapacity) assign_face(below.faces[static_cast<std::size_t>(below.size++)], cap);
  if (above.size > 0 && above.size < Piece::kCapacity) {
    Face& reversed = above.faces[static_cast<std::size_t>(above.size++)];
    reversed.size = cap.size;
    for (int i = 0; i < cap.size; ++i)
      reversed.v[static_cast<std::size_t>(i)] = cap.v[static_cast<std::size_t>(cap.size - 1 - i)];
  }
}

/// Volume of a closed piece: Σ over faces of the cones from one vertex
/// (divergence theorem; the faces through the apex add nothing).
double volume(const Piece& piece) {
  if (piece.size < 4) return 0.0;
  const Eigen::Vector3d& apex = piece.faces[0].v[0];
  double six_v = 0.0;
  for (int f = 1; f < piece.size; ++f) {
    const Face& face = piece.faces[static_cast<std::size_t>(f)];
    const Eigen::Vector3d a = face.v[0] - apex;
    for (int i = 1; i + 1 < face.size; ++i)
      six_v += a.dot((face.v[static_cast<std::size_t>(i)] - apex).cross(face.v[static_cast<std::size_t>(i + 1)] - apex));
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
  tet.size = 4;
  for (std::size_t k = 0; k < 4; ++k) {
    Face& face = tet.faces[k];
    face.size = 3;
    for (std::size_t i = 0; i < 3; ++i) face.v[i] = u[static_cast<std::size_t>(kTetFaces[k][i])];
  }
  current_.assign(1, 0);
  for (const Family& family : kFamilies) {
    next_.clear();
    for (const std::size_t first : current_) {
      // Slice at each plane of the family inside the piece, lowest first:
      // the part below is done with this family, the part above goes on.
      std::size_t piece = first;
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      const Piece& in = pool_[piece];
      for (int f = 0; f < in.size; ++f)
        for (int i = 0; i < in.faces[static_cast<std::size_t>(f)].size; ++i) {
          const double s = family.s(in.faces[static_cast<std::size_t>(f)].v[static_cast<std::size_t>(i)]);
          lo = std::min(lo, s);
          hi = std::max(hi, s);
        }
      // The part above the plane k reaches from k to hi: the next plane is k + 1.
      for (double k = std::floor(lo + tolerance) + 1.0;; k += 1.0) {
        if (!(k < hi - tolerance)) {
          next_.push_back(piece);
          break;
        }
        reserve(2);  // before taking references into the pool
        const std::size_t below = pool_count_++, above = pool_count_++;
        split(pool_[piece], family, k, tolerance, pool_[below], pool_[above]);
        if (pool_[below].size >= 4) next_.push_back(below);
        if (pool_[above].size < 4) break;
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
    int n = 0;
    for (int f = 0; f < piece.size; ++f)
      for (int i = 0; i < piece.faces[static_cast<std::size_t>(f)].size; ++i, ++n)
        mean += piece.faces[static_cast<std::size_t>(f)].v[static_cast<std::size_t>(i)];
    const std::optional<BccLattice::Key> key = lattice.locate(lattice.origin() + (h / n) * mean);
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
    for (std::size_t index = 0; index < count; ++index) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      {
        const Face& piece = polygons_[index];
        for (int i = 0; i < piece.size; ++i) {
          const double s = family.s(piece.v[static_cast<std::size_t>(i)]);
          lo = std::min(lo, s);
          hi = std::max(hi, s);
        }
      }
      double k = std::floor(lo + tolerance) + 1.0;
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
          const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>((i + 1) % piece.size);
          if (d[a] <= 0.0) push(below, piece.v[a]);
          if (d[a] >= 0.0) push(above, piece.v[a]);
          if ((d[a] < 0.0 && d[b] > 0.0) || (d[a] > 0.0 && d[b] < 0.0)) {
            const Eigen::Vector3d x = crossing(piece.v[a], d[a], piece.v[b], d[b]);
            push(below, x);
            push(above, x);
          }
        }
        if (below.size >= 3) {
          if (first_part) {
            polygons_[index] = below;
            first_part = false;
          } else {
            polygons_.push_back(below);
          }
        }
        if (above.size < 3) break;
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
