#pragma once
// Clipping of convex polygons and polyhedra by planes (Sutherland–Hodgman),
// and the signed volumes and first moments of cones over polygons: what the
// exact sub-element masses and the tet–tet overlap volumes are made of.
#include <array>
#include <vector>

#include "core/types.h"

namespace goo {

/// The plane n·x = offset; `distance` is signed, positive on the side n
/// points to (outside, for a face of a convex body).
struct Plane {
  Eigen::Vector3d normal;
  double offset = 0.0;
  [[nodiscard]] double distance(const Eigen::Vector3d& p) const { return normal.dot(p) - offset; }
};

/// A convex polygon of at most kCapacity vertices (a triangle or a
/// tetrahedron's face clipped by the four planes of another has at most 7;
/// a cut through a tetrahedron clipped by three planes, at most 7).
struct Polygon {
  static constexpr int kCapacity = 10;
  std::array<Eigen::Vector3d, kCapacity> v;
  int size = 0;
  void push(const Eigen::Vector3d& p) {
    if (size < kCapacity) v[static_cast<std::size_t>(size++)] = p;
  }
};

/// Outward unit-normal planes of a positively oriented tetrahedron, face k
/// opposite vertex k.
std::array<Plane, 4> tet_planes(const std::array<Eigen::Vector3d, 4>& x);

/// Vertex order of face k (opposite vertex k) of a positively oriented
/// tetrahedron, counter-clockwise seen from outside.
inline constexpr int kTetFaces[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/// The crossing of edge pq with a plane, given the endpoints' signed
/// distances dp and dq of opposite signs; computed from the endpoints in a
/// fixed (lexicographic) order, so the two faces sharing an edge get the
/// same point, bit for bit.
Eigen::Vector3d edge_crossing(const Eigen::Vector3d& p, double dp, const Eigen::Vector3d& q, double dq);

/// The part of `polygon` with distance ≤ 0 (vertex order kept).
Polygon clip(const Polygon& polygon, const Plane& plane);

/// Volume and first moment about an apex of cones over polygons.
struct ConeIntegrals {
  double volume = 0.0;                               ///< Σ signed cone volumes
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  ///< Σ ∫ (x − apex) dV
  void add_cone(const Eigen::Vector3d& apex, const Polygon& base, double sign = 1.0);
};

/// Volume of the intersection of two positively oriented tetrahedra:
/// `a` clipped by the four planes of `b` as a closed polyhedron (faces
/// clipped, each cut closed by a cap). Exact up to round-off, also when faces
/// coincide or touch: vertices within `tolerance` of a plane count as on it,
/// a polyhedron on one side of a plane is kept whole or dropped whole.
double tet_overlap_volume(const std::array<Eigen::Vector3d, 4>& a, const std::array<Eigen::Vector3d, 4>& b,
                          double tolerance);
/// The same with both tetrahedra's planes given (tet_planes), when they are reused.
double tet_overlap_volume(const std::array<Eigen::Vector3d, 4>& a, const std::array<Plane, 4>& a_planes,
                          const std::array<Eigen::Vector3d, 4>& b, const std::array<Plane, 4>& b_planes,
                          double tolerance);

/// Distance from p to a triangle (closest point by region, Ericson 2005).
double point_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c);

}  // namespace goo
