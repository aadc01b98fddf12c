#pragma once
// A strict cursor over a parsed JSON document (goo's scene files,
// docs/scene-format.md): each value knows its JSON path, and every error
// names the file and that path; an object remembers which keys were read,
// so that finish() refuses the others (a misspelt key must not be silently
// ignored), with a "did you mean" for the nearest known one.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"

namespace goo::io::detail {

using json = nlohmann::json;

inline const char* type_name(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return "null";
    case nlohmann::json::value_t::boolean:
      return "a boolean";
    case nlohmann::json::value_t::string:
      return "a string";
    case nlohmann::json::value_t::array:
      return "an array";
    case nlohmann::json::value_t::object:
      return "an object";
    case nlohmann::json::value_t::number_float:
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
      return "a number";
    default:
      return "something else";
  }
}

/// Levenshtein distance, for "did you mean".
inline std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

/// One JSON value at a path. Objects remember which keys were read, so that
/// finish() refuses the rest (a misspelt key must not be silently ignored).
class Node {
 public:
  Node(const json& value, std::string path, const std::string& source)
      : value_(value), path_(std::move(path)), source_(source) {}

  [[noreturn]] void fail(std::string_view message) const {
    throw Error(fmt::format("{}: {} {}", source_, path_.empty() ? "/" : path_, message));
  }
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const json& value() const { return value_; }

  void expect_object() const {
    if (!value_.is_object()) fail(fmt::format("must be an object, got {}", type_name(value_)));
  }
  [[nodiscard]] bool has(const std::string& key) const { return value_.contains(key); }
  std::optional<Node> get(const std::string& key) {
    expect_object();
    used_.insert(key);
    const auto it = value_.find(key);
    if (it == value_.end()) return std::nullopt;
    return Node(*it, path_ + "/" + key, source_);
  }
  Node at(const std::string& key) {
    auto node = get(key);
    if (!node) {
      // A key that is missing is most often misspelt: name the misspelling.
      for (const auto& [present, value] : value_.items())
        if (!used_.contains(present) && edit_distance(present, key) <= 2)
          Node(value, path_ + "/" + present, source_)
              .fail(fmt::format("is not a known key (did you mean '{}'?)", key));
      fail(fmt::format("needs the key '{}'", key));
    }
    return *node;
  }
  /// Refuses keys that were never asked for.
  void finish() const {
    std::vector<std::string> unknown;
    for (const auto& [key, _] : value_.items())
      if (!used_.contains(key)) unknown.push_back(key);
    if (unknown.empty()) return;
    Node(value_[unknown.front()], path_ + "/" + unknown.front(), source_)
        .fail(fmt::format("is not a known key here (known: {})", fmt::join(used_, ", ")));
  }

  [[nodiscard]] double number() const {
    if (!value_.is_number()) fail(fmt::format("must be a number, got {}", type_name(value_)));
    const double v = value_.get<double>();
    if (!std::isfinite(v)) fail("must be finite");
    return v;
  }
  [[nodiscard]] double positive() const {
    const double v = number();
    if (!(v > 0.0)) fail(fmt::format("must be positive, got {}", v));
    return v;
  }
  [[nodiscard]] double non_negative() const {
    const double v = number();
    if (!(v >= 0.0)) fail(fmt::format("must be non-negative, got {}", v));
    return v;
  }
  [[nodiscard]] int integer(int low, int high) const {
    if (!value_.is_number_integer()) fail(fmt::format("must be an integer, got {}", type_name(value_)));
    if (value_.is_number_unsigned() && value_.get<unsigned long long>() > static_cast<unsigned long long>(high))
      fail(fmt::format("must be an integer in [{}, {}], got {}", low, high, value_.get<unsigned long long>()));
    const auto v = value_.get<long long>();
    if (v < low || v > high) fail(fmt::format("must be an integer in [{}, {}], got {}", low, high, v));
    return static_cast<int>(v);
  }
  [[nodiscard]] bool boolean() const {
    if (!value_.is_boolean()) fail(fmt::format("must be true or false, got {}", type_name(value_)));
    return value_.get<bool>();
  }
  [[nodiscard]] std::string string() const {
    if (!value_.is_string()) fail(fmt::format("must be a string, got {}", type_name(value_)));
    return value_.get<std::string>();
  }
  [[nodiscard]] std::string choice(std::initializer_list<std::string_view> options) const {
    const std::string s = string();
    for (const auto o : options)
      if (s == o) return s;
    fail(fmt::format("must be one of {}, got '{}'", fmt::join(options, ", "), s));
  }
  [[nodiscard]] Eigen::Vector3d vec3() const {
    if (!value_.is_array() || value_.size() != 3) fail(fmt::format("must be an array of 3 numbers"));
    Eigen::Vector3d v;
    for (std::size_t k = 0; k < 3; ++k) v[static_cast<Eigen::Index>(k)] = element(k).number();
    return v;
  }
  [[nodiscard]] std::size_t size() const {
    if (!value_.is_array()) fail(fmt::format("must be an array, got {}", type_name(value_)));
    return value_.size();
  }
  [[nodiscard]] Node element(std::size_t i) const {
    return Node(value_[i], fmt::format("{}/{}", path_, i), source_);
  }

 private:
  const json& value_;
  std::string path_;
  const std::string& source_;
  std::set<std::string> used_;
};

/// Reads an optional key into `out` with `read`.
template <class T, class Read>
void optional(Node& parent, const std::string& key, T& out, Read read) {
  if (auto n = parent.get(key)) out = read(*n);
}

}  // namespace goo::io::detail
