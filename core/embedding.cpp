#include "core/embedding.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/parallel.h"

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
  const Index nv = num_vertices();
  Points out(nv, 3);
  tbb::parallel_for(tbb::blocked_range<Index>(0, nv, 4 * kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index v = r.begin(); v != r.end(); ++v) out.row(v) = surface_position(tets, x, v);
  });
  return out;
}

void Embedding::update_surface_positions(const Tets& tets, const Points& x, const std::vector<Index>& vertices,
                                         Points& out) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, vertices.size(), 4 * kParallelGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i)
                        out.row(vertices[i]) = surface_position(tets, x, vertices[i]);
                    });
}

void reembed(Embedding& embedding, const Tets& tets, const Tets& neighbours, const Points& x, const Points& targets,
             int max_steps) {
  const Index nv = embedding.num_vertices();
  tbb::parallel_for(tbb::blocked_range<Index>(0, nv, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index v = r.begin(); v != r.end(); ++v) {
      const Eigen::Vector3d p = targets.row(v).transpose();
      Index e = embedding.parent[at(v)], best = -1;
      Eigen::Vector4d best_b = Eigen::Vector4d::Constant(-1e300);
      for (int step = 0; step <= max_steps && e >= 0; ++step) {
        const Eigen::Vector3d x0 = x.row(tets(e, 0)).transpose();
        Eigen::Matrix3d Ds;
        for (int k = 0; k < 3; ++k) Ds.col(k) = x.row(tets(e, k + 1)).transpose() - x0;
        if (!(Ds.determinant() > 0.0)) break;
        const Eigen::Vector3d c = Ds.inverse() * (p - x0);
        const Eigen::Vector4d b(1.0 - c.sum(), c.x(), c.y(), c.z());
        if (b.minCoeff() > best_b.minCoeff()) {
          best = e;
          best_b = b;
        }
        Eigen::Index worst = 0;
        if (b.minCoeff(&worst) >= 0.0) break;
        e = neighbours(e, static_cast<int>(worst));
      }
      if (best < 0) continue;  // the old parent is inverted: keep the old embedding
      embedding.parent[at(v)] = best;
      embedding.bary.row(v) = best_b.transpose();
    }
  });
}

}  // namespace goo
