#pragma once
// A simulation's complete state as named arrays: what a checkpoint stores.
// solvers fill it (Simulation::save) and read it back (Simulation::load); io
// writes and reads it (HDF5) without knowing what the arrays mean.
#include <cstdint>
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

/// Arrays and strings by path ("bodies/0/positions"): '/' separates groups.
/// The getters throw goo::Error naming the field when it is missing or has
/// the wrong type or shape, so a damaged checkpoint is refused clearly.
class StateRecord {
 public:
  void put(const std::string& name, double value);
  void put(const std::string& name, std::int64_t value);
  void put_matrix(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& matrix);  ///< stored row-major
  void put_vector(const std::string& name, const Eigen::VectorXd& vector);  ///< shape {n}
  void put(const std::string& name, const Tets& tets);
  void put(const std::string& name, const Triangles& triangles);
  void put(const std::string& name, const std::vector<Index>& values);
  void put(const std::string& name, const std::vector<Eigen::Matrix3d>& matrices);  ///< shape {n, 3, 3}
  void put_array(const std::string& name, StateArray array);
  void put_string(const std::string& name, std::string value);

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
  bool operator==(const StateRecord&) const = default;

 private:
  [[nodiscard]] const StateArray& array(const std::string& name, bool integer) const;
  std::map<std::string, StateArray> arrays_;
  std::map<std::string, std::string> strings_;
};

}  // namespace goo
