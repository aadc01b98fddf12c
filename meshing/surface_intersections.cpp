#include "meshing/surface_intersections.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>

#include "core/contact/box_pairs.h"
#include "core/parallel.h"
#include "core/radix_sort.h"
#include "core/surface_geometry.h"
#include "meshing/exact_predicates.h"

namespace goo {
namespace {

using Vec3 = Eigen::Vector3d;

/// A plane projection that keeps a triangle's plane one-to-one: the axis
/// dropped is one along which the exact normal has a non-zero component.
/// orient() is then the exact orientation of the projected points.
struct Projection {
  int drop = -1;  // -1: the triangle has no area
  [[nodiscard]] int orient(const Vec3& a, const Vec3& b, const Vec3& c) const {
    switch (drop) {
      case 0: return exact::orient_yz(a, b, c);
      case 1: return exact::orient_zx(a, b, c);
      default: return exact::orient_xy(a, b, c);
    }
  }
  /// p, known to lie on the line ab (in projection), lies between a and b.
  [[nodiscard]] bool between(const Vec3& a, const Vec3& b, const Vec3& p) const {
    for (int k = 0; k < 3; ++k) {
      if (k == drop) continue;
      if (p[k] < std::min(a[k], b[k]) || p[k] > std::max(a[k], b[k])) return false;
    }
    return true;
  }
};

Projection projection_of(const Vec3& a, const Vec3& b, const Vec3& c) {
  if (exact::orient_yz(a, b, c) != 0) return {0};
  if (exact::orient_zx(a, b, c) != 0) return {1};
  if (exact::orient_xy(a, b, c) != 0) return {2};
  return {-1};
}

bool mixed(int s1, int s2, int s3) {
  return (s1 > 0 || s2 > 0 || s3 > 0) && (s1 < 0 || s2 < 0 || s3 < 0);
}

// --- In one plane, seen through a projection ------------------------------

/// The closed segments pq and rs (coplanar) meet.
bool segments_meet_2d(const Projection& pr, const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& s) {
  const int d1 = pr.orient(r, s, p), d2 = pr.orient(r, s, q);
  const int d3 = pr.orient(p, q, r), d4 = pr.orient(p, q, s);
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;
  return (d1 == 0 && pr.between(r, s, p)) || (d2 == 0 && pr.between(r, s, q)) || (d3 == 0 && pr.between(p, q, r)) ||
         (d4 == 0 && pr.between(p, q, s));
}

/// p (coplanar) lies in the closed triangle (u, v, w) of non-zero area.
bool point_in_triangle_2d(const Projection& pr, const Vec3& p, const Vec3& u, const Vec3& v, const Vec3& w) {
  return !mixed(pr.orient(u, v, p), pr.orient(v, w, p), pr.orient(w, u, p));
}

bool segment_meets_triangle_2d(const Projection& pr, const Vec3& a, const Vec3& b, const Vec3& u, const Vec3& v,
                               const Vec3& w) {
  return point_in_triangle_2d(pr, a, u, v, w) || point_in_triangle_2d(pr, b, u, v, w) ||
         segments_meet_2d(pr, a, b, u, v) || segments_meet_2d(pr, a, b, v, w) || segments_meet_2d(pr, a, b, w, u);
}

bool triangles_meet_2d(const Projection& pr, const std::array<const Vec3*, 3>& p,
                       const std::array<const Vec3*, 3>& q) {
  for (std::size_t i = 0; i < 3; ++i) {
    if (segment_meets_triangle_2d(pr, *p[i], *p[(i + 1) % 3], *q[0], *q[1], *q[2])) return true;
  }
  // No edge of p meets q, so q is inside p or the two are apart.
  return point_in_triangle_2d(pr, *q[0], *p[0], *p[1], *p[2]);
}

// --- In space ---------------------------------------------------------------

/// The closed segment ab against the closed triangle (u, v, w) of non-zero
/// area, given the exact sides sa, sb of a and b relative to its plane.
bool segment_meets_triangle_3d(const Vec3& a, const Vec3& b, int sa, int sb, const Vec3& u, const Vec3& v,
                               const Vec3& w) {
  if (sa * sb > 0) return false;  // both strictly on one side
  if (sa == 0 && sb == 0) return segment_meets_triangle_2d(projection_of(u, v, w), a, b, u, v, w);
  // The segment meets the plane in one point; the line ab passes through the
  // closed triangle iff it passes no edge of it on opposite sides.
  return !mixed(exact::orient_3d(a, b, u, v), exact::orient_3d(a, b, v, w), exact::orient_3d(a, b, w, u));
}

bool nondegenerate(const Vec3& a, const Vec3& b, const Vec3& c) {
  return projection_of(a, b, c).drop >= 0;
}

bool triangles_meet(const std::array<const Vec3*, 3>& p, const std::array<const Vec3*, 3>& q) {
  std::array<int, 3> sq{}, sp{};
  for (std::size_t i = 0; i < 3; ++i) sq[i] = exact::orient_3d(*p[0], *p[1], *p[2], *q[i]);
  if ((sq[0] > 0 && sq[1] > 0 && sq[2] > 0) || (sq[0] < 0 && sq[1] < 0 && sq[2] < 0)) return false;
  for (std::size_t i = 0; i < 3; ++i) sp[i] = exact::orient_3d(*q[0], *q[1], *q[2], *p[i]);
  if ((sp[0] > 0 && sp[1] > 0 && sp[2] > 0) || (sp[0] < 0 && sp[1] < 0 && sp[2] < 0)) return false;
  if (sq[0] == 0 && sq[1] == 0 && sq[2] == 0) return triangles_meet_2d(projection_of(*p[0], *p[1], *p[2]), p, q);
  // Not coplanar: the common part lies on the planes' line, and its ends lie
  // on an edge of one triangle inside the other.
  for (std::size_t i = 0; i < 3; ++i) {
    const std::size_t j = (i + 1) % 3;
    if (segment_meets_triangle_3d(*p[i], *p[j], sp[i], sp[j], *q[0], *q[1], *q[2])) return true;
    if (segment_meets_triangle_3d(*q[i], *q[j], sq[i], sq[j], *p[0], *p[1], *p[2])) return true;
  }
  return false;
}

std::array<const Vec3*, 3> pointers(const std::array<Vec3, 3>& p) {
  return {&p[0], &p[1], &p[2]};
}

}  // namespace

bool segment_meets_triangle(const Vec3& a, const Vec3& b, const Vec3& u, const Vec3& v, const Vec3& w) {
  if (!nondegenerate(u, v, w)) return false;
  return segment_meets_triangle_3d(a, b, exact::orient_3d(u, v, w, a), exact::orient_3d(u, v, w, b), u, v, w);
}

bool triangles_intersect(const Vec3& a0, const Vec3& a1, const Vec3& a2, const Vec3& b0, const Vec3& b1,
                         const Vec3& b2) {
  if (!nondegenerate(a0, a1, a2) || !nondegenerate(b0, b1, b2)) return false;
  return triangles_meet({&a0, &a1, &a2}, {&b0, &b1, &b2});
}

namespace {

/// triangles_intersect for two triangles of non-zero area.
bool nondegenerate_triangles_intersect(const TriangleMesh& mesh, Index s, Index t) {
  const std::array<Vec3, 3> p = mesh.corners(s), q = mesh.corners(t);
  int shared = 0, is = -1, js = -1;  // the number of shared ids, and the last shared corner in s and t
  int in_s[3] = {-1, -1, -1};        // for each corner of s, the matching corner of t
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (mesh.triangles(s, i) == mesh.triangles(t, j)) {
        ++shared;
        is = i;
        js = j;
        in_s[i] = j;
      }
    }
  }
  if (shared == 0) return triangles_meet(pointers(p), pointers(q));
  if (shared >= 3) return true;
  if (shared == 1) {
    // The edge opposite the shared vertex in either triangle meets the other.
    const Vec3 &p1 = p[at((is + 1) % 3)], &p2 = p[at((is + 2) % 3)];
    const Vec3 &q1 = q[at((js + 1) % 3)], &q2 = q[at((js + 2) % 3)];
    return segment_meets_triangle_3d(q1, q2, exact::orient_3d(p[0], p[1], p[2], q1),
                                     exact::orient_3d(p[0], p[1], p[2], q2), p[0], p[1], p[2]) ||
           segment_meets_triangle_3d(p1, p2, exact::orient_3d(q[0], q[1], q[2], p1),
                                     exact::orient_3d(q[0], q[1], q[2], p2), q[0], q[1], q[2]);
  }
  // A shared edge: folded flat onto each other when the two opposite corners
  // lie in one plane with it, on the same side.
  int r = 0;
  while (in_s[r] >= 0) ++r;  // the corner of s off the shared edge
  int o = 0;
  while (o == in_s[(r + 1) % 3] || o == in_s[(r + 2) % 3]) ++o;  // the corner of t off it
  const Vec3 &u = p[at((r + 1) % 3)], &v = p[at((r + 2) % 3)], &pr = p[at(r)], &qo = q[at(o)];
  if (exact::orient_3d(u, v, pr, qo) != 0) return false;
  const Projection proj = projection_of(u, v, pr);
  return proj.orient(u, v, pr) * proj.orient(u, v, qo) > 0;
}

