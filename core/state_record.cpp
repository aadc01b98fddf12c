#include "core/state_record.h"

#include <fmt/format.h>

#include <algorithm>
#include <numeric>

#include "core/error.h"

namespace goo {

std::size_t StateArray::size() const {
  return std::accumulate(shape.begin(), shape.end(), std::size_t{1}, std::multiplies<>());
}

void check_state_array(const std::string& name, const StateArray& array) {
  if (array.size() != (array.integer ? array.integers.size() : array.reals.size()))
    throw Error(fmt::format("state '{}': shape does not match its {} values", name,
                            array.integer ? array.integers.size() : array.reals.size()));
}

void StateRecord::put_array(const std::string& name, StateArray array) {
  check_state_array(name, array);
  arrays_[name] = std::move(array);
}

void StateSink::put(const std::string& name, double value) { put_array(name, {{}, false, {value}, {}}); }

void StateSink::put(const std::string& name, std::int64_t value) { put_array(name, {{}, true, {}, {value}}); }

void StateSink::put_vector(const std::string& name, const Eigen::VectorXd& vector) {
  put_rows(name, {static_cast<std::size_t>(vector.size())}, false,
           [&](std::size_t first, std::size_t count, double* out, std::int64_t*) {
             std::copy_n(vector.data() + first, count, out);
           });
}

namespace {
template <class M>
StateSink::RowFiller integer_rows(const M& m) {
  return [&m](std::size_t first, std::size_t count, double*, std::int64_t* out) {
    for (auto r = static_cast<Eigen::Index>(first); r < static_cast<Eigen::Index>(first + count); ++r)
      for (Eigen::Index c = 0; c < m.cols(); ++c) *out++ = m(r, c);
  };
}
}  // namespace

void StateSink::put(const std::string& name, const Tets& tets) {
  put_rows(name, {static_cast<std::size_t>(tets.rows()), 4}, true, integer_rows(tets));
}

void StateSink::put(const std::string& name, const Triangles& triangles) {
  put_rows(name, {static_cast<std::size_t>(triangles.rows()), 3}, true, integer_rows(triangles));
}

void StateSink::put(const std::string& name, const std::vector<Index>& values) {
  put_rows(name, {values.size()}, true, [&](std::size_t first, std::size_t count, double*, std::int64_t* out) {
    std::copy_n(values.begin() + static_cast<std::ptrdiff_t>(first), count, out);
  });
}

void StateSink::put(const std::string& name, const std::vector<Eigen::Matrix3d>& matrices) {
  put_rows(name, {matrices.size(), 3, 3}, false, [&](std::size_t first, std::size_t count, double* out, std::int64_t*) {
    for (std::size_t k = first; k < first + count; ++k)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) *out++ = matrices[k](r, c);
  });
}

void StateSink::put_rows(const std::string& name, std::vector<std::size_t> shape, bool integer, const RowFiller& fill) {
  StateArray a;
  a.shape = std::move(shape);
  a.integer = integer;
  const std::size_t rows = a.shape.empty() ? 1 : a.shape[0];
  if (integer) {
    a.integers.resize(a.size());
    fill(0, rows, nullptr, a.integers.data());
  } else {
    a.reals.resize(a.size());
    fill(0, rows, a.reals.data(), nullptr);
  }
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
