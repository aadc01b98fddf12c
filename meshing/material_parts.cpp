#include "meshing/material_parts.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/error.h"
#include "core/parallel.h"
#include "core/surface_topology.h"
#include "core/tet_mesh.h"
#include "core/union_find.h"
#include "meshing/convex_clip.h"
#include "meshing/exact_mass.h"
#include "meshing/exact_predicates.h"
#include "meshing/lattice_slicing.h"

namespace goo {
namespace {

using Vec = Eigen::Vector3d;
using Corners = std::array<Vec, 4>;

/// An exact test's answer: no, yes, or undecided by a zero orientation (a
/// degenerate configuration).
enum class Answer : std::uint8_t { no, yes, degenerate };

/// Whether the segment uw passes through the open triangle abc, given the
/// exact sides su, sw of u and w to its plane: u and w strictly on opposite
/// sides, the line strictly inside its three edges.
Answer segment_crosses_triangle(const Vec& u, const Vec& w, int su, int sw, const Vec& a, const Vec& b, const Vec& c) {
  if (su != 0 && su == sw) return Answer::no;
  const int o0 = exact::orient_3d(u, w, a, b), o1 = exact::orient_3d(u, w, b, c);
  if (o0 * o1 < 0) return Answer::no;  // the line passes beside the triangle
  const int o2 = exact::orient_3d(u, w, c, a);
  if (o0 * o2 < 0 || o1 * o2 < 0) return Answer::no;
  if (su == 0 || sw == 0 || o0 == 0 || o1 == 0 || o2 == 0) return Answer::degenerate;
  return Answer::yes;
}

Answer segment_crosses_triangle(const Vec& u, const Vec& w, const Vec& a, const Vec& b, const Vec& c) {
  return segment_crosses_triangle(u, w, exact::orient_3d(a, b, c, u), exact::orient_3d(a, b, c, w), a, b, c);
}

/// The exact sides of a triangle and a tetrahedron to each other's planes,
/// from which every test of the two is made: each triangle vertex to each
/// face's plane (negative on the inner side: faces counter-clockwise from
/// outside), each tetrahedron corner to the triangle's plane.
struct Sides {
  std::array<std::array<std::int8_t, 4>, 3> vertex{};  ///< [triangle vertex][face opposite corner f]
  std::array<std::int8_t, 4> corner{};                 ///< [corner]
};

const Vec& face_corner(const Corners& x, int f, int i) {
  return x[static_cast<std::size_t>(kTetFaces[f][i])];
}

Sides sides_of(const Corners& x, const std::array<Vec, 3>& t) {
  Sides s;
  for (int i = 0; i < 3; ++i)
    for (int f = 0; f < 4; ++f)
      s.vertex[static_cast<std::size_t>(i)][static_cast<std::size_t>(f)] = static_cast<std::int8_t>(exact::orient_3d(
          face_corner(x, f, 0), face_corner(x, f, 1), face_corner(x, f, 2), t[static_cast<std::size_t>(i)]));
  for (int k = 0; k < 4; ++k)
    s.corner[static_cast<std::size_t>(k)] =
        static_cast<std::int8_t>(exact::orient_3d(t[0], t[1], t[2], x[static_cast<std::size_t>(k)]));
  return s;
}

/// Whether a point with these sides to the faces is strictly inside the
/// tetrahedron; degenerate on its boundary.
Answer strictly_inside(const std::array<std::int8_t, 4>& side) {
  bool on_boundary = false;
  for (const auto s : side) {
    if (s > 0) return Answer::no;
    on_boundary = on_boundary || s == 0;
  }
  return on_boundary ? Answer::degenerate : Answer::yes;
}

/// Whether the segment uw (with its ends' sides to the faces) meets the
/// tetrahedron's interior: an end strictly inside or a face crossed.
/// `degenerate` when no witness is found but a test was undecided.
Answer segment_meets_tet(const Corners& x, const Vec& u, const Vec& w, const std::array<std::int8_t, 4>& su,
                         const std::array<std::int8_t, 4>& sw) {
  bool undecided = false;
  for (const auto* side : {&su, &sw}) {
    const Answer a = strictly_inside(*side);
    if (a == Answer::yes) return Answer::yes;
    undecided = undecided || a == Answer::degenerate;
  }
  for (int f = 0; f < 4; ++f) {
    const int a0 = su[static_cast<std::size_t>(f)], a1 = sw[static_cast<std::size_t>(f)];
    if (a0 > 0 && a1 > 0) return undecided ? Answer::degenerate : Answer::no;  // both beyond one face
  }
  for (int f = 0; f < 4; ++f) {
    const Answer a = segment_crosses_triangle(u, w, su[static_cast<std::size_t>(f)], sw[static_cast<std::size_t>(f)],
                                              face_corner(x, f, 0), face_corner(x, f, 1), face_corner(x, f, 2));
    if (a == Answer::yes) return Answer::yes;
    undecided = undecided || a == Answer::degenerate;
  }
  return undecided ? Answer::degenerate : Answer::no;
}

/// Whether the triangle t meets the tetrahedron's interior: a vertex
/// inside, one of its edges through a face, or an edge of the tetrahedron
/// through it (the three ways a triangle and a tetrahedron in general
/// position can meet).
Answer triangle_meets_tet(const Corners& x, const std::array<Vec, 3>& t, const Sides& s) {
  // Separated by a face's plane or the triangle's: exactly no.
  for (int f = 0; f < 4; ++f)
    if (s.vertex[0][static_cast<std::size_t>(f)] > 0 && s.vertex[1][static_cast<std::size_t>(f)] > 0 &&
        s.vertex[2][static_cast<std::size_t>(f)] > 0)
      return Answer::no;
  const auto& c = s.corner;
  if ((c[0] > 0 && c[1] > 0 && c[2] > 0 && c[3] > 0) || (c[0] < 0 && c[1] < 0 && c[2] < 0 && c[3] < 0))
    return Answer::no;
  bool undecided = false;
  for (int k = 0; k < 3; ++k) {
    const Answer a =
        segment_meets_tet(x, t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)],
                          s.vertex[static_cast<std::size_t>(k)], s.vertex[static_cast<std::size_t>((k + 1) % 3)]);
    if (a == Answer::yes) return Answer::yes;
    undecided = undecided || a == Answer::degenerate;
  }
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) {
      const Answer a =
          segment_crosses_triangle(x[static_cast<std::size_t>(i)], x[static_cast<std::size_t>(j)],
                                   c[static_cast<std::size_t>(i)], c[static_cast<std::size_t>(j)], t[0], t[1], t[2]);
      if (a == Answer::yes) return Answer::yes;
      undecided = undecided || a == Answer::degenerate;
    }
  return undecided ? Answer::degenerate : Answer::no;
}