/// What the measurements take of each triangle, once: its box, whether it
/// has area, its normal and how far round-off can turn it (a frame's
/// coordinates carry an absolute error of about δ; a normal n = e1 × e2
/// then turns by up to 2δ(|e1| + |e2|)/|n|).
struct TriangleFacts {
  std::vector<Box3> boxes;
  std::vector<std::uint8_t> has_area;
  std::vector<Vec3> normal;
  std::vector<double> turn;
};

TriangleFacts triangle_facts(const TriangleMesh& mesh, double delta) {
  const Index nt = mesh.num_triangles();
  TriangleFacts f;
  f.boxes.resize(at(nt));
  f.has_area.resize(at(nt));
  f.normal.resize(at(nt));
  f.turn.resize(at(nt));
  for_each_index(nt, [&](Index t) {
    const std::array<Vec3, 3> p = mesh.corners(t);
    Box3 box;
    for (const Vec3& x : p) box.extend(x);
    f.boxes[at(t)] = box;
    f.has_area[at(t)] = nondegenerate(p[0], p[1], p[2]) ? 1 : 0;
    f.normal[at(t)] = (p[1] - p[0]).cross(p[2] - p[0]);
    f.turn[at(t)] = 2.0 * delta * ((p[1] - p[0]).norm() + (p[2] - p[0]).norm()) / f.normal[at(t)].norm();
  });
  return f;
}

