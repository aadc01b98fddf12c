#include "core/embedding.h"

namespace goo {

Eigen::SparseMatrix<double, Eigen::RowMajor> Embedding::operator_matrix(const TetMesh& mesh) const {
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(4 * parent.size());
  for (std::size_t v = 0; v < parent.size(); ++v)
    for (int k = 0; k < 4; ++k)
      triplets.emplace_back(static_cast<Index>(v), mesh.tets(parent[v], k), bary(static_cast<Eigen::Index>(v), k));
  Eigen::SparseMatrix<double, Eigen::RowMajor> W(static_cast<Eigen::Index>(parent.size()), mesh.num_nodes());
  W.setFromTriplets(triplets.begin(), triplets.end());
  return W;
}

Points Embedding::surface_positions(const Tets& tets, const Points& x) const {
  Points out(static_cast<Eigen::Index>(parent.size()), 3);
  for (std::size_t v = 0; v < parent.size(); ++v) {
    Eigen::RowVector3d p = Eigen::RowVector3d::Zero();
    for (int k = 0; k < 4; ++k) p += bary(static_cast<Eigen::Index>(v), k) * x.row(tets(parent[v], k));
    out.row(static_cast<Eigen::Index>(v)) = p;
  }
  return out;
}

}  // namespace goo