Corners element_corners(const TetMesh& mesh, Index e) {
  return {mesh.positions.row(mesh.tets(e, 0)).transpose(), mesh.positions.row(mesh.tets(e, 1)).transpose(),
          mesh.positions.row(mesh.tets(e, 2)).transpose(), mesh.positions.row(mesh.tets(e, 3)).transpose()};
}

/// Disjoint sets over a few items, reused from element to element.
struct SmallSets {
  std::vector<int> parent;
  void reset(int n) {
    parent.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) parent[static_cast<std::size_t>(i)] = i;
  }
  int find(int x) {
    while (parent[static_cast<std::size_t>(x)] != x)
      x = parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
    return x;
  }
  /// The smaller root wins: a class is named by its first item.
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
  }
};

constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/// One element's candidate parts: the class of each of its triangles and
/// corners (−1: outside), numbered in order of first item; whether each
/// class holds an edge interval; degenerate if an exact test was undecided.
struct ElementClasses {
  std::vector<int> triangle_class;
  std::array<int, 4> corner_class{-1, -1, -1, -1};
  std::vector<std::uint8_t> class_on_edge;
  /// The class of each interval of each edge (kEdges order), walked from
  /// the edge's lower node: intervals[interval_first[j] .. interval_first[j + 1]),
  /// −1 for an interval outside the surface.
  std::vector<int> intervals;
  std::array<int, 7> interval_first{};
  bool degenerate = false;
  /// One surface patch at most (found without exact tests): one part, and
  /// no intervals walked.
  bool simple = false;
  /// An element examined exactly: the triangles meeting its interior
  /// (increasing), until they are moved to the pairs.
  std::vector<Index> triangles;
  [[nodiscard]] int count() const { return static_cast<int>(class_on_edge.size()); }
  /// One part holding the element's m triangles and its inside corners (no
  /// part if it has neither).
  void one_part(int m, const std::array<bool, 4>& inside) {
    const bool any = m > 0 || inside[0] || inside[1] || inside[2] || inside[3];
    class_on_edge.assign(any ? 1 : 0, 1);
    triangle_class.assign(static_cast<std::size_t>(m), 0);
    for (std::size_t k = 0; k < 4; ++k) corner_class[k] = inside[k] ? 0 : -1;
  }
};

struct Scratch {
  SmallSets sets;
  struct Crossing {
    double s;
    int triangle;
  };
  std::vector<Crossing> crossings;
  std::vector<int> label;
};

