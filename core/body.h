#pragma once
// The state of one simulated body: structure of arrays, indexed by node id
// and element id (architecture.md, "State").
#include <string_view>
#include <vector>

#include "core/embedding.h"
#include "core/material.h"
#include "core/tet_mesh.h"
#include "core/triangle_mesh.h"

namespace goo {

/// For each node, the element corners (4 e + k) that touch it, in increasing
/// order: node sums gather per-element values in this fixed order, so they
/// are bitwise identical for any number of threads.
struct NodeIncidence {
  std::vector<Index> offsets;  ///< #N+1; corners of node n are [offsets[n], offsets[n+1])
  std::vector<Index> corners;  ///< 4 #E entries, 4 e + k
  /// 4 #E entries: where corner 4 e + k is in `corners`. A pass over the
  /// elements that writes its corner values there leaves each node's values
  /// contiguous, in the order its sum takes them.
  std::vector<Index> slots;

  static NodeIncidence build(const Tets& tets, Index num_nodes);
};

struct Body {
  Material material;

  // Nodes.
  Points rest_positions;   ///< #N×3 positions when the mesh was made, m
  Points positions;        ///< #N×3 x, m
  Points velocities;       ///< #N×3 v, m/s
  Eigen::VectorXd masses;  ///< #N lumped masses, kg

  // Elements.
  Tets tets;                            ///< #E×4
  std::vector<Eigen::Matrix3d> Dm_inv;  ///< #E inverse rest edge matrices, 1/m
  Eigen::VectorXd rest_volumes;         ///< #E W = |det Dm| / 6, m³
  std::vector<Eigen::Matrix3d> Fp;      ///< #E plastic deformation
  Eigen::VectorXd alpha;                ///< #E accumulated hardening, Pa
  Eigen::VectorXd rest_condition;       ///< #E condition number of Dm at creation
  /// #E fraction of each element the material fills, in [0, 1] (the
  /// embedded surface moves with the elements, so it holds until the next
  /// re-mesh). Empty: every element full (a tetrahedral body).
  Eigen::VectorXd solid_fractions;

  NodeIncidence incidence;
  /// The stress-free volume of the material, Σ W det Fp over the solid, m³:
  /// invariant in time (plastic flow is isochoric), so a re-mesh restores it.
  /// A body made from a tetrahedral mesh starts with Σ W (the material fills
  /// its elements); a lattice body with its solid's volume.
  double rest_material_volume = 0.0;

  // The embedded surface (empty for a body without one).
  Triangles surface_triangles;  ///< #T×3 vertex ids, counter-clockwise seen from outside
  Embedding embedding;          ///< each surface vertex's parent element and barycentric coordinates

  /// The surface at the current positions: x_s = Σ b_i x_i.
  [[nodiscard]] TriangleMesh surface() const {
    return {embedding.surface_positions(tets, positions), surface_triangles};
  }

  [[nodiscard]] Index num_nodes() const { return static_cast<Index>(positions.rows()); }
  [[nodiscard]] Index num_elements() const { return static_cast<Index>(tets.rows()); }
};

/// A body at rest in the mesh's configuration: F = Fp = I, v = 0, masses
/// lumped from element volumes (ρ W / 4 to each node). The mesh is checked
/// and oriented first (check_and_orient); the material is validated.
Body make_body(TetMesh mesh, const Material& material, std::string_view source = "body");

/// The boundary faces of the body's tetrahedra (face_neighbours), outward,
/// as its embedded surface: each boundary node is a surface vertex on a
/// corner of its first element (barycentric coordinate 1 there), numbered
/// in the order of the faces' sorted nodes.
void embed_boundary(Body& body);

/// Lumped masses: each element gives ρ W det(Fp) / 4 to each of its nodes.
void lump_masses(Body& body);

/// Σ m v (kg m/s) and Σ m x × v (kg m²/s), in node order.
Eigen::Vector3d linear_momentum(const Body& body);
Eigen::Vector3d angular_momentum(const Body& body);
/// ½ Σ m |v|², J.
double kinetic_energy(const Body& body);

}  // namespace goo
