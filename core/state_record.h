#pragma once
// A simulation's complete state as named arrays: what a checkpoint stores.
// solvers fill it (Simulation::save) and read it back (Simulation::load); io
// writes and reads it (HDF5) without knowing what the arrays mean.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/types.h"

namespace goo {

/// One array: row-major values of the given shape (scalars have shape {}).
/// Exactly one of `reals` and `integers` holds the values.
struct StateArray {
  std::vector<std::size_t> shape;
  bool integer = false;
  std::vector<double> reals;
  std::vector<std::int64_t> integers;

  [[nodiscard]] std::size_t size() const;  ///< product of the shape (1 for a scalar)
  bool operator==(const StateArray&) const = default;
};

/// Where a state goes, array by array: a StateRecord keeps them; a
/// checkpoint writer (io) writes each as it comes, a block of rows at a
/// time, so a checkpoint never holds a second copy of the state. The typed
/// puts of arrays hand their rows to put_rows; scalars go to put_array.
class StateSink {
 public:
  virtual ~StateSink() = default;
  virtual void put_array(const std::string& name, StateArray array) = 0;
  virtual void put_string(const std::string& name, std::string value) = 0;

  void put(const std::string& name, double value);
  void put(const std::string& name, std::int64_t value);
  /// Any matrix or expression of reals, stored row-major, without a copy of its own.
  template <class Derived>
  void put_matrix(const std::string& name, const Eigen::DenseBase<Derived>& matrix) {
    put_rows(name, {static_cast<std::size_t>(matrix.rows()), static_cast<std::size_t>(matrix.cols())}, false,
             [&](std::size_t first, std::size_t count, double* out, std::int64_t*) {
               for (auto r = static_cast<Eigen::Index>(first); r < static_cast<Eigen::Index>(first + count); ++r)
                 for (Eigen::Index c = 0; c < matrix.cols(); ++c) *out++ = matrix(r, c);
             });
  }
  void put_vector(const std::string& name, const Eigen::VectorXd& vector);  ///< shape {n}
  void put(const std::string& name, const Tets& tets);
  void put(const std::string& name, const Triangles& triangles);
  void put(const std::string& name, const std::vector<Index>& values);
  void put(const std::string& name, const std::vector<Eigen::Matrix3d>& matrices);  ///< shape {n, 3, 3}

  /// Writes rows [first, first + count) of an array, row-major, to `reals`
  /// or to `integers` (the other is null).
  using RowFiller = std::function<void(std::size_t first, std::size_t count, double* reals, std::int64_t* integers)>;

 protected:
  /// An array of the given shape (shape[0] rows) handed over row by row: by
  /// default gathered into one StateArray for put_array; a sink that writes
  /// as it goes takes a block of rows at a time.
  virtual void put_rows(const std::string& name, std::vector<std::size_t> shape, bool integer, const RowFiller& fill);

  StateSink() = default;
  StateSink(const StateSink&) = default;
  StateSink& operator=(const StateSink&) = default;
  StateSink(StateSink&&) = default;
  StateSink& operator=(StateSink&&) = default;
};

/// Throws goo::Error naming the field if the array's values do not fill its shape.
void check_state_array(const std::string& name, const StateArray& array);

/// Arrays and strings by path ("bodies/0/positions"): '/' separates groups.
/// The getters throw goo::Error naming the field when it is missing or has
/// the wrong type or shape, so a damaged checkpoint is refused clearly.
class StateRecord final : public StateSink {
 public:
  void put_array(const std::string& name, StateArray array) override;
  void put_string(const std::string& name, std::string value) override;

  [[nodiscard]] double real(const std::string& name) const;
  [[nodiscard]] std::int64_t integer(const std::string& name) const;
  /// A matrix of `cols` columns (any number of rows; cols < 0: the stored shape's).
  [[nodiscard]] Eigen::MatrixXd matrix(const std::string& name, int cols) const;
  [[nodiscard]] Points points(const std::string& name) const;
  [[nodiscard]] Eigen::VectorXd vector(const std::string& name) const;
  [[nodiscard]] Tets tets(const std::string& name) const;
  [[nodiscard]] Triangles triangles(const std::string& name) const;
  [[nodiscard]] std::vector<Index> indices(const std::string& name) const;
  [[nodiscard]] std::vector<Eigen::Matrix3d> matrices3(const std::string& name) const;
  [[nodiscard]] const std::string& string(const std::string& name) const;
  [[nodiscard]] bool has(const std::string& name) const;

  [[nodiscard]] const std::map<std::string, StateArray>& arrays() const { return arrays_; }
  [[nodiscard]] const std::map<std::string, std::string>& strings() const { return strings_; }
  bool operator==(const StateRecord& other) const { return arrays_ == other.arrays_ && strings_ == other.strings_; }

 private:
  [[nodiscard]] const StateArray& array(const std::string& name, bool integer) const;
  std::map<std::string, StateArray> arrays_;
  std::map<std::string, std::string> strings_;
};

}  // namespace goo