void classify_element(const Corners& x, const std::array<Index, 4>& nodes, const std::array<bool, 4>& inside,
                      const TriangleMesh& surface,
                      const Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor>& across, const Index* tris,
                      const Sides* sides, int m, Scratch& scratch, ElementClasses& out) {
  out.degenerate = false;
  out.intervals.clear();
  out.interval_first.fill(0);
  out.triangle_class.assign(static_cast<std::size_t>(m), 0);
  out.corner_class = {-1, -1, -1, -1};
  out.class_on_edge.clear();
  // Items: the m triangles, then each edge's intervals (crossings + 1).
  // Intervals are added as the edges are walked; at most m + 1 per edge.
  SmallSets& sets = scratch.sets;
  sets.reset(m + 6 * (m + 1));
  auto local = [&](Index t) -> int {
    const Index* it = std::lower_bound(tris, tris + m, t);
    return it != tris + m && *it == t ? static_cast<int>(it - tris) : -1;
  };
  // Patches: two triangles whose shared edge passes through the interior.
  for (int i = 0; i < m && !out.degenerate; ++i) {
    const Index t = tris[i];
    for (int k = 0; k < 3; ++k) {
      const Index nb = across(t, k);
      if (nb <= t) continue;
      const int j = local(nb);
      if (j < 0) continue;
      const Answer a = segment_meets_tet(x, surface.vertices.row(surface.triangles(t, k)).transpose(),
                                         surface.vertices.row(surface.triangles(t, (k + 1) % 3)).transpose(),
                                         sides[i].vertex[static_cast<std::size_t>(k)],
                                         sides[i].vertex[static_cast<std::size_t>((k + 1) % 3)]);
      if (a == Answer::degenerate) out.degenerate = true;
      if (a == Answer::yes) sets.unite(i, j);
    }
  }
  // The edges' intervals, in order from the edge's lower node (the same
  // order, bit for bit, in every element around the edge).
  int next_item = m;
  std::array<int, 4> corner_item{-1, -1, -1, -1};
  std::vector<int> interval_inside;  // per item − m: 1 if inside
  interval_inside.reserve(static_cast<std::size_t>(6 * (m + 1)));
  std::array<int, 7> item_first{};
  item_first[0] = m;
  for (int j = 0; j < 6; ++j) {
    if (out.degenerate) break;
    std::array<int, 2> edge = {kEdges[j][0], kEdges[j][1]};
    if (nodes[static_cast<std::size_t>(edge[0])] > nodes[static_cast<std::size_t>(edge[1])])
      std::swap(edge[0], edge[1]);
    const Vec& p = x[static_cast<std::size_t>(edge[0])];
    const Vec& q = x[static_cast<std::size_t>(edge[1])];
    auto& crossings = scratch.crossings;
    crossings.clear();
    for (int i = 0; i < m; ++i) {
      const int sp = sides[i].corner[static_cast<std::size_t>(edge[0])],
                sq = sides[i].corner[static_cast<std::size_t>(edge[1])];
      if (sp != 0 && sp == sq) continue;
      const auto c = surface.corners(tris[i]);
      const Answer a = segment_crosses_triangle(p, q, sp, sq, c[0], c[1], c[2]);
      if (a == Answer::degenerate) out.degenerate = true;
      if (a != Answer::yes) continue;
      const Vec n = (c[1] - c[0]).cross(c[2] - c[0]);
      const double dp = n.dot(p - c[0]), dq = n.dot(q - c[0]);
      crossings.push_back({dp / (dp - dq), i});
    }
    if (out.degenerate) break;
    std::sort(crossings.begin(), crossings.end(), [](const Scratch::Crossing& a, const Scratch::Crossing& b) {
      return a.s < b.s || (a.s == b.s && a.triangle < b.triangle);
    });
    for (std::size_t r = 1; r < crossings.size(); ++r)
      if (!(crossings[r].s - crossings[r - 1].s > 1e-9)) out.degenerate = true;
    // Inside and outside alternate from the lower corner's exact flag; the
    // upper corner's flag must agree.
    bool now_inside = inside[static_cast<std::size_t>(edge[0])];
    const int first = next_item;
    interval_inside.push_back(now_inside ? 1 : 0);
    ++next_item;
    for (const auto& crossing : crossings) {
      const int before = next_item - 1, after = next_item;
      now_inside = !now_inside;
      interval_inside.push_back(now_inside ? 1 : 0);
      ++next_item;
      sets.unite(crossing.triangle, now_inside ? after : before);
    }
    if (now_inside != inside[static_cast<std::size_t>(edge[1])]) out.degenerate = true;
    const int last = next_item - 1;
    for (const auto& [corner, item] : {std::pair{edge[0], first}, std::pair{edge[1], last}}) {
      if (!inside[static_cast<std::size_t>(corner)]) continue;
      int& seen = corner_item[static_cast<std::size_t>(corner)];
      if (seen < 0)
        seen = item;
      else
        sets.unite(seen, item);
    }
    item_first[static_cast<std::size_t>(j + 1)] = next_item;
  }
  if (out.degenerate) return out.one_part(m, inside);  // everything there is
  // Number the classes that hold a triangle or an inside interval, in
  // order of their first item.
  auto& label = scratch.label;
  label.assign(static_cast<std::size_t>(next_item), -1);
  for (int item = 0; item < next_item; ++item) {
    if (item >= m && !interval_inside[static_cast<std::size_t>(item - m)]) continue;
    const int root = sets.find(item);
    if (label[static_cast<std::size_t>(root)] < 0) {
      label[static_cast<std::size_t>(root)] = out.count();
      out.class_on_edge.push_back(0);
    }
    if (item >= m) out.class_on_edge[static_cast<std::size_t>(label[static_cast<std::size_t>(root)])] = 1;
  }
  for (int i = 0; i < m; ++i)
    out.triangle_class[static_cast<std::size_t>(i)] = label[static_cast<std::size_t>(sets.find(i))];
  for (int j = 0; j < 6; ++j) {
    out.interval_first[static_cast<std::size_t>(j)] = static_cast<int>(out.intervals.size());
    for (int item = item_first[static_cast<std::size_t>(j)]; item < item_first[static_cast<std::size_t>(j + 1)]; ++item)
      out.intervals.push_back(
          interval_inside[static_cast<std::size_t>(item - m)] ? label[static_cast<std::size_t>(sets.find(item))] : -1);
  }
  out.interval_first[6] = static_cast<int>(out.intervals.size());
  for (int k = 0; k < 4; ++k)
    if (corner_item[static_cast<std::size_t>(k)] >= 0)
      out.corner_class[static_cast<std::size_t>(k)] =
          label[static_cast<std::size_t>(sets.find(corner_item[static_cast<std::size_t>(k)]))];
}

using Across = Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Whether the segment uw clearly passes through the open tetrahedron of
/// these (outward, unit-normal) face planes: a point of it more than
/// `margin` inside every plane, computed in floating point. The round-off
/// is far below the margin, so a true answer is exact; false may be wrong
/// within the margin.
bool segment_clearly_inside(const std::array<Plane, 4>& planes, const Vec& u, const Vec& w, double margin) {
  double s0 = 0.0, s1 = 1.0;
  for (const Plane& plane : planes) {
    const double du = plane.distance(u) + margin, dw = plane.distance(w) + margin;
    if (du >= 0.0 && dw >= 0.0) return false;
    if (du >= 0.0)
      s0 = std::max(s0, du / (du - dw));
    else if (dw >= 0.0)
      s1 = std::min(s1, du / (du - dw));
  }
  if (!(s1 > s0)) return false;
  const Vec middle = u + 0.5 * (s0 + s1) * (w - u);
  for (const Plane& plane : planes)
    if (!(plane.distance(middle) < -margin)) return false;
  return true;
}

