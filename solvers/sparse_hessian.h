#pragma once
// The sparse Hessian of a body's implicit step: pattern and element-to-slot
// map computed once per mesh topology, values assembled from per-element
// 12×12 blocks (computed in parallel, added in element order: deterministic),
// and from the surface tension's per-triangle blocks, which couple the up to
// 12 nodes a triangle's corners are embedded in.
#include <Eigen/SparseCore>
#include <vector>

#include "core/body.h"
#include "core/element_elasticity.h"
#include "solvers/embedded_tension.h"

namespace goo {

/// Lower triangle (row ≥ column) of a symmetric 3N×3N matrix whose nonzeros
/// are the 3×3 blocks of node pairs sharing an element.
class SparseHessian {
 public:
  /// (Re)builds pattern and slots for these elements, and the node pairs of
  /// each surface triangle (rows of `surface`, none by default); counts how
  /// often. The pattern depends on its arguments only, never on earlier
  /// ones (so a restarted run factors the same matrix in the same order).
  void build(const Tets& tets, Index num_nodes, const Eigen::Matrix<Index, Eigen::Dynamic, 12, Eigen::RowMajor>& surface = {});
  /// Whether the pattern was built for exactly these elements and triangles.
  [[nodiscard]] bool matches(const Tets& tets, Index num_nodes,
                             const Eigen::Matrix<Index, Eigen::Dynamic, 12, Eigen::RowMajor>& surface = {}) const;
  [[nodiscard]] int builds() const { return builds_; }

  /// values = Σ_e blocks[e] (scattered by the slot map) + diagonal.
  void assemble(const std::vector<Matrix12>& blocks, const Eigen::VectorXd& diagonal);
  /// values += Σ_t Wₜᵀ H[t] Wₜ: triangle t's 9×9 block (corner positions)
  /// mapped to its nodes with their weights (surface.nodes must be the
  /// pattern's). In triangle order: deterministic.
  void add_surface(const SurfaceNodes& surface, const std::vector<Matrix9d>& H);
  /// Rows and columns of fixed nodes become the identity.
  void fix_nodes(const std::vector<std::uint8_t>& fixed);

  [[nodiscard]] const Eigen::SparseMatrix<double>& matrix() const { return matrix_; }

 private:
  /// The value index of entry (3p + x, 3q + y), p ≥ q (and x ≥ y if p = q).
  [[nodiscard]] Index slot(Index p, Index q, int x, int y) const;

  Tets tets_;
  Eigen::Matrix<Index, Eigen::Dynamic, 12, Eigen::RowMajor> surface_;
  Eigen::SparseMatrix<double> matrix_;  // lower triangle, compressed
  std::vector<Index> slots_;            // 78 × 4 … per element: its lower-triangle entries' value indices
  std::vector<Index> diagonal_slots_;   // 3N
  int builds_ = 0;
};

}  // namespace goo
