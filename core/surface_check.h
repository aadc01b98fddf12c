#pragma once
// Checking a triangle surface before it is simulated: geometry, topology,
// orientation, and the first defect that makes it unfit.
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <string_view>

#include "core/triangle_mesh.h"

namespace goo {

struct SurfaceReport {
  Index num_vertices = 0;
  Index num_triangles = 0;
  Index num_edges = 0;
  Eigen::AlignedBox3d bounds;
  double area = 0.0;                                   ///< m²
  double volume = 0.0;                                 ///< signed enclosed volume, m³
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< volume centroid, m
  Index components = 0;                                ///< edge-connected components of triangles
  Index boundary_edges = 0;                            ///< edges with one triangle
  Index nonmanifold_edges = 0;                         ///< edges with three or more triangles
  Index nonmanifold_vertices = 0;                      ///< vertices whose triangles form several fans
  Index misoriented_triangles = 0;                     ///< triangles against their component's majority
  bool orientable = true;                              ///< false if no consistent orientation exists
  bool topology_valid = false;                         ///< false if indices or coordinates were unusable

  /// The first problem that makes the mesh unfit for simulation, phrased for a
  /// user ("triangle 3 is flipped ..."); empty when the mesh is fit, except
  /// for a negative volume, which validate_surface repairs.
  std::optional<std::string> first_defect;

  [[nodiscard]] bool closed() const { return topology_valid && boundary_edges == 0; }
  [[nodiscard]] bool edge_manifold() const { return topology_valid && nonmanifold_edges == 0; }
  [[nodiscard]] bool manifold() const { return edge_manifold() && nonmanifold_vertices == 0; }
  [[nodiscard]] bool consistently_oriented() const {
    return topology_valid && orientable && misoriented_triangles == 0;
  }
  /// V − E + F (2 − 2g for each closed orientable component of genus g).
  [[nodiscard]] Index euler_characteristic() const { return num_vertices - num_edges + num_triangles; }
};

/// Everything goo knows about a mesh. Never throws: defects are reported, in
/// a fixed order (coordinates, indices, degenerate triangles, boundary edges,
/// non-manifold edges, orientation, zero volume), the first in first_defect.
SurfaceReport analyze_surface(const TriangleMesh& mesh);

/// Refuses a mesh unfit for simulation with goo::Error("<source>: <defect>").
/// A closed, consistently oriented mesh whose volume is negative (inside-out)
/// is flipped in place, with a warning. Returns the report of the final mesh.
SurfaceReport validate_surface(TriangleMesh& mesh, std::string_view source);

/// Reverses the orientation of every triangle.
void flip_orientation(TriangleMesh& mesh);

}  // namespace goo
