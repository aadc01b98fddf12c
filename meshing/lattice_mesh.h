#pragma once
// The tetrahedral mesh cut from the BCC lattice around a closed surface, and
// the surface embedded in it (W&T secs. 4–5).
#include <array>
#include <cstdint>
#include <vector>

#include "core/embedding.h"
#include "core/tet_mesh.h"
#include "core/triangle_mesh.h"
#include "meshing/bcc_lattice.h"

namespace goo {

struct LatticeMesh {
  BccLattice lattice;
  TetMesh mesh;                                           ///< compact nodes and tets, positively oriented
  std::vector<BccLattice::Key> node_keys;                 ///< #N lattice key of each node (in BccLattice::space_order)
  std::vector<BccLattice::Key> tet_keys;                  ///< #E lattice key of each tet (increasing)
  std::vector<std::uint8_t> node_inside;                  ///< #N 1 if the node is inside the surface (exact)
  std::vector<Index> element_of_key;                      ///< lattice tet key → element, −1 if not kept
  std::vector<Index> node_of_key;                         ///< lattice node key → node, −1 if not in the mesh

  /// The element of a lattice tetrahedron key (−1 if not kept or outside the block).
  [[nodiscard]] Index element(BccLattice::Key tet) const {
    return tet >= 0 && tet < static_cast<BccLattice::Key>(element_of_key.size())
               ? element_of_key[static_cast<std::size_t>(tet)]
               : -1;
  }
  /// The node of a lattice node key (−1 if not in the mesh or outside the block).
  [[nodiscard]] Index node(BccLattice::Key key) const {
    return key >= 0 && key < static_cast<BccLattice::Key>(node_of_key.size()) ? node_of_key[static_cast<std::size_t>(key)]
                                                                              : -1;
  }
};

/// Separating-axis test of a triangle and a tetrahedron, with both inflated
/// by `slack` along every axis: touching counts as overlapping, so coverage
/// is never lost to round-off (extra tetrahedra are harmless); false only
/// when a plane separates them by more than `slack`. Without `edge_axes`,
/// only the five face planes are tried (a cheaper filter: true may then
/// also mean separated along an edge–edge axis).
bool overlaps_inflated(const std::array<Eigen::Vector3d, 3>& tri, const std::array<Eigen::Vector3d, 4>& tet,
                       double slack, bool edge_axes = true);

/// The lattice block of spacing h around `surface` (aligned to the world
/// grid of spacing h, two cells of margin), and every lattice tetrahedron
/// that has an inside node or overlaps a surface triangle, so the kept
/// tetrahedra cover the whole surface (thin sheets have no inside nodes).
LatticeMesh build_lattice_mesh(const TriangleMesh& surface, double h);


/// Embeds surface vertices by constant-time lattice point location. A vertex
/// whose located tetrahedron was not kept (it lies on a face shared with a
/// kept one) goes to the kept neighbour that contains it best.
Embedding embed(const LatticeMesh& lattice_mesh, const Points& surface_vertices);

}  // namespace goo
