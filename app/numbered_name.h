#pragma once
// File names of a run folder: PREFIX + digits + SUFFIX (frame_00012.ply).
#include <optional>
#include <string_view>

namespace goo::app {

/// The number in `name` when it is `prefix`, at least `digits` decimal
/// digits, then `suffix`; nothing otherwise (or beyond nine digits).
inline std::optional<long> numbered_name(std::string_view name, std::string_view prefix, std::string_view suffix,
                                         std::size_t digits = 5) {
  if (name.size() < prefix.size() + suffix.size() + digits || name.substr(0, prefix.size()) != prefix ||
      name.substr(name.size() - suffix.size()) != suffix)
    return std::nullopt;
  const std::string_view number = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
  if (number.size() > 9) return std::nullopt;
  long value = 0;
  for (const char c : number) {
    if (c < '0' || c > '9') return std::nullopt;
    value = 10 * value + (c - '0');
  }
  return value;
}

}  // namespace goo::app
