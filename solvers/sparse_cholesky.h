#pragma once
// A sparse Cholesky factorisation of a symmetric positive-definite matrix
// stored as its lower triangle: CHOLMOD's supernodal LLᵀ behind a pimpl (only
// sparse_cholesky.cpp includes CHOLMOD), its symbolic analysis kept while
// the pattern is the same, and conjugate gradients preconditioned with the
// last factor (a lagged factor stays a good preconditioner while the
// matrix's values drift; docs/implicit.md, "Linear solves").
#include <Eigen/SparseCore>
#include <memory>

namespace goo {

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  /// Whether the symbolic analysis is of the pattern `pattern` (an id the
  /// caller keeps per pattern, e.g. SparseHessian::builds()).
  [[nodiscard]] bool analysed_for(int pattern) const;
  /// The symbolic analysis (fill-reducing ordering, supernodes) of A's pattern.
  void analyse(const Eigen::SparseMatrix<double>& A, int pattern);
  /// The numerical factor of A (pattern analysed); false if A is not
  /// positive definite, and then there is no factor.
  bool factor(const Eigen::SparseMatrix<double>& A, int pattern);
  /// Whether a factor of a matrix with this pattern is held.
  [[nodiscard]] bool has_factor_for(int pattern) const;
  /// x = A⁻¹ b with the factor held; false if the solve fails.
  bool solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const;
  /// Solves A x = b (A lower-stored, with the held factor's pattern) by
  /// conjugate gradients preconditioned with the held factor, from
  /// x₀ = L⁻ᵀL⁻¹ b, to ‖r‖ ≤ tolerance ‖b‖; counts the iterations into
  /// `iterations`. False after max_iterations, or where A is not positive
  /// definite along a search direction.
  bool preconditioned_cg(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& b, Eigen::VectorXd& x,
                         double tolerance, int max_iterations, int& iterations) const;
  /// Drops the factor (the analysis stays): the next solve factors afresh.
  void forget_factor();
  /// Symbolic analyses so far.
  [[nodiscard]] int analyses() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace goo