/// self_intersecting_pairs with each triangle's box and area known.
std::vector<std::array<Index, 2>> intersecting_pairs(const TriangleMesh& mesh, const TriangleFacts& facts) {
  const std::vector<std::array<Index, 2>> candidates = overlapping_pairs(facts.boxes);
  std::vector<std::uint8_t> hit(candidates.size(), 0);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, candidates.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const Index s = candidates[i][0], t = candidates[i][1];
          hit[i] =
              facts.has_area[at(s)] && facts.has_area[at(t)] && nondegenerate_triangles_intersect(mesh, s, t) ? 1 : 0;
        }
      });
  std::vector<std::array<Index, 2>> pairs;
  for (std::size_t i = 0; i < candidates.size(); ++i)
    if (hit[i]) pairs.push_back(candidates[i]);
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

/// The absolute error of a frame's coordinates, about 8ε max|x| (they come
/// through the embedding, Σ b_i x_i).
double coordinate_error(const TriangleMesh& mesh) {
  return 8.0 * std::numeric_limits<double>::epsilon() * mesh.vertices.cwiseAbs().maxCoeff();
}

}  // namespace

bool triangles_intersect(const TriangleMesh& mesh, Index s, Index t) {
  const std::array<Vec3, 3> p = mesh.corners(s), q = mesh.corners(t);
  if (!nondegenerate(p[0], p[1], p[2]) || !nondegenerate(q[0], q[1], q[2])) return false;
  return nondegenerate_triangles_intersect(mesh, s, t);
}

std::vector<std::array<Index, 2>> self_intersecting_pairs(const TriangleMesh& mesh) {
  return intersecting_pairs(mesh, triangle_facts(mesh, coordinate_error(mesh)));
}

