#pragma once
// A fine surface embedded in a tetrahedral mesh (W&T sec. 4): each vertex
// has a parent element and barycentric coordinates in it.
#include <Eigen/SparseCore>
#include <vector>

#include "core/tet_mesh.h"

namespace goo {

struct Embedding {
  std::vector<Index> parent;                                       ///< #V element ids
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> bary;  ///< #V×4, in the element's node order

  [[nodiscard]] Index num_vertices() const { return static_cast<Index>(parent.size()); }
  /// W (#V × #N, 4 entries a row): surface positions x_s = W x, node forces Wᵀ f_s.
  [[nodiscard]] Eigen::SparseMatrix<double, Eigen::RowMajor> operator_matrix(const TetMesh& mesh) const;
  /// x_s = Σ b_i x_i over each vertex's parent (#V×3).
  [[nodiscard]] Points surface_positions(const Tets& tets, const Points& node_positions) const;
  /// The same for the listed vertices only: their rows of `out` (#V×3)
  /// set to what surface_positions gives them, to the bit; the others kept.
  void update_surface_positions(const Tets& tets, const Points& node_positions, const std::vector<Index>& vertices,
                                Points& out) const;
  /// x_s of vertex v.
  [[nodiscard]] Eigen::RowVector3d surface_position(const Tets& tets, const Points& x, Index v) const {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    const Index e = parent[static_cast<std::size_t>(v)];
    for (int k = 0; k < 4; ++k) p += bary(v, k) * x.row(tets(e, k));
    return p;
  }
};

/// Moves each surface vertex to `targets` (#V×3) and finds its new parent
/// and barycentric coordinates in the mesh at positions x by walking from
/// its old parent across the face opposite its most negative coordinate
/// (at most `max_steps` steps; `neighbours` from face_neighbours). A vertex
/// that leaves the mesh keeps the element it is least outside of, with
/// negative coordinates (the −0.2 re-mesh trigger watches them). Inverted
/// or flat elements stop the walk.
void reembed(Embedding& embedding, const Tets& tets, const Tets& neighbours, const Points& x, const Points& targets,
             int max_steps = 32);

}  // namespace goo