/// The number of patches among an element's triangles (increasing), two
/// joined where their shared edge clearly passes through the element's
/// interior (segment_clearly_inside): only where the exact test joins
/// them, so one patch here is one patch exactly.
int count_patches(const Corners& x, const TriangleMesh& surface, const Across& across, const Index* tris, int m,
                  double margin, SmallSets& sets) {
  if (m <= 1) return m;
  const std::array<Plane, 4> planes = tet_planes(x);
  sets.reset(m);
  int count = m;
  for (int i = 0; i < m && count > 1; ++i) {
    const Index t = tris[i];
    for (int k = 0; k < 3; ++k) {
      const Index nb = across(t, k);
      if (nb <= t) continue;
      const Index* it = std::lower_bound(tris, tris + m, nb);
      if (it == tris + m || *it != nb) continue;
      const int j = static_cast<int>(it - tris);
      if (sets.find(i) == sets.find(j)) continue;
      if (segment_clearly_inside(planes, surface.vertices.row(surface.triangles(t, k)).transpose(),
                                 surface.vertices.row(surface.triangles(t, (k + 1) % 3)).transpose(), margin)) {
        sets.unite(i, j);
        --count;
      }
    }
  }
  return count;
}

/// Two elements' parts joined across their shared face: the element and
/// face (corner opposite) on each side, and the pairs of parts whose
/// material meets on the face.
struct FaceJoin {
  Index element[2];
  int opposite[2];
  std::vector<std::array<Index, 2>> parts;
};

/// Whether triangle t crosses the open triangle f (the face of an element):
/// one of its edges through f, or an edge of f through it.
Answer triangle_crosses_face(const std::array<Vec, 3>& t, const std::array<Vec, 3>& f) {
  bool undecided = false;
  for (int k = 0; k < 3; ++k) {
    const Answer a = segment_crosses_triangle(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)],
                                              f[0], f[1], f[2]);
    if (a == Answer::yes) return Answer::yes;
    undecided = undecided || a == Answer::degenerate;
  }
  for (int k = 0; k < 3; ++k) {
    const Answer a = segment_crosses_triangle(f[static_cast<std::size_t>(k)], f[static_cast<std::size_t>((k + 1) % 3)],
                                              t[0], t[1], t[2]);
    if (a == Answer::yes) return Answer::yes;
    undecided = undecided || a == Answer::degenerate;
  }
  return undecided ? Answer::degenerate : Answer::no;
}

/// Local edge index (kEdges) of corners a and b.
int edge_index(int a, int b) {
  if (a > b) std::swap(a, b);
  for (int j = 0; j < 6; ++j)
    if (kEdges[j][0] == a && kEdges[j][1] == b) return j;
  return -1;
}

/// Which parts of the two elements sharing a face have material that meets
/// on it: the same inside interval of one of the face's edges, or a
/// triangle that crosses the face. A simple element's one part holds every
/// inside interval of its edges. Where either element is degenerate or two
/// walked elements disagree on an edge's intervals, every part of both is
/// joined (as a re-mesh without parts has it).
void join_across_face(const LatticeMesh& lm, const TriangleMesh& surface, const std::vector<ElementClasses>& classes,
                      const MaterialParts& out, FaceJoin& join) {
  const TetMesh& mesh = lm.mesh;
  const Index e0 = join.element[0], e1 = join.element[1];
  const Index base0 = out.first_part[at(e0)], base1 = out.first_part[at(e1)];
  const Index n0 = out.num_parts(e0), n1 = out.num_parts(e1);
  join.parts.clear();
  if (n0 == 0 || n1 == 0) return;
  auto join_all = [&] {
    join.parts.clear();
    for (Index a = 0; a < n0; ++a)
      for (Index b = 0; b < n1; ++b) join.parts.push_back({base0 + a, base1 + b});
  };
  const ElementClasses& c0 = classes[at(e0)];
  const ElementClasses& c1 = classes[at(e1)];
  if (c0.degenerate || c1.degenerate) return join_all();
  // The face's corners in each element.
  const auto& f0 = kTetFaces[join.opposite[0]];
  std::array<int, 3> corner0{}, corner1{};
  for (int i = 0; i < 3; ++i) {
    corner0[static_cast<std::size_t>(i)] = f0[i];
    const Index node = mesh.tets(e0, f0[i]);
    for (int k = 0; k < 4; ++k)
      if (mesh.tets(e1, k) == node) corner1[static_cast<std::size_t>(i)] = k;
  }
  const std::array<Vec, 3> face = {mesh.positions.row(mesh.tets(e0, corner0[0])).transpose(),
                                   mesh.positions.row(mesh.tets(e0, corner0[1])).transpose(),
                                   mesh.positions.row(mesh.tets(e0, corner0[2])).transpose()};
  auto crosses_face = [&](Index t) { return triangle_crosses_face(surface.corners(t), face); };
  const Index i_begin = out.pair_first[at(e0)], i_end = out.pair_first[at(e0) + 1];
  const Index j_begin = out.pair_first[at(e1)], j_end = out.pair_first[at(e1) + 1];
  if (c0.simple && c1.simple) {
    // One part each: joined if an inside corner is on the face, or a
    // triangle of either crosses it (the material's trace on the face is
    // bounded by the face's edges and the triangles crossing it).
    for (const int k : corner0)
      if (lm.node_inside[at(mesh.tets(e0, k))]) return join_all();
    Index i = i_begin, j = j_begin;
    while (i < i_end || j < j_end) {
      const Index t0 = i < i_end ? out.pair_triangle[at(i)] : std::numeric_limits<Index>::max();
      const Index t1 = j < j_end ? out.pair_triangle[at(j)] : std::numeric_limits<Index>::max();
      const Index t = std::min(t0, t1);
      if (crosses_face(t) != Answer::no) return join_all();
      i += t0 == t ? 1 : 0;
      j += t1 == t ? 1 : 0;
    }
    return;
  }
  if (c0.simple || c1.simple) {
    // The walked element's parts with material on the face each join the
    // simple one's part: those holding an inside interval of a face edge,
    // and those of its triangles crossing the face (every triangle that
    // crosses the face meets the walked element's interior: exactly found).
    const bool walked0 = !c0.simple;
    const ElementClasses& w = walked0 ? c0 : c1;
    const std::array<int, 3>& corner = walked0 ? corner0 : corner1;
    const Index base = walked0 ? base0 : base1, other = walked0 ? base1 : base0;
    auto add = [&](Index part) {
      join.parts.push_back(walked0 ? std::array<Index, 2>{part, other} : std::array<Index, 2>{other, part});
    };
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j) {
        const int a = edge_index(corner[static_cast<std::size_t>(i)], corner[static_cast<std::size_t>(j)]);
        for (int r = w.interval_first[static_cast<std::size_t>(a)]; r < w.interval_first[static_cast<std::size_t>(a + 1)];
             ++r)
          if (w.intervals[static_cast<std::size_t>(r)] >= 0) add(base + w.intervals[static_cast<std::size_t>(r)]);
      }
    const Index begin = walked0 ? i_begin : j_begin, end = walked0 ? i_end : j_end;
    for (Index i = begin; i < end; ++i) {
      const Answer a = crosses_face(out.pair_triangle[at(i)]);
      if (a == Answer::degenerate) return join_all();
      if (a == Answer::yes) add(out.pair_part[at(i)]);
    }
  } else {
    // Intervals of the face's three edges.
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j) {
        const int a = edge_index(corner0[static_cast<std::size_t>(i)], corner0[static_cast<std::size_t>(j)]);
        const int b = edge_index(corner1[static_cast<std::size_t>(i)], corner1[static_cast<std::size_t>(j)]);
        const int len0 =
            c0.interval_first[static_cast<std::size_t>(a + 1)] - c0.interval_first[static_cast<std::size_t>(a)];
        const int len1 =
            c1.interval_first[static_cast<std::size_t>(b + 1)] - c1.interval_first[static_cast<std::size_t>(b)];
        if (len0 != len1) return join_all();
        for (int r = 0; r < len0; ++r) {
          const int p0 = c0.intervals[static_cast<std::size_t>(c0.interval_first[static_cast<std::size_t>(a)] + r)];
          const int p1 = c1.intervals[static_cast<std::size_t>(c1.interval_first[static_cast<std::size_t>(b)] + r)];
          if ((p0 >= 0) != (p1 >= 0)) return join_all();
          if (p0 >= 0) join.parts.push_back({base0 + p0, base1 + p1});
        }
      }
    // Triangles of both elements that cross the face.
    Index i = i_begin, j = j_begin;
    while (i < i_end && j < j_end) {
      const Index t0 = out.pair_triangle[at(i)], t1 = out.pair_triangle[at(j)];
      if (t0 < t1) {
        ++i;
      } else if (t1 < t0) {
        ++j;
      } else {
        const Answer a = crosses_face(t0);
        if (a == Answer::degenerate) return join_all();
        if (a == Answer::yes) join.parts.push_back({out.pair_part[at(i)], out.pair_part[at(j)]});
        ++i;
        ++j;
      }
    }
  }
  std::sort(join.parts.begin(), join.parts.end());
  join.parts.erase(std::unique(join.parts.begin(), join.parts.end()), join.parts.end());
}