SurfaceQuality measure_surface_quality(const TriangleMesh& mesh) {
  SurfaceQuality q;
  q.triangles = mesh.num_triangles();
  const SurfaceIntegrals integrals = surface_integrals(mesh);
  q.area = integrals.area;
  q.volume = integrals.volume;
  // Edges: (key, triangle) sorted; an edge with exactly two triangles is
  // creased when their normals point more than 90° apart by more than the
  // coordinates can resolve (TriangleFacts::turn), so a box's 90° edges are
  // not counted, wherever the box stands.
  const TriangleFacts facts = triangle_facts(mesh, coordinate_error(mesh));
  q.self_intersecting_pairs = static_cast<Index>(intersecting_pairs(mesh, facts).size());
  q.degenerate_triangles = static_cast<Index>(std::count(facts.has_area.begin(), facts.has_area.end(), 0));
  std::vector<std::pair<std::uint64_t, Index>> half_edges(at(q.triangles) * 3);
  for_each_index(q.triangles, [&](Index t) {
    for (int k = 0; k < 3; ++k) {
      const auto a = static_cast<std::uint32_t>(mesh.triangles(t, k));
      const auto c = static_cast<std::uint32_t>(mesh.triangles(t, (k + 1) % 3));
      half_edges[at(3 * t + k)] = {(std::uint64_t{std::min(a, c)} << 32) | std::max(a, c), t};
    }
  });
  // Stable by key, written in triangle order: (key, triangle) ascending.
  radix_sort(half_edges, [](const std::pair<std::uint64_t, Index>& h) { return h.first; });
  for (std::size_t e = 0; e < half_edges.size();) {
    std::size_t f = e;
    while (f < half_edges.size() && half_edges[f].first == half_edges[e].first) ++f;
    ++q.edges;
    if (f - e == 2) {
      const Index s = half_edges[e].second, t = half_edges[e + 1].second;
      const Vec3 &n1 = facts.normal[at(s)], &n2 = facts.normal[at(t)];
      // cos θ < −sin(tolerance): past 90° beyond what round-off can turn (a
      // degenerate triangle's NaN tolerance counts nothing).
      if (n1.dot(n2) < -(facts.turn[at(s)] + facts.turn[at(t)]) * n1.norm() * n2.norm()) ++q.creased_edges;
    }
    e = f;
  }
  return q;
}

