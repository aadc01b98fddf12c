#include "core/state_record.h"

#include <fmt/format.h>

#include <numeric>

#include "core/error.h"

namespace goo {

std::size_t StateArray::size() const {
  return std::accumulate(shape.begin(), shape.end(), std::size_t{1}, std::multiplies<>());
}

void StateRecord::put_array(const std::string& name, StateArray array) {
  if (array.size() != (array.integer ? array.integers.size() : array.reals.size()))
    throw Error(fmt::format("state '{}': shape does not match its {} values", name,
                            array.integer ? array.integers.size() : array.reals.size()));
  arrays_[name] = std::move(array);
}

void StateRecord::put(const std::string& name, double value) { put_array(name, {{}, false, {value}, {}}); }

void StateRecord::put(const std::string& name, std::int64_t value) { put_array(name, {{}, true, {}, {value}}); }

void StateRecord::put_matrix(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& matrix) {
  StateArray a;
  a.shape = {static_cast<std::size_t>(matrix.rows()), static_cast<std::size_t>(matrix.cols())};
  a.reals.reserve(a.size());
  for (Eigen::Index r = 0; r < matrix.rows(); ++r)
    for (Eigen::Index c = 0; c < matrix.cols(); ++c) a.reals.push_back(matrix(r, c));
  put_array(name, std::move(a));
}

void StateRecord::put_vector(const std::string& name, const Eigen::VectorXd& vector) {
  put_array(name, {{static_cast<std::size_t>(vector.size())}, false, {vector.data(), vector.data() + vector.size()}, {}});
}

namespace {
template <class M>
StateArray integer_matrix(const M& m) {
  StateArray a;
  a.integer = true;
  a.shape = {static_cast<std::size_t>(m.rows()), static_cast<std::size_t>(m.cols())};
  a.integers.reserve(a.size());
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) a.integers.push_back(m(r, c));
  return a;
}
}  // namespace

void StateRecord::put(const std::string& name, const Tets& tets) { put_array(name, integer_matrix(tets)); }

void StateRecord::put(const std::string& name, const Triangles& triangles) {
  put_array(name, integer_matrix(triangles));
}

void StateRecord::put(const std::string& name, const std::vector<Index>& values) {
  put_array(name, {{values.size()}, true, {}, {values.begin(), values.end()}});
}

void StateRecord::put(const std::string& name, const std::vector<Eigen::Matrix3d>& matrices) {
  StateArray a;
  a.shape = {matrices.size(), 3, 3};
  a.reals.reserve(a.size());
  for (const auto& m : matrices)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) a.reals.push_back(m(r, c));
  put_array(name, std::move(a));
}

void StateRecord::put_string(const std::string& name, std::string value) { strings_[name] = std::move(value); }

bool StateRecord::has(const std::string& name) const { return arrays_.contains(name) || strings_.contains(name); }

const StateArray& StateRecord::array(const std::string& name, bool integer) const {
  const auto it = arrays_.find(name);
  if (it == arrays_.end()) throw Error(fmt::format("state field '{}' is missing", name));
  if (it->second.integer != integer)
    throw Error(fmt::format("state field '{}' should hold {}", name, integer ? "integers" : "reals"));
  return it->second;
}

double StateRecord::real(const std::string& name) const {
  const StateArray& a = array(name, false);
  if (!a.shape.empty()) throw Error(fmt::format("state field '{}' should be a scalar", name));
  return a.reals[0];
}

std::int64_t StateRecord::integer(const std::string& name) const {
  const StateArray& a = array(name, true);
  if (!a.shape.empty()) throw Error(fmt::format("state field '{}' should be a scalar", name));
  return a.integers[0];
}

Eigen::MatrixXd StateRecord::matrix(const std::string& name, int cols) const {
  const StateArray& a = array(name, false);
  if (a.shape.size() != 2 || (cols >= 0 && a.shape[1] != static_cast<std::size_t>(cols)))
    throw Error(fmt::format("state field '{}' should be a matrix of {} columns", name, cols));
  Eigen::MatrixXd m(static_cast<Eigen::Index>(a.shape[0]), static_cast<Eigen::Index>(a.shape[1]));
  std::size_t k = 0;
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) m(r, c) = a.reals[k++];
  return m;
}

Points StateRecord::points(const std::string& name) const { return matrix(name, 3); }

Eigen::VectorXd StateRecord::vector(const std::string& name) const {
  const StateArray& a = array(name, false);
  if (a.shape.size() != 1) throw Error(fmt::format("state field '{}' should be a vector", name));
  return Eigen::Map<const Eigen::VectorXd>(a.reals.data(), static_cast<Eigen::Index>(a.reals.size()));
}

namespace {
template <class M>
M read_integer_matrix(const StateArray& a, const std::string& name) {
  if (a.shape.size() != 2 || a.shape[1] != static_cast<std::size_t>(M::ColsAtCompileTime))
    throw Error(fmt::format("state field '{}' should be a matrix of {} columns", name, M::ColsAtCompileTime));
  M m(static_cast<Eigen::Index>(a.shape[0]), M::ColsAtCompileTime);
  std::size_t k = 0;
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) m(r, c) = static_cast<Index>(a.integers[k++]);
  return m;
}
}  // namespace

Tets StateRecord::tets(const std::string& name) const { return read_integer_matrix<Tets>(array(name, true), name); }

Triangles StateRecord::triangles(const std::string& name) const {
  return read_integer_matrix<Triangles>(array(name, true), name);
}

std::vector<Index> StateRecord::indices(const std::string& name) const {
  const StateArray& a = array(name, true);
  if (a.shape.size() != 1) throw Error(fmt::format("state field '{}' should be a vector", name));
  return {a.integers.begin(), a.integers.end()};
}

std::vector<Eigen::Matrix3d> StateRecord::matrices3(const std::string& name) const {
  const StateArray& a = array(name, false);
  if (a.shape.size() != 3 || a.shape[1] != 3 || a.shape[2] != 3)
    throw Error(fmt::format("state field '{}' should be n×3×3", name));
  std::vector<Eigen::Matrix3d> out(a.shape[0]);
  std::size_t k = 0;
  for (auto& m : out)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = a.reals[k++];
  return out;
}

const std::string& StateRecord::string(const std::string& name) const {
  const auto it = strings_.find(name);
  if (it == strings_.end()) throw Error(fmt::format("state field '{}' is missing", name));
  return it->second;
}

}  // namespace goo
