#pragma once
// Distances and continuous collision detection between the primitives of
// a triangle surface: a vertex against a triangle, an edge against an edge.
// Positions move linearly over a step: x(t) = x + t d, t in [0, 1].
#include <Eigen/Core>
#include <array>
#include <optional>

namespace goo::ccd {

using Vec3 = Eigen::Vector3d;

/// Squared distance from p to the closed triangle (a, b, c), and the
/// barycentric coordinates of the closest point in `weights` (Ericson 2005,
/// "Real-Time Collision Detection", sec. 5.1.5). A triangle without area is
/// treated as its longest edge.
double point_triangle_distance2(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                                Vec3* weights = nullptr);

/// Squared distance between the closed segments p0p1 and q0q1, and the
/// parameters of the closest points, p0 + s (p1 − p0) and q0 + u (q1 − q0)
/// (Ericson 2005, sec. 5.1.9; parallel segments get one of their closest
/// pairs).
double segment_segment_distance2(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1,
                                 double* s = nullptr, double* u = nullptr);

enum class PairKind { vertex_triangle, edge_edge };

/// Four points: a vertex and a triangle's corners (x[0]; x[1..3]), or two
/// edges' ends (x[0], x[1]; x[2], x[3]).
using Points4 = std::array<Vec3, 4>;

/// The closest points of a pair, as weights on its four points: the vector
/// between them is Σ_k coefficients[k] x[k] (first primitive minus second),
/// so Σ coefficients = 0.
struct Closest {
  double distance = 0.0;
  std::array<double, 4> coefficients{};
};
Closest closest(PairKind kind, const Points4& x);

/// The first time t in [0, 1] at which a pair moving from x with
/// displacements d comes within `min_distance` of each other while
/// approaching, found by additive CCD (Li, Kaufman & Jiang 2021,
/// "Codimensional incremental potential contact", alg. 1): steps of
/// s (D − min_distance) / l_p, where l_p bounds the relative speed of any
/// two points of the pair, can never pass through min_distance, so the pair
/// is at least min_distance apart at and before the time returned. A pair
/// is reported once it is approaching and within 2 min_distance (or, for a
/// min_distance of 0, within a tenth of its first gap). nullopt: the pair
/// stays farther than min_distance over the whole step. A pair closer than
/// min_distance at t = 0 reports 0.
///
/// With `clearance`, a step without impact also tells how far its pair stays
/// beyond the reporting distance: the pair is at least 2 min_distance +
/// *clearance apart all step (each safe step of s·gap/l_p keeps the distance
/// above min_distance + (1 − s) gap). Displacements changed by at most e at
/// every point of the pair, with e < *clearance, report no impact either
/// (the distance moves by at most e). With an impact, *clearance is −∞.
std::optional<double> time_of_impact(PairKind kind, const Points4& x, const Points4& d, double min_distance,
                                     double* clearance = nullptr);

}  // namespace goo::ccd