/// Every face shared by two elements, once (from the lower element), in
/// order of element and face. Throws where a face has more than two.
std::vector<FaceJoin> shared_faces(const Tets& neighbours) {
  std::vector<FaceJoin> joins;
  for (Index e = 0; e < neighbours.rows(); ++e)
    for (int k = 0; k < 4; ++k) {
      const Index f = neighbours(e, k);
      if (f <= e) continue;
      int back = 0;  // the face of f opposite the corner f does not share with e
      while (back < 4 && neighbours(f, back) != e) ++back;
      if (back == 4)  // face_neighbours pairs a face's sides two by two: a third side breaks the pairing
        throw Error(fmt::format("material_parts: a face of element {} is shared by more than two elements "
                                "(a lattice mesh is conforming)",
                                e));
      joins.push_back({{e, f}, {k, back}, {}});
    }
  return joins;
}

/// The virtual-node copies (Molino, Bao & Fedkiw 2004): each part has its
/// own copy of its element's four corners; copies of two parts joined
/// across a face are one at the face's three nodes.
void copy_nodes(const LatticeMesh& lm, const TriangleMesh& surface, const std::vector<ElementClasses>& classes,
                std::vector<FaceJoin>& joins, MaterialParts& out) {
  const TetMesh& mesh = lm.mesh;
  tbb::parallel_for(std::size_t{0}, joins.size(),
                    [&](std::size_t f) { join_across_face(lm, surface, classes, out, joins[f]); });
  // Copies: one item per part corner, joined at each joined face's nodes.
  const Index np = out.first_part.back();
  UnionFind copies(4 * np);
  for (const FaceJoin& join : joins)
    for (const auto& [p0, p1] : join.parts)
      for (int i = 0; i < 3; ++i) {
        const int k0 = kTetFaces[join.opposite[0]][i];
        const Index node = mesh.tets(join.element[0], k0);
        for (int k1 = 0; k1 < 4; ++k1)
          if (mesh.tets(join.element[1], k1) == node) copies.unite(4 * p0 + k0, 4 * p1 + k1);
      }
  // Numbered in order of first item.
  std::vector<Index> id(at(4 * np), -1);
  out.part_nodes.resize(at(np));
  out.copy_node.clear();
  Index e = 0;
  for (Index p = 0; p < np; ++p) {
    while (out.first_part[at(e) + 1] <= p) ++e;
    for (int k = 0; k < 4; ++k) {
      Index& root = id[at(copies.find(4 * p + k))];
      if (root < 0) {
        root = static_cast<Index>(out.copy_node.size());
        out.copy_node.push_back(mesh.tets(e, k));
      }
      out.part_nodes[at(p)][static_cast<std::size_t>(k)] = root;
    }
  }
}

}  // namespace

