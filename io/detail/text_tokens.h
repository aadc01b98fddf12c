#pragma once
// Internal to goo::io: reading text formats token by token, with line
// numbers for error messages.
#include <charconv>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace goo::io::detail {

/// Whitespace-separated tokens of a text, with their 1-based line numbers.
class Tokens {
 public:
  Tokens(std::string_view text, bool hash_comments) : text_(text), comments_(hash_comments) {}

  struct Token {
    std::string_view text;
    int line = 0;
    [[nodiscard]] bool end() const { return text.empty(); }
  };

  Token next() {
    skip_space();
    const std::size_t begin = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return {text_.substr(begin, pos_ - begin), line_};
  }
  /// The rest of the current line as tokens (stops at the newline).
  std::vector<Token> line() {
    skip_space();
    std::vector<Token> out;
    const int current = line_;
    while (true) {
      skip_blanks();
      if (pos_ >= text_.size() || text_[pos_] == '\n' || (comments_ && text_[pos_] == '#')) break;
      const std::size_t begin = pos_;
      while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
      out.push_back({text_.substr(begin, pos_ - begin), current});
    }
    return out;
  }
  [[nodiscard]] int line_number() const { return line_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
  void skip_blanks() {
    while (pos_ < text_.size() && text_[pos_] != '\n' && is_space(text_[pos_])) ++pos_;
  }
  void skip_space() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        ++line_;
        ++pos_;
      } else if (is_space(c)) {
        ++pos_;
      } else if (comments_ && c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else {
        break;
      }
    }
  }
  std::string_view text_;
  bool comments_;
  std::size_t pos_ = 0;
  int line_ = 1;
};

/// The whole file as bytes (empty if it cannot be read).
inline std::string read_all(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

inline std::optional<double> to_double(std::string_view s) {
  double value = 0.0;
  const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (error != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

inline std::optional<long long> to_integer(std::string_view s) {
  long long value = 0;
  const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (error != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

}  // namespace goo::io::detail
