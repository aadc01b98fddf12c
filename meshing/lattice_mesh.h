#pragma once
// The tetrahedral mesh cut from the BCC lattice around a closed surface, and
// the surface embedded in it (W&T secs. 4–5).
#include <Eigen/SparseCore>
#include <unordered_map>
#include <vector>

#include "core/tet_mesh.h"
#include "core/triangle_mesh.h"
#include "meshing/bcc_lattice.h"

namespace goo {

struct LatticeMesh {
  BccLattice lattice;
  TetMesh mesh;                                           ///< compact nodes and tets, positively oriented
  std::vector<BccLattice::Key> node_keys;                 ///< #N lattice key of each node (increasing)
  std::vector<BccLattice::Key> tet_keys;                  ///< #E lattice key of each tet (increasing)
  std::unordered_map<BccLattice::Key, Index> element_of;  ///< lattice tet key → element
};

/// The lattice block of spacing h around `surface` (aligned to the world
/// grid of spacing h, two cells of margin), and every lattice tetrahedron
/// that has an inside node or overlaps a surface triangle, so the kept
/// tetrahedra cover the whole surface (thin sheets have no inside nodes).
LatticeMesh build_lattice_mesh(const TriangleMesh& surface, double h);

/// Each surface vertex's parent element and barycentric coordinates.
struct Embedding {
  std::vector<Index> parent;                                       ///< #V element ids
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> bary;  ///< #V×4, in the element's node order

  /// W (#V × #N, 4 entries a row): surface positions x_s = W x, node forces Wᵀ f_s.
  [[nodiscard]] Eigen::SparseMatrix<double, Eigen::RowMajor> operator_matrix(const TetMesh& mesh) const;
  /// x_s = Σ b_i x_i over each vertex's parent (#V×3).
  [[nodiscard]] Points surface_positions(const Tets& tets, const Points& node_positions) const;
};

/// Embeds surface vertices by constant-time lattice point location. A vertex
/// whose located tetrahedron was not kept (it lies on a face shared with a
/// kept one) goes to the kept neighbour that contains it best.
Embedding embed(const LatticeMesh& lattice_mesh, const Points& surface_vertices);

}  // namespace goo
