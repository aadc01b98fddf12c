#pragma once
// From what files hold (polygons, triangle soups) to an indexed triangle mesh.
#include <span>
#include <vector>

#include "core/triangle_mesh.h"

namespace goo {

/// Triangulates one simple polygon (vertex ids into `vertices`, ≥ 3 of them)
/// by ear clipping in the plane of its Newell normal, appending triangles with
/// the polygon's winding to `out`. A polygon with no ear left (self-
/// intersecting, or degenerate to round-off) is finished as a fan.
void triangulate_polygon(std::span<const Index> polygon, const Points& vertices, std::vector<Eigen::Vector3i>& out);

struct WeldResult {
  Index merged = 0;        ///< vertices merged into an earlier one
  double tolerance = 0.0;  ///< absolute distance used, m
};

/// Merges vertices closer than `relative_tolerance` × (bounding-box diagonal)
/// into the first of them (in index order, so the result does not depend on
/// anything but the input), renumbers the triangles and drops unused vertices.
/// Triangle soups (STL) need it: every triangle carries its own copies.
WeldResult weld_vertices(TriangleMesh& mesh, double relative_tolerance);

/// Drops vertices that no triangle references, keeping the order of the rest.
/// Returns how many were dropped; with `new_ids`, each old vertex's new id
/// (−1: dropped).
Index remove_unreferenced_vertices(TriangleMesh& mesh, std::vector<Index>* new_ids = nullptr);

}  // namespace goo