FacingSheets facing_sheets(const TriangleMesh& mesh, double gap) {
  FacingSheets out;
  const Index nt = mesh.num_triangles();
  if (nt == 0 || !(gap > 0.0) || !std::isfinite(gap)) return out;
  struct Entry {
    std::int64_t key;
    Vec3 centre, unit_normal;
    Index triangle;
    std::uint8_t direction;  // the normal's largest coordinate, by axis and sign (0–5; 6: no normal)
  };
  std::vector<Entry> entries(at(nt));
  std::vector<double> area(at(nt));
  for_each_index(nt, [&](Index t) {
    const std::array<Vec3, 3> p = mesh.corners(t);
    Entry& e = entries[at(t)];
    e.centre = (p[0] + p[1] + p[2]) / 3.0;
    const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]);
    area[at(t)] = 0.5 * n.norm();
    e.unit_normal = area[at(t)] > 0.0 ? Vec3(n / (2.0 * area[at(t)])) : Vec3::Zero();  // no area: faces nothing
    e.triangle = t;
    Eigen::Index axis = 0;
    const double largest = e.unit_normal.cwiseAbs().maxCoeff(&axis);
    e.direction = largest > 0.0 ? static_cast<std::uint8_t>(2 * axis + (e.unit_normal[axis] < 0.0 ? 1 : 0)) : 6;
  });
  Vec3 low = Vec3::Constant(std::numeric_limits<double>::infinity()), high = -low;
  for (const Entry& e : entries) low = low.cwiseMin(e.centre), high = high.cwiseMax(e.centre);
  if (!low.allFinite() || !high.allFinite()) return out;
  // Centroids binned on a grid of cells at least `gap` wide (and at most
  // 2¹⁹ along an axis): a pair closer than the gap lies in one cell or two
  // neighbouring ones. Each pair of cells is visited once, from the cell
  // with the lower key, and marks both triangles when they face.
  const double side = std::max(gap, (high - low).maxCoeff() / double{1 << 19});
  constexpr std::int64_t kSide = 1 << 20;
  auto cell_of = [&](const Vec3& c) -> Eigen::Vector3i { return ((c - low) / side).array().floor().cast<int>(); };
  auto key_of = [&](const Eigen::Vector3i& c) { return (std::int64_t{c.x()} * kSide + c.y()) * kSide + c.z(); };
  for_each_index(nt, [&](Index t) { entries[at(t)].key = key_of(cell_of(entries[at(t)].centre)); });
  // By key, then direction, then triangle (stable, from triangle order);
  // keys are not negative and below 2⁶⁰.
  radix_sort(entries, [](const Entry& e) { return (static_cast<std::uint64_t>(e.key) << 3) | e.direction; });
  std::vector<std::size_t> cells;  // where each cell's run of entries starts
  for (std::size_t i = 0; i < entries.size(); ++i)
    if (i == 0 || entries[i].key != entries[i - 1].key) cells.push_back(i);
  cells.push_back(entries.size());
  // Where each direction's entries start in each cell (8 a cell, the last
  // the cell's end). Two normals whose largest coordinate is the same axis
  // with the same sign lie within arccos(1/√3) of it each, so at most
  // 109.5° apart (cosine ≥ −1/3): they never face, and a cell's entries
  // skip the block of their own direction in the other.
  std::vector<std::size_t> direction_start(8 * (cells.size() - 1));
  for_each_index(
      static_cast<Index>(cells.size() - 1),
      [&](Index c) {
        std::size_t i = cells[at(c)];
        for (std::uint8_t d = 0; d < 8; ++d) {
          while (i < cells[at(c) + 1] && entries[i].direction < d) ++i;
          direction_start[8 * at(c) + d] = i;
        }
      },
      64);
  const double gap2 = gap * gap;
  // s faces t: normals more than 120° apart, each centroid on the outer
  // side of the other's plane (air between them), closer than the gap, and
  // no shared vertex. The cheapest tests first.
  auto face = [&](const Entry& a, const Entry& b) {
    if (!(a.unit_normal.dot(b.unit_normal) < -0.5)) return false;
    const Vec3 d = b.centre - a.centre;
    if (!(d.dot(a.unit_normal) > 0.0) || !(d.dot(b.unit_normal) < 0.0) || !(d.squaredNorm() < gap2)) return false;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (mesh.triangles(a.triangle, i) == mesh.triangles(b.triangle, j)) return false;
    return true;
  };
  std::vector<std::atomic<std::uint8_t>> faces(at(nt));  // set to 1 only: the same for any order
  const std::size_t num_cells = cells.size() - 1;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, num_cells, 16), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      const Eigen::Vector3i cell = cell_of(entries[cells[c]].centre);
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const std::int64_t key = key_of(cell + Eigen::Vector3i(dx, dy, dz));
            if (key < entries[cells[c]].key) continue;  // visited from that cell
            const auto first = std::lower_bound(cells.begin(), cells.end() - 1, key,
                                                [&](std::size_t at_entry, std::int64_t k) { return entries[at_entry].key < k; });
            if (first == cells.end() - 1 || entries[*first].key != key) continue;
            const std::size_t begin = *first, end = *(first + 1);
            const std::size_t other = static_cast<std::size_t>(first - cells.begin());
            const bool same = key == entries[cells[c]].key;
            for (std::size_t i = cells[c]; i != cells[c + 1]; ++i) {
              const std::uint8_t d = entries[i].direction;
              if (d == 6) continue;  // no normal: faces nothing
              // [from, end) less the block of i's own direction.
              const std::size_t own_begin = direction_start[8 * other + d],
                                own_end = direction_start[8 * other + d + 1];
              const std::size_t from = same ? i + 1 : begin;
              auto test = [&](std::size_t j) {
                if (face(entries[i], entries[j])) {
                  faces[at(entries[i].triangle)].store(1, std::memory_order_relaxed);
                  faces[at(entries[j].triangle)].store(1, std::memory_order_relaxed);
                }
              };
              for (std::size_t j = from; j < std::min(end, own_begin); ++j) test(j);
              for (std::size_t j = std::max(from, own_end); j < end; ++j) test(j);
            }
          }
    }
  });
  for (Index t = 0; t < nt; ++t)  // in triangle order: the same sum for any thread count
    if (faces[at(t)].load(std::memory_order_relaxed) != 0) {
      out.area += area[at(t)];
      ++out.triangles;
    }
  return out;
}

}  // namespace goo
