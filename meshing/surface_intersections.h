#pragma once
// Where a triangle surface passes through itself: exact triangle–triangle
// tests and a search over a whole surface, with the meaning of CGAL's
// Polygon_mesh_processing::self_intersections (docs/embedded-surface.md,
// "Surface quality"). Every decision is made with exact orientation
// predicates, so a count is a fact about the coordinates, not a tolerance.
#include <array>
#include <vector>

#include "core/triangle_mesh.h"

namespace goo {

/// Whether two closed triangles of one surface intersect more than their
/// shared vertices and edge allow, decided exactly:
///   - no shared vertex: any common point;
///   - one shared vertex: the edge opposite it in either triangle meets the
///     other triangle;
///   - a shared edge: the two triangles lie in one plane and overlap (folded
///     flat onto each other);
///   - three shared vertices: always (a duplicated triangle).
/// Shared means the same vertex id, as in CGAL. A triangle with zero area
/// (its three corners collinear, exactly) intersects nothing here; the
/// surface measurements count such triangles apart.
bool triangles_intersect(const TriangleMesh& mesh, Index s, Index t);

/// The same test for two triangles given by their corners, sharing nothing.
bool triangles_intersect(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1, const Eigen::Vector3d& a2,
                         const Eigen::Vector3d& b0, const Eigen::Vector3d& b1, const Eigen::Vector3d& b2);

/// Whether the closed segment ab meets the closed triangle (u, v, w), exactly.
bool segment_meets_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& u,
                            const Eigen::Vector3d& v, const Eigen::Vector3d& w);

/// Every pair of triangles that intersect (triangles_intersect), as (s, t)
/// with s < t, sorted. Broad phase: a uniform grid over the triangles'
/// bounding boxes; each pair is tested in one cell only. Parallel over TBB;
/// the result does not depend on the thread count.
std::vector<std::array<Index, 2>> self_intersecting_pairs(const TriangleMesh& mesh);

/// What a frame's surface looks like, in numbers (summary.json's
/// "surface" record of each frame).
struct SurfaceQuality {
  Index triangles = 0;
  Index edges = 0;                    ///< distinct edges
  Index self_intersecting_pairs = 0;  ///< triangle pairs, as self_intersecting_pairs()
  Index creased_edges = 0;            ///< edges of two triangles whose normals are more than 90° apart
  Index degenerate_triangles = 0;     ///< triangles of exactly zero area
  double area = 0.0;                  ///< m²
  double volume = 0.0;                ///< signed enclosed volume, m³
};

/// The quality measurements of a surface (valid indices required).
SurfaceQuality measure_surface_quality(const TriangleMesh& mesh);

/// Where one closed surface faces itself across a narrow gap of air: the
/// places a re-mesh of lattice spacing about `gap` puts two sheets of the
/// body into shared elements (docs/lattice.md, "Re-meshing"). Triangle s
/// faces triangle t when they share no vertex, their centroids are less
/// than `gap` apart, their normals point more than 120° apart, and each
/// centroid lies on the outer side of the other's plane, (c_t − c_s) · n_s > 0
/// and (c_s − c_t) · n_t > 0: air between them, not material (the two sides
/// of a thin sheet face away from each other). Returns the total area of the
/// triangles that face at least one other, m², and their number. Parallel
/// over TBB; the same bits for any thread count.
struct FacingSheets {
  double area = 0.0;
  Index triangles = 0;
};
FacingSheets facing_sheets(const TriangleMesh& mesh, double gap);

}  // namespace goo
