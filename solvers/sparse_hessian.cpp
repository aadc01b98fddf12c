#include "solvers/sparse_hessian.h"

#include <algorithm>

#include "core/parallel.h"

namespace goo {
namespace {

constexpr int kLowerEntries = 78;  // 12 · 13 / 2

}  // namespace

bool SparseHessian::matches(const Tets& tets, Index num_nodes,
                            const Eigen::Matrix<Index, Eigen::Dynamic, 12, Eigen::RowMajor>& surface) const {
  return matrix_.rows() == 3 * num_nodes && tets_.rows() == tets.rows() && tets_ == tets &&
         surface_.rows() == surface.rows() && surface_ == surface;
}

void SparseHessian::build(const Tets& tets, Index num_nodes,
                          const Eigen::Matrix<Index, Eigen::Dynamic, 12, Eigen::RowMajor>& surface) {
  ++builds_;
  tets_ = tets;
  surface_ = surface;
  const auto ne = static_cast<Index>(tets.rows());
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(at(ne) * kLowerEntries + at(3 * num_nodes));
  // Whole 3×3 blocks for every node pair (the lower triangle of the
  // diagonal ones), so that slot() can find entries by block.
  auto add_pair = [&](Index p, Index q) {
    if (p < q) std::swap(p, q);
    for (int x = 0; x < 3; ++x)
      for (int y = 0; y < 3; ++y)
        if (p > q || x >= y) triplets.emplace_back(3 * p + x, 3 * q + y, 0.0);
  };
  for (Index e = 0; e < ne; ++e)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b <= a; ++b) add_pair(tets(e, a), tets(e, b));
  for (Index t = 0; t < surface.rows(); ++t)
    for (int a = 0; a < 12; ++a)
      for (int b = 0; b <= a; ++b) add_pair(surface(t, a), surface(t, b));
  for (Index i = 0; i < 3 * num_nodes; ++i) triplets.emplace_back(i, i, 0.0);
  matrix_.resize(3 * num_nodes, 3 * num_nodes);
  matrix_.setFromTriplets(triplets.begin(), triplets.end());
  matrix_.makeCompressed();
  auto dof = [&](Index e, int a) { return 3 * tets(e, a / 3) + a % 3; };
  auto slot = [&](Index r, Index c) {
    const Index* begin = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[c];
    const Index* end = matrix_.innerIndexPtr() + matrix_.outerIndexPtr()[c + 1];
    return static_cast<Index>(std::lower_bound(begin, end, r) - matrix_.innerIndexPtr());
  };
  // Per element, all 144 entries mapped to their lower-triangle slot.
  slots_.resize(at(ne) * 144);
  for (Index e = 0; e < ne; ++e)
    for (int a = 0; a < 12; ++a)
      for (int b = 0; b < 12; ++b) {
        const Index r = dof(e, a), c = dof(e, b);
        slots_[at(e) * 144 + static_cast<std::size_t>(12 * a + b)] = r >= c ? slot(r, c) : -1;
      }
  diagonal_slots_.resize(at(3 * num_nodes));
  for (Index i = 0; i < 3 * num_nodes; ++i) diagonal_slots_[at(i)] = slot(i, i);
}

void SparseHessian::assemble(const std::vector<Matrix12>& blocks, const Eigen::VectorXd& diagonal) {
  double* values = matrix_.valuePtr();
  std::fill(values, values + matrix_.nonZeros(), 0.0);
  // Element order: the same sums for any thread count.
  for (std::size_t e = 0; e < blocks.size(); ++e)
    for (int a = 0; a < 12; ++a)
      for (int b = 0; b < 12; ++b) {
        const Index s = slots_[e * 144 + static_cast<std::size_t>(12 * a + b)];
        if (s >= 0) values[s] += blocks[e](a, b);
      }
  for (Index i = 0; i < diagonal.size(); ++i) values[diagonal_slots_[at(i)]] += diagonal[i];
}

Index SparseHessian::slot(Index p, Index q, int x, int y) const {
  // Column 3q + y holds rows 3q + y … 3q + 2 (the diagonal block's lower
  // part), then the same off-diagonal rows as column 3q, in order.
  const Index* inner = matrix_.innerIndexPtr();
  const auto* outer = matrix_.outerIndexPtr();
  if (p == q) return static_cast<Index>(outer[3 * q + y] + (x - y));
  const Index* begin = inner + outer[3 * q];
  const Index* end = inner + outer[3 * q + 1];
  const auto position = static_cast<Index>(std::lower_bound(begin, end, 3 * p) - begin);
  return static_cast<Index>(outer[3 * q + y] + position - y + x);
}

void SparseHessian::add_surface(const SurfaceNodes& surface, const std::vector<Matrix9d>& H) {
  double* values = matrix_.valuePtr();
  for (Index t = 0; t < surface.num_triangles(); ++t)
    for (int a = 0; a < 12; ++a)
      for (int b = 0; b < 12; ++b) {
        // Entry (node p, node q) of corner k's and corner l's 3×3 block; the
        // lower triangle only (the transposed term comes with (b, a)).
        const Index p = surface.nodes(t, a), q = surface.nodes(t, b);
        if (p < q) continue;
        const double w = surface.weights(t, a) * surface.weights(t, b);
        if (w == 0.0) continue;
        const auto block = H[at(t)].block<3, 3>(3 * (a / 4), 3 * (b / 4));
        for (int y = 0; y < 3; ++y) {
          const Index column = slot(p, q, p == q ? y : 0, y);
          for (int x = p == q ? y : 0; x < 3; ++x) values[column + (x - (p == q ? y : 0))] += w * block(x, y);
        }
      }
}

void SparseHessian::fix_nodes(const std::vector<std::uint8_t>& fixed) {
  for (Index c = 0; c < matrix_.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(matrix_, c); it; ++it) {
      const bool row_fixed = fixed[at(static_cast<Index>(it.row()) / 3)] != 0;
      const bool col_fixed = fixed[at(c / 3)] != 0;
      if (row_fixed || col_fixed) it.valueRef() = it.row() == c ? 1.0 : 0.0;
    }
}

}  // namespace goo
