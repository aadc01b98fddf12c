#pragma once
// Mutations of input files for the fuzz harness: bytes (flips, inserts,
// deletions, truncation), numeric tokens (replaced by the numbers that break
// readers: overflow, NaN, 2³¹, 2⁶³, negative counts), lines, and JSON values
// (types swapped, keys deleted, repeated or renamed). Deterministic for a
// seed: the same case number gives the same mutant on every machine.
#include <cstdint>
#include <random>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace goo::fuzz {

using Random = std::mt19937_64;

/// A uniform integer in [0, n) that does not depend on the standard
/// library's distributions (which differ between implementations).
inline std::size_t below(Random& random, std::size_t n) {
  return n == 0 ? 0 : static_cast<std::size_t>(random() % n);
}

/// Numbers that readers get wrong: beyond double, integer and index ranges,
/// not finite, negative zero, subnormal, the values of counts and ids.
inline std::string_view interesting_number(Random& random) {
  static constexpr std::string_view kNumbers[] = {
      "1e309",   "-1e309",     "nan",        "inf",        "-inf",      "-0",          "0",
      "1e-320",  "-1",         "2147483647", "2147483648", "4294967296", "-2147483649", "9223372036854775807",
      "9223372036854775808", "18446744073709551616", "1e15", "1e300", "3.5", "007", "0x10", "1e", "-", ".",
      "100000000", "65536", "255", "256"};
  return kNumbers[below(random, std::size(kNumbers))];
}

/// Replaces one number (a run of digits with its sign, point and exponent)
/// by an interesting one. False if the text has no number.
inline bool replace_number(std::string& text, Random& random) {
  std::vector<std::pair<std::size_t, std::size_t>> spans;
  for (std::size_t i = 0; i < text.size();) {
    const auto digit = [&](std::size_t k) { return k < text.size() && text[k] >= '0' && text[k] <= '9'; };
    if (!digit(i)) {
      ++i;
      continue;
    }
    std::size_t begin = i, end = i;
    if (begin > 0 && (text[begin - 1] == '-' || text[begin - 1] == '+')) --begin;
    while (end < text.size() && (digit(end) || text[end] == '.' || text[end] == 'e' || text[end] == 'E' ||
                                 ((text[end] == '-' || text[end] == '+') && (text[end - 1] == 'e' || text[end - 1] == 'E'))))
      ++end;
    spans.emplace_back(begin, end);
    i = end;
  }
  if (spans.empty()) return false;
  const auto [begin, end] = spans[below(random, spans.size())];
  text.replace(begin, end - begin, interesting_number(random));
  return true;
}

/// One random byte-, number- or line-level change to `bytes` (never empty
/// afterwards unless truncated to nothing on purpose).
inline void mutate_bytes(std::string& bytes, Random& random) {
  if (bytes.empty()) {
    bytes = "0";
    return;
  }
  const std::size_t at = below(random, bytes.size());
  switch (below(random, 9)) {
    case 0:  // flip one bit
      bytes[at] = static_cast<char>(bytes[at] ^ (1 << below(random, 8)));
      break;
    case 1: {  // one byte set to something a parser cares about
      static constexpr char kBytes[] = {'\0', '\xff', '\n', ' ', '-', '9', '.', 'e', '\r', '#', '"', '{', '['};
      bytes[at] = kBytes[below(random, sizeof kBytes)];
      break;
    }
    case 2:  // delete a short range
      bytes.erase(at, 1 + below(random, 16));
      break;
    case 3: {  // repeat a short range in place
      const std::string piece = bytes.substr(at, 1 + below(random, 32));
      bytes.insert(at, piece);
      break;
    }
    case 4:  // truncate
      bytes.resize(at);
      break;
    case 5:
    case 6:
      if (!replace_number(bytes, random)) bytes[at] = static_cast<char>(random());
      break;
    case 7: {  // one line repeated many times
      const std::size_t begin = bytes.rfind('\n', at) == std::string::npos ? 0 : bytes.rfind('\n', at) + 1;
      const std::size_t end = bytes.find('\n', at);
      const std::string line = bytes.substr(begin, end == std::string::npos ? std::string::npos : end - begin + 1);
      std::string many;
      for (std::size_t k = 0, n = 2 + below(random, 200); k < n; ++k) many += line;
      bytes.insert(begin, many);
      break;
    }
    default: {  // random bytes inserted
      std::string noise(1 + below(random, 8), '\0');
      for (char& c : noise) c = static_cast<char>(random());
      bytes.insert(at, noise);
      break;
    }
  }
}

/// Every value of a JSON document, by pointer, in document order.
inline void collect_pointers(const nlohmann::json& value, const nlohmann::json::json_pointer& at,
                             std::vector<nlohmann::json::json_pointer>& out) {
  out.push_back(at);
  if (value.is_object()) {
    for (const auto& [key, child] : value.items()) collect_pointers(child, at / key, out);
  } else if (value.is_array()) {
    for (std::size_t i = 0; i < value.size(); ++i) collect_pointers(value[i], at / i, out);
  }
}

/// One structural change to a JSON document: a value replaced by another
/// type or an extreme number, a key deleted or renamed, an array emptied or
/// grown. The result is valid JSON (the byte mutations cover invalid JSON).
inline void mutate_json(nlohmann::json& document, Random& random) {
  std::vector<nlohmann::json::json_pointer> pointers;
  collect_pointers(document, nlohmann::json::json_pointer(), pointers);
  const auto& at = pointers[below(random, pointers.size())];
  nlohmann::json& value = document[at];
  switch (below(random, 7)) {
    case 0: {
      static const nlohmann::json kValues[] = {nullptr, true, "text", "", nlohmann::json::array(),
                                               nlohmann::json::object(), 0, -1, 1e308, -1e308, 5e-324, 1e15,
                                               9223372036854775807LL, 18446744073709551615ULL, 0.5, 1e6,
                                               nlohmann::json::array({1, 2, 3}), nlohmann::json::array({0, 0, 0})};
      value = kValues[below(random, std::size(kValues))];
      break;
    }
    case 1:  // a number scaled far away
      if (value.is_number()) value = value.get<double>() * (below(random, 2) ? 1e6 : 1e-6);
      else value = nullptr;
      break;
    case 2:  // a key deleted
      if (!at.empty()) document[at.parent_pointer()].is_object() ? static_cast<void>(document[at.parent_pointer()].erase(at.back()))
                                                                 : static_cast<void>(value = nullptr);
      break;
    case 3:  // a key renamed (an unknown key)
      if (!at.empty() && document[at.parent_pointer()].is_object()) {
        nlohmann::json moved = value;
        nlohmann::json& parent = document[at.parent_pointer()];
        parent.erase(at.back());
        parent[at.back() + "_"] = moved;
      }
      break;
    case 4:  // an array emptied, or grown with copies of its first element
      if (value.is_array() && !value.empty()) {
        if (below(random, 2)) value = nlohmann::json::array();
        else for (std::size_t k = 0, n = 1 + below(random, 50); k < n; ++k) value.push_back(value[0]);
      } else {
        value = nlohmann::json::array({value});
      }
      break;
    case 5:  // a vector's component negated or zeroed
      if (value.is_number()) value = below(random, 2) ? -value.get<double>() : 0.0;
      else value = 0;
      break;
    default:  // a value wrapped in an object
      value = nlohmann::json::object({{"value", value}});
      break;
  }
}

}  // namespace goo::fuzz