Index MaterialParts::duplicated_nodes() const {
  std::vector<Index> copies;
  for (const Index n : copy_node) {
    if (at(n) >= copies.size()) copies.resize(at(n) + 1, 0);
    ++copies[at(n)];
  }
  return static_cast<Index>(std::count_if(copies.begin(), copies.end(), [](Index c) { return c >= 2; }));
}

Index MaterialParts::split_elements() const {
  Index n = 0;
  for (Index e = 0; e < num_elements(); ++e) n += num_parts(e) >= 2 ? 1 : 0;
  return n;
}

Index MaterialParts::degenerate_elements() const {
  return static_cast<Index>(std::count(degenerate.begin(), degenerate.end(), std::uint8_t{1}));
}

MaterialParts material_parts(const LatticeMesh& lm, const TriangleMesh& surface) {
  return material_parts(lm, surface, slice_surface(lm, surface));
}

MaterialParts material_parts(const LatticeMesh& lm, const TriangleMesh& surface, const SurfacePieces& pieces) {
  const TetMesh& mesh = lm.mesh;
  const Index ne = mesh.num_elements();
  if (static_cast<Index>(lm.node_inside.size()) != mesh.num_nodes())
    throw Error("material_parts: the lattice mesh has no inside flags for its nodes");
  const BccLattice& lattice = lm.lattice;
  // The triangle across each edge (−1 where an edge does not have exactly
  // two: a surface that is not closed joins nothing there).
  const Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor> across = triangles_across(surface.triangles);
  const double slack = 1e-9 * lattice.spacing();
  // 1. The surface's pieces in each element, with their volume shares from
  // the element's apex (the exact masses' slicing): the pairs of the
  // elements examined without exact tests (step 3).
  if (static_cast<Index>(pieces.first.size()) != ne + 1 || pieces.apex.size() != at(ne))
    throw Error("material_parts: the surface's pieces are not of this lattice mesh");
  const std::vector<std::uint8_t>& apex = pieces.apex;
  const std::vector<Index>& slice_first = pieces.first;
  const std::vector<Index>& slice_triangle = pieces.triangle;
  const std::vector<ConeIntegrals>& slice_integrals = pieces.integrals;

  // 2. The faces shared by two elements.
  const Tets neighbours = face_neighbours(mesh.tets);
  std::vector<FaceJoin> joins = shared_faces(neighbours);

  // 3. Each element's candidate parts. An element whose triangles form one
  // patch, by a test that joins two only where their shared edge passes a
  // margin inside the element (so never where the exact test would not),
  // has one part: the surface's one patch bounds one region of material.
  // The others are examined exactly: their triangles (the pieces of theirs
  // and their face neighbours', so a piece the slicing rounded away is
  // found) tested against the element with exact predicates, and their
  // classes walked (classify_element).
  std::vector<ElementClasses> classes(at(ne));
  std::vector<std::uint8_t> degenerate(at(ne), 0);
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    Scratch scratch;
    std::vector<Index> candidates;
    std::vector<Sides> sides;
    for (Index e = r.begin(); e != r.end(); ++e) {
      const Corners x = element_corners(mesh, e);
      std::array<bool, 4> inside{};
      std::array<Index, 4> nodes{};
      for (int k = 0; k < 4; ++k) {
        nodes[static_cast<std::size_t>(k)] = mesh.tets(e, k);
        inside[static_cast<std::size_t>(k)] = lm.node_inside[at(mesh.tets(e, k))] != 0;
      }
      const Index* own = slice_triangle.data() + slice_first[at(e)];
      const int m = static_cast<int>(slice_first[at(e) + 1] - slice_first[at(e)]);
      ElementClasses& c = classes[at(e)];
      // Corners inside and outside with no triangle between them: the
      // surface passes through a corner or along a face (examined exactly).
      const bool mixed = (inside[0] || inside[1] || inside[2] || inside[3]) &&
                         !(inside[0] && inside[1] && inside[2] && inside[3]);
      if (!(m == 0 && mixed) && count_patches(x, surface, across, own, m, slack, scratch.sets) <= 1) {
        c.simple = true;
        c.one_part(m, inside);
      } else {
        candidates.assign(own, own + m);
        for (int k = 0; k < 4; ++k)
          if (const Index f = neighbours(e, k); f >= 0)
            candidates.insert(candidates.end(), slice_triangle.begin() + slice_first[at(f)],
                              slice_triangle.begin() + slice_first[at(f) + 1]);
        std::sort(candidates.begin(), candidates.end());
        candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
        c.triangles.clear();
        sides.clear();
        bool undecided = false;
        for (const Index t : candidates) {
          const auto tri = surface.corners(t);
          // A face plane of either that separates them by more than the
          // slack separates them exactly (the round-off of the projections
          // is far smaller).
          if (!overlaps_inflated(tri, x, slack, false)) continue;
          const Sides s = sides_of(x, tri);
          const Answer a = triangle_meets_tet(x, tri, s);
          if (a == Answer::no) continue;
          undecided = undecided || a == Answer::degenerate;
          c.triangles.push_back(t);
          sides.push_back(s);
        }
        const int count = static_cast<int>(c.triangles.size());
        classify_element(x, nodes, inside, surface, across, c.triangles.data(), sides.data(), count, scratch, c);
        if (undecided && !c.degenerate) {
          c.degenerate = true;
          c.one_part(count, inside);
        }
        degenerate[at(e)] = c.degenerate ? 1 : 0;
      }
    }
  });

  // 4. The pairs: a simple element's pieces, an examined element's exactly
  // found triangles, and each pair's volume share from its piece (none for
  // a triangle found exactly whose piece the slicing rounded away).
  MaterialParts out;
  out.degenerate = std::move(degenerate);
  out.pair_first.assign(at(ne) + 1, 0);
  for (Index e = 0; e < ne; ++e)
    out.pair_first[at(e) + 1] = out.pair_first[at(e)] + (classes[at(e)].simple
                                                             ? slice_first[at(e) + 1] - slice_first[at(e)]
                                                             : static_cast<Index>(classes[at(e)].triangles.size()));
  out.pair_triangle.resize(at(out.pair_first.back()));
  std::vector<ConeIntegrals> pair_integrals(out.pair_triangle.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      ElementClasses& c = classes[at(e)];
      const Index begin = out.pair_first[at(e)], end = out.pair_first[at(e) + 1];
      const auto s_begin = slice_triangle.begin() + slice_first[at(e)];
      const auto s_end = slice_triangle.begin() + slice_first[at(e) + 1];
      if (c.simple) {
        std::copy(s_begin, s_end, out.pair_triangle.begin() + begin);
        std::copy(slice_integrals.begin() + slice_first[at(e)], slice_integrals.begin() + slice_first[at(e) + 1],
                  pair_integrals.begin() + begin);
        continue;
      }
      std::copy(c.triangles.begin(), c.triangles.end(), out.pair_triangle.begin() + begin);
      c.triangles.clear();
      c.triangles.shrink_to_fit();
      for (Index i = begin; i < end; ++i) {
        const auto it = std::lower_bound(s_begin, s_end, out.pair_triangle[at(i)]);
        if (it != s_end && *it == out.pair_triangle[at(i)])
          pair_integrals[at(i)] = slice_integrals[static_cast<std::size_t>(it - slice_triangle.begin())];
      }
    }
  });

  // 5. Candidate volumes; an element with a patch of its own that encloses
  // air (a hole through its material) keeps one part.
  out.first_part.assign(at(ne) + 1, 0);
  std::vector<std::vector<ConeIntegrals>> volumes(at(ne));
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      ElementClasses& c = classes[at(e)];
      auto& v = volumes[at(e)];
      v.assign(static_cast<std::size_t>(c.count()), ConeIntegrals{});
      const Index begin = out.pair_first[at(e)];
      for (std::size_t i = 0; i < c.triangle_class.size(); ++i) {
        ConeIntegrals& sum = v[static_cast<std::size_t>(c.triangle_class[i])];
        sum.volume += pair_integrals[at(begin) + i].volume;
        sum.moment += pair_integrals[at(begin) + i].moment;
      }
      if (const int k = c.corner_class[apex[at(e)]]; k >= 0) {
        const Corners x = element_corners(mesh, e);
        const double w = lm.lattice.tet_volume();
        v[static_cast<std::size_t>(k)].volume += w;
        v[static_cast<std::size_t>(k)].moment += w * (0.25 * (x[0] + x[1] + x[2] + x[3]) - x[apex[at(e)]]);
      }
      bool hole = false;
      for (int k = 0; k < c.count(); ++k)
        hole =
            hole || (!c.class_on_edge[static_cast<std::size_t>(k)] && !(v[static_cast<std::size_t>(k)].volume > 0.0));
      if (hole) {
        ConeIntegrals total;
        for (const auto& part : v) {
          total.volume += part.volume;
          total.moment += part.moment;
        }
        v.assign(1, total);
        c.class_on_edge.assign(1, 1);
        std::fill(c.triangle_class.begin(), c.triangle_class.end(), 0);
        for (int& k : c.corner_class)
          if (k >= 0) k = 0;
        for (int& k : c.intervals)
          if (k >= 0) k = 0;
      }
      out.first_part[at(e) + 1] = c.count();
    }
  });
  for (std::size_t e = 0; e + 1 < out.first_part.size(); ++e) out.first_part[e + 1] += out.first_part[e];
  out.part_volume.resize(out.first_part.back());
  out.part_centroid.resize(out.first_part.back(), 3);
  out.corner_part.resize(at(ne));
  out.pair_part.resize(out.pair_triangle.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      const ElementClasses& c = classes[at(e)];
      const Index base = out.first_part[at(e)];
      const Corners x = element_corners(mesh, e);
      for (int k = 0; k < c.count(); ++k) {
        const ConeIntegrals& part = volumes[at(e)][static_cast<std::size_t>(k)];
        out.part_volume[base + k] = part.volume;
        out.part_centroid.row(base + k) = part.volume > 0.0
                                              ? Vec(x[apex[at(e)]] + part.moment / part.volume).transpose()
                                              : Vec(0.25 * (x[0] + x[1] + x[2] + x[3])).transpose();
      }
      for (int k = 0; k < 4; ++k) {
        const int cls = c.corner_class[static_cast<std::size_t>(k)];
        out.corner_part[at(e)][static_cast<std::size_t>(k)] = cls >= 0 ? base + cls : -1;
      }
      const Index begin = out.pair_first[at(e)];
      for (std::size_t i = 0; i < c.triangle_class.size(); ++i)
        out.pair_part[at(begin) + i] = base + c.triangle_class[i];
    }
  });

  // 6. The parts joined across shared faces, and the node copies.
  copy_nodes(lm, surface, classes, joins, out);
  return out;
}

