#include "meshing/convex_clip.h"

#include <algorithm>
#include <cmath>

namespace goo {
namespace {

double snapped(const Plane& plane, const Eigen::Vector3d& p, double tolerance) {
  const double d = plane.distance(p);
  return std::abs(d) <= tolerance ? 0.0 : d;
}

/// Points of a cut, collected from the clipped faces.
struct CutPoints {
  static constexpr int kCapacity = 48;
  std::array<Eigen::Vector3d, kCapacity> p;
  int size = 0;
  void push_back(const Eigen::Vector3d& x) {
    if (size < kCapacity) p[static_cast<std::size_t>(size++)] = x;
  }
};

/// Sutherland–Hodgman with snapped distances; points on the plane are also
/// appended to `on_plane` (the cap's vertices).
template <class Sink>
Polygon clip_snapped(const Polygon& polygon, const Plane& plane, double tolerance, Sink* on_plane) {
  Polygon out;
  if (polygon.size == 0) return out;
  std::array<double, Polygon::kCapacity> d{};
  for (int i = 0; i < polygon.size; ++i)
    d[static_cast<std::size_t>(i)] = snapped(plane, polygon.v[static_cast<std::size_t>(i)], tolerance);
  for (int i = 0; i < polygon.size; ++i) {
    const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>((i + 1) % polygon.size);
    if (d[a] <= 0.0) {
      out.push(polygon.v[a]);
      if (d[a] == 0.0 && on_plane) on_plane->push_back(polygon.v[a]);
    }
    if ((d[a] < 0.0 && d[b] > 0.0) || (d[a] > 0.0 && d[b] < 0.0)) {
      const Eigen::Vector3d x = edge_crossing(polygon.v[a], d[a], polygon.v[b], d[b]);
      out.push(x);
      if (on_plane) on_plane->push_back(x);
    }
  }
  if (out.size < 3) out.size = 0;
  return out;
}

}  // namespace

Eigen::Vector3d edge_crossing(const Eigen::Vector3d& p, double dp, const Eigen::Vector3d& q, double dq) {
  const bool swap = std::lexicographical_compare(q.data(), q.data() + 3, p.data(), p.data() + 3);
  const Eigen::Vector3d& a = swap ? q : p;
  const Eigen::Vector3d& b = swap ? p : q;
  const double da = swap ? dq : dp, db = swap ? dp : dq;
  return a + (b - a) * (da / (da - db));
}

std::array<Plane, 4> tet_planes(const std::array<Eigen::Vector3d, 4>& x) {
  std::array<Plane, 4> planes;
  for (std::size_t k = 0; k < 4; ++k) {
    const Eigen::Vector3d& a = x[static_cast<std::size_t>(kTetFaces[k][0])];
    const Eigen::Vector3d& b = x[static_cast<std::size_t>(kTetFaces[k][1])];
    const Eigen::Vector3d& c = x[static_cast<std::size_t>(kTetFaces[k][2])];
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    planes[k] = {n, n.dot(a)};
  }
  return planes;
}

Polygon clip(const Polygon& polygon, const Plane& plane) {
  return clip_snapped<CutPoints>(polygon, plane, 0.0, nullptr);
}

void ConeIntegrals::add_cone(const Eigen::Vector3d& apex, const Polygon& base, double sign) {
  if (base.size < 3) return;
  const Eigen::Vector3d a = base.v[0] - apex;
  for (int i = 1; i + 1 < base.size; ++i) {
    const Eigen::Vector3d b = base.v[static_cast<std::size_t>(i)] - apex;
    const Eigen::Vector3d c = base.v[static_cast<std::size_t>(i + 1)] - apex;
    // Signed volume of the tetrahedron (apex, a, b, c) and its first moment
    // about the apex: volume × (a + b + c) / 4.
    const double v = sign * a.dot(b.cross(c)) / 6.0;
    volume += v;
    moment += v * 0.25 * (a + b + c);
  }
}

double tet_overlap_volume(const std::array<Eigen::Vector3d, 4>& a, const std::array<Eigen::Vector3d, 4>& b,
                          double tolerance) {
  return tet_overlap_volume(a, tet_planes(a), b, tet_planes(b), tolerance);
}

double tet_overlap_volume(const std::array<Eigen::Vector3d, 4>& a, const std::array<Plane, 4>& a_planes,
                          const std::array<Eigen::Vector3d, 4>& b, const std::array<Plane, 4>& b_planes,
                          double tolerance) {
  // b against a's planes first: separated (a plane of a has b wholly
  // outside) or contained (b wholly inside a) without clipping.
  bool b_inside_a = true;
  for (const Plane& plane : a_planes) {
    int outside = 0;
    for (const auto& p : b) {
      const double d = snapped(plane, p, tolerance);
      outside += d >= 0.0;
      b_inside_a = b_inside_a && d <= 0.0;
    }
    if (outside == 4) return 0.0;
  }
  if (b_inside_a) return std::max(0.0, (b[1] - b[0]).dot((b[2] - b[0]).cross(b[3] - b[0])) / 6.0);
  std::array<Polygon, 8> faces;
  int num_faces = 4;
  for (std::size_t k = 0; k < 4; ++k)
    for (const int i : kTetFaces[k]) faces[k].push(a[static_cast<std::size_t>(i)]);
  CutPoints cap;
  for (const Plane& plane : b_planes) {
    bool any_inside = false, any_outside = false;
    for (int f = 0; f < num_faces; ++f)
      for (int i = 0; i < faces[static_cast<std::size_t>(f)].size; ++i) {
        const double d = snapped(plane, faces[static_cast<std::size_t>(f)].v[static_cast<std::size_t>(i)], tolerance);
        any_inside |= d < 0.0;
        any_outside |= d > 0.0;
      }
    if (!any_inside) return 0.0;  // on or beyond the plane: touching at most
    if (!any_outside) continue;   // wholly on the kept side
    cap.size = 0;
    int kept = 0;
    for (int f = 0; f < num_faces; ++f) {
      Polygon clipped = clip_snapped(faces[static_cast<std::size_t>(f)], plane, tolerance, &cap);
      if (clipped.size >= 3) faces[static_cast<std::size_t>(kept++)] = clipped;
    }
    num_faces = kept;
    if (cap.size < 3 || num_faces >= 8) continue;
    // The cap: the cut's points in counter-clockwise order about the plane's
    // normal (it is the outward normal of the kept part there), sorted by a
    // pseudo-angle (monotone in the angle, no trigonometry).
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int i = 0; i < cap.size; ++i) centre += cap.p[static_cast<std::size_t>(i)];
    centre /= static_cast<double>(cap.size);
    const Eigen::Vector3d u = plane.normal.unitOrthogonal(), w = plane.normal.cross(u);
    std::array<std::pair<double, int>, CutPoints::kCapacity> around;
    for (int i = 0; i < cap.size; ++i) {
      const Eigen::Vector3d d = cap.p[static_cast<std::size_t>(i)] - centre;
      const double x = d.dot(u), y = d.dot(w);
      const double r = std::abs(x) + std::abs(y);
      const double t = r > 0.0 ? y / r : 0.0;  // in [−1, 1] along the diamond
      around[static_cast<std::size_t>(i)] = {x >= 0.0 ? t : (y >= 0.0 ? 2.0 - t : -2.0 - t), i};
    }
    std::sort(around.begin(), around.begin() + cap.size);
    Polygon& lid = faces[static_cast<std::size_t>(num_faces)];
    lid.size = 0;
    for (int i = 0; i < cap.size; ++i) {
      const Eigen::Vector3d& p = cap.p[static_cast<std::size_t>(around[static_cast<std::size_t>(i)].second)];
      if (lid.size == 0 || (p - lid.v[static_cast<std::size_t>(lid.size - 1)]).squaredNorm() > 0.0) lid.push(p);
    }
    if (lid.size >= 3) ++num_faces;
  }
  ConeIntegrals integrals;
  for (int f = 0; f < num_faces; ++f) integrals.add_cone(a[0], faces[static_cast<std::size_t>(f)]);
  return std::max(0.0, integrals.volume);
}

double point_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c) {
  // Voronoi regions of the vertices, then the edges, then the face.
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return ap.norm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return bp.norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return (p - (a + ab * (d1 / (d1 - d3)))).norm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return cp.norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return (p - (a + ac * (d2 / (d2 - d6)))).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
    return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).norm();
  const double denom = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

}  // namespace goo
