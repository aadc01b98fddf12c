#pragma once
// Central differences for the tests of every analytic derivative in goo
// (an energy's gradient, a force's Jacobian, a Hessian): one helper instead
// of a loop per test. Inputs and values are any dense Eigen object or a
// double, flattened in storage order: a column-major 3×3 F is vec(F), a
// 3×4 corner matrix is corner-major (entry 3k + i), a row-major Points is
// node-major (entry 3n + i), which are the orders goo's derivatives use.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "core/types.h"

namespace goo::test {

namespace detail {

inline Eigen::VectorXd flatten(double value) {
  return Eigen::VectorXd::Constant(1, value);
}
template <class Derived>
Eigen::VectorXd flatten(const Eigen::DenseBase<Derived>& value) {
  const typename Derived::PlainObject plain = value;
  return Eigen::Map<const Eigen::VectorXd>(plain.data(), plain.size());
}

}  // namespace detail

/// The m×n Jacobian of `value` at x by central differences with step h:
/// column j = (value(x + h e_j) − value(x − h e_j)) / 2h, for the input
/// coordinates listed (all by default; the other columns are zero). Its
/// error is h² |∂³value| / 6 from truncation plus ε |value| / h from
/// rounding.
template <class X, class Value>
Eigen::MatrixXd central_differences(const Value& value, const X& x, double h, const std::vector<Index>& coordinates = {}) {
  const auto n = static_cast<Index>(x.size());
  std::vector<Index> columns = coordinates;
  if (columns.empty())
    for (Index j = 0; j < n; ++j) columns.push_back(j);
  Eigen::MatrixXd jacobian;
  for (const Index j : columns) {
    X plus = x, minus = x;
    plus.data()[j] += h;
    minus.data()[j] -= h;
    const Eigen::VectorXd column = (detail::flatten(value(plus)) - detail::flatten(value(minus))) / (2.0 * h);
    if (jacobian.size() == 0) jacobian = Eigen::MatrixXd::Zero(column.size(), n);
    jacobian.col(j) = column;
  }
  return jacobian;
}

/// How the error of central differences is measured against the analytic derivative.
enum class ErrorNorm { max_entry, frobenius };

/// The error of central differences against an analytic derivative at the
/// step h and at h/2: a right derivative's error falls by 4 as h halves
/// (central differences are second order) until rounding takes over; a
/// wrong one levels off at its mistake.
struct DerivativeCheck {
  double error = 0.0;         ///< at step h
  double halved_error = 0.0;  ///< at step h/2
  /// error / halved_error: 4 in the truncation regime.
  [[nodiscard]] double ratio() const { return error / halved_error; }
};

/// Compares `derivative` (m×n, same flattening as central_differences; a
/// gradient of a scalar as a 1×n row or an n-vector) with the central
/// differences of `value` at steps h and h/2, over the coordinates listed.
template <class X, class Value, class Derivative>
DerivativeCheck check_derivative(const Value& value, const X& x, const Eigen::MatrixBase<Derivative>& derivative,
                                 double h, ErrorNorm norm = ErrorNorm::max_entry,
                                 const std::vector<Index>& coordinates = {}) {
  Eigen::MatrixXd expected = derivative;
  DerivativeCheck check;
  for (int level = 0; level < 2; ++level) {
    const Eigen::MatrixXd fd = central_differences(value, x, h / (1 << level), coordinates);
    if (expected.cols() == 1 && fd.rows() == 1) expected.transposeInPlace();  // a gradient given as a column
    Eigen::MatrixXd difference = fd - expected;
    if (!coordinates.empty()) {  // only the columns that were differenced
      Eigen::MatrixXd selected(difference.rows(), static_cast<Eigen::Index>(coordinates.size()));
      for (std::size_t c = 0; c < coordinates.size(); ++c) selected.col(static_cast<Eigen::Index>(c)) = difference.col(coordinates[c]);
      difference = selected;
    }
    const double error = norm == ErrorNorm::max_entry ? difference.cwiseAbs().maxCoeff() : difference.norm();
    (level == 0 ? check.error : check.halved_error) = error;
  }
  return check;
}

/// Passes if the error at h is at most `tolerance`, and, unless it is
/// already below `round_off` (where halving h no longer helps), falls by
/// more than 3 as h halves: second order, which a wrong derivative is not.
inline ::testing::AssertionResult second_order(const DerivativeCheck& check, double tolerance, double round_off) {
  if (!(check.error <= tolerance))
    return ::testing::AssertionFailure() << "error " << check.error << " above the tolerance " << tolerance;
  if (check.error > round_off && !(check.ratio() > 3.0))
    return ::testing::AssertionFailure() << "not second order: the error went " << check.error << " -> "
                                         << check.halved_error << " as the step halved (ratio " << check.ratio()
                                         << ", 4 expected)";
  return ::testing::AssertionSuccess();
}

}  // namespace goo::test