SeparatedMesh separate_parts(const LatticeMesh& lm, const MaterialParts& parts) {
  const TetMesh& mesh = lm.mesh;
  const Index ne = mesh.num_elements();
  // Elements without material are left out: they hold nothing, and on
  // nodes of different parts they would join them.
  const std::vector<Index>& copy_node = parts.copy_node;
  // Node copies numbered by node, then copy.
  std::vector<Index> order(copy_node.size());
  std::iota(order.begin(), order.end(), Index{0});
  std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return copy_node[at(a)] < copy_node[at(b)]; });
  std::vector<Index> renumbered(copy_node.size());
  SeparatedMesh out{LatticeMesh{lm.lattice, {}, {}, {}, {}, {}, {}}, {}, {}, {}, {}};
  out.node.resize(copy_node.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    renumbered[at(order[i])] = static_cast<Index>(i);
    out.node[i] = copy_node[at(order[i])];
  }
  // Element copies.
  std::vector<std::array<Index, 4>> tets;
  out.first_copy.assign(at(ne) + 1, 0);
  for (Index e = 0; e < ne; ++e) {
    out.first_copy[at(e)] = static_cast<Index>(tets.size());
    if (parts.num_parts(e) > 0) {
      for (Index p = parts.first_part[at(e)]; p < parts.first_part[at(e) + 1]; ++p) {
        std::array<Index, 4> t{};
        for (int k = 0; k < 4; ++k)
          t[static_cast<std::size_t>(k)] = renumbered[at(parts.part_nodes[at(p)][static_cast<std::size_t>(k)])];
        tets.push_back(t);
        out.element.push_back(e);
        out.part.push_back(p);
      }
    }
  }
  out.first_copy[at(ne)] = static_cast<Index>(tets.size());
  LatticeMesh& c = out.copies;
  c.lattice = lm.lattice;
  c.mesh.positions.resize(static_cast<Eigen::Index>(out.node.size()), 3);
  c.node_keys.resize(out.node.size());
  c.node_inside.resize(out.node.size());
  for (std::size_t i = 0; i < out.node.size(); ++i) {
    c.mesh.positions.row(static_cast<Eigen::Index>(i)) = mesh.positions.row(out.node[i]);
    c.node_keys[i] = lm.node_keys[at(out.node[i])];
    c.node_inside[i] = lm.node_inside[at(out.node[i])];
  }
  c.mesh.tets.resize(static_cast<Eigen::Index>(tets.size()), 4);
  c.tet_keys.resize(tets.size());
  for (std::size_t i = 0; i < tets.size(); ++i) {
    for (int k = 0; k < 4; ++k) c.mesh.tets(static_cast<Eigen::Index>(i), k) = tets[i][static_cast<std::size_t>(k)];
    c.tet_keys[i] = lm.tet_keys[at(out.element[i])];
  }
  return out;
}

