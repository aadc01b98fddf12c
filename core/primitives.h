#pragma once
// Closed, outward-oriented primitive surfaces at a chosen resolution.
// Every primitive is centred at the origin; move it with a transform.
#include "core/triangle_mesh.h"

namespace goo {

/// Axis-aligned box of the given full side lengths, each face split into
/// `subdivisions`² squares (two triangles each). subdivisions ≥ 1.
TriangleMesh make_box(const Eigen::Vector3d& size, int subdivisions);

/// Latitude–longitude sphere: `segments` around the z axis (≥ 3) and
/// segments/2 (at least 2) bands from pole to pole; poles are single vertices.
TriangleMesh make_sphere(double radius, int segments);

/// Cylinder along z of the given radius and full height: `segments` around
/// (≥ 3), side bands of roughly square aspect, caps fanned from their centre.
TriangleMesh make_cylinder(double radius, double height, int segments);

/// Torus around the z axis: tube centre circle of radius `major`, tube radius
/// `minor` < major; `major_segments` around z and `minor_segments` around the
/// tube (each ≥ 3).
TriangleMesh make_torus(double major, double minor, int major_segments, int minor_segments);

/// Each triangle split into four at its edges' midpoints, `times` times
/// (4^times as many triangles). Flat: every new vertex lies on an old edge,
/// so the surface, its area and its enclosed volume are unchanged; closed,
/// manifold and oriented as the input. A midpoint is shared by the edge's
/// two triangles; new vertices follow the old ones in the order their edges
/// are first met (triangles in order, edges 01, 12, 20).
TriangleMesh split_into_four(const TriangleMesh& mesh, int times = 1);

}  // namespace goo
