#include "solvers/sparse_cholesky.h"

#include <Eigen/CholmodSupport>

#include "solvers/linear_algebra_threads.h"

namespace goo {

struct SparseCholesky::Impl {
  // A factor that fails (not positive definite) comes back as info(), which
  // the caller handles; CHOLMOD's own warnings on stderr are silenced.
  Impl() { llt.cholmod().print = 0; }
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt;
  int analyses = 0;
  int analysed_for = -1;  // the pattern of the last analysis
  int factored_for = -1;  // the same, for the factor held (-1: none)
};

SparseCholesky::SparseCholesky() : impl_(std::make_unique<Impl>()) {
  // One BLAS (and OpenMP) thread, set once per process by the one class
  // that calls BLAS: TBB already runs the assembly on every core, and BLAS
  // threads spinning next to TBB's workers cost more than they bring.
  static const bool configured = [] {
    set_linear_algebra_threads(1);
    return true;
  }();
  (void)configured;
}
SparseCholesky::~SparseCholesky() = default;

bool SparseCholesky::analysed_for(int pattern) const { return impl_->analysed_for == pattern; }

void SparseCholesky::analyse(const Eigen::SparseMatrix<double>& A, int pattern) {
  impl_->llt.analyzePattern(A);
  ++impl_->analyses;
  impl_->analysed_for = pattern;
}

bool SparseCholesky::factor(const Eigen::SparseMatrix<double>& A, int pattern) {
  impl_->llt.factorize(A);
  if (impl_->llt.info() != Eigen::Success) {
    impl_->factored_for = -1;
    return false;
  }
  impl_->factored_for = pattern;
  return true;
}

bool SparseCholesky::has_factor_for(int pattern) const { return impl_->factored_for == pattern; }

bool SparseCholesky::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) const {
  x = impl_->llt.solve(b);
  return impl_->llt.info() == Eigen::Success;
}

bool SparseCholesky::preconditioned_cg(const Eigen::SparseMatrix<double>& A, const Eigen::VectorXd& b,
                                       Eigen::VectorXd& x, double tolerance, int max_iterations,
                                       int& iterations) const {
  const auto H = A.selfadjointView<Eigen::Lower>();
  const auto& llt = impl_->llt;
  x = llt.solve(b);
  Eigen::VectorXd r = b - H * x;
  const double b_norm = b.norm();
  if (b_norm == 0.0) return true;
  Eigen::VectorXd z = llt.solve(r), p = z, Ap;
  double rz = r.dot(z);
  for (int k = 0; k < max_iterations; ++k) {
    if (r.norm() <= tolerance * b_norm) return true;
    Ap = H * p;
    const double curvature = p.dot(Ap);
    if (!(curvature > 0.0)) return false;  // A is not positive definite along p
    const double alpha = rz / curvature;
    x += alpha * p;
    r -= alpha * Ap;
    ++iterations;
    z = llt.solve(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return r.norm() <= tolerance * b_norm;
}

void SparseCholesky::forget_factor() { impl_->factored_for = -1; }

int SparseCholesky::analyses() const { return impl_->analyses; }

}  // namespace goo