std::vector<Index> vertex_copies(const LatticeMesh& lm, const SeparatedMesh& separated, const MaterialParts& parts,
                                 const TriangleMesh& surface, const std::vector<Index>& vertex_element) {
  const Index nv = surface.num_vertices();
  // Each vertex's triangles.
  std::vector<Index> first(at(nv) + 1, 0), triangles(at(3 * surface.num_triangles()));
  for (Index t = 0; t < surface.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) ++first[at(surface.triangles(t, k)) + 1];
  for (std::size_t v = 0; v + 1 < first.size(); ++v) first[v + 1] += first[v];
  {
    std::vector<Index> fill(first.begin(), first.end() - 1);
    for (Index t = 0; t < surface.num_triangles(); ++t)
      for (int k = 0; k < 3; ++k) triangles[at(fill[at(surface.triangles(t, k))]++)] = t;
  }
  // The copy of triangle t's part in element e, −1 if t has no piece there
  // or e has no copy of that part.
  auto copy_of = [&](Index e, Index t) -> Index {
    const auto begin = parts.pair_triangle.begin() + parts.pair_first[at(e)];
    const auto end = parts.pair_triangle.begin() + parts.pair_first[at(e) + 1];
    const auto it = std::lower_bound(begin, end, t);
    if (it == end || *it != t) return -1;
    const Index p = parts.pair_part[static_cast<std::size_t>(it - parts.pair_triangle.begin())];
    const Index c = separated.first_copy[at(e)] + (p - parts.first_part[at(e)]);
    return c < separated.first_copy[at(e) + 1] ? c : -1;
  };
  std::vector<Index> out(at(nv), -1);
  tbb::parallel_for(tbb::blocked_range<Index>(0, nv, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index v = r.begin(); v != r.end(); ++v) {
      const Index e = vertex_element[at(v)];
      for (Index i = first[at(v)]; i < first[at(v) + 1] && out[at(v)] < 0 && e >= 0; ++i)
        out[at(v)] = copy_of(e, triangles[at(i)]);
      if (out[at(v)] >= 0) continue;
      // The element containing the vertex best among those its triangles
      // have pieces in (the lowest copy on a tie).
      const Eigen::Vector3d x = surface.vertices.row(v).transpose();
      double best = -std::numeric_limits<double>::infinity();
      for (Index i = first[at(v)]; i < first[at(v) + 1]; ++i) {
        const Index t = triangles[at(i)];
        // Elements holding t: search the elements around the vertex's cell.
        const Eigen::Vector3i cell = lm.lattice.cell_of(x);
        for (int dk = -1; dk <= 1; ++dk)
          for (int dj = -1; dj <= 1; ++dj)
            for (int di = -1; di <= 1; ++di) {
              const Eigen::Vector3i c = cell + Eigen::Vector3i(di, dj, dk);
              if ((c.array() < 0).any() || (c.array() >= lm.lattice.cells().array()).any()) continue;
              for (int shape = 0; shape < 12; ++shape) {
                const BccLattice::Key key = lm.lattice.tet_key(c, shape / 4, shape % 4);
                const Index f = lm.element(key);
                if (f < 0) continue;
                const Index copy = copy_of(f, t);
                if (copy < 0) continue;
                const double b = lm.lattice.barycentric(key, x).minCoeff();
                if (b > best || (b == best && copy < out[at(v)])) {
                  best = b;
                  out[at(v)] = copy;
                }
              }
            }
      }
    }
  });
  return out;
}

}  // namespace goo
