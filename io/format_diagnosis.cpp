// The structure of a mesh file, checked before a library parses it. The
// parsers (CGAL, tinyobjloader) say only that they failed, and some accept
// broken files (CGAL reads a 40-byte or truncated ASCII STL as an empty mesh),
// so every read first walks the file to name the first problem, with its line
// or byte offset. It favours clarity over speed: a fraction of parsing time.
#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string_view>

#include "io/detail/polygon_soup_readers.h"
#include "io/detail/text_tokens.h"

namespace goo::io::detail {
namespace {

/// A coordinate token's problem, if any ("'abc' is not a number", ...).
std::optional<std::string> coordinate_problem(std::string_view token) {
  const auto value = to_double(token);
  if (!value) return fmt::format("'{}' is not a number", token);
  if (!std::isfinite(*value)) return fmt::format("the coordinate '{}' is not finite", token);
  return std::nullopt;
}

std::string shown(std::string_view token) {
  return token.empty() ? "the end of the file" : fmt::format("'{}'", token);
}

// ---------------------------------------------------------------- OFF
std::string diagnose_off(std::string_view text) {
  Tokens tokens(text, true);
  const auto header = tokens.next();
  const std::string_view h = header.text;
  if (h.size() < 3 || h.substr(h.size() - 3) != "OFF") {
    return fmt::format("line {}: wrong header: expected 'OFF', found {}", header.line, shown(h));
  }
  if (h.find('4') != std::string_view::npos || h.find('n') != std::string_view::npos) {
    return fmt::format("line {}: '{}' (homogeneous or n-dimensional OFF) is not supported", header.line, h);
  }
  long long counts[3] = {0, 0, 0};
  for (long long& count : counts) {
    const auto token = tokens.next();
    const auto value = to_integer(token.text);
    if (!value || *value < 0) {
      return fmt::format("line {}: expected the vertex, face and edge counts, found {}", token.line, shown(token.text));
    }
    count = *value;
  }
  const long long nv = counts[0], nf = counts[1];
  for (long long v = 0; v < nv; ++v) {
    const auto line = tokens.line();
    if (line.empty()) return fmt::format("the file ends after {} of the {} vertices it declares", v, nv);
    if (line.size() < 3) {
      return fmt::format("line {}: vertex {} has {} coordinates, expected 3", line[0].line, v, line.size());
    }
    for (int k = 0; k < 3; ++k) {
      if (auto problem = coordinate_problem(line[static_cast<std::size_t>(k)].text)) {
        return fmt::format("line {}: vertex {}: {}", line[0].line, v, *problem);
      }
    }
  }
  for (long long f = 0; f < nf; ++f) {
    const auto line = tokens.line();
    if (line.empty()) return fmt::format("the file ends after {} of the {} faces it declares", f, nf);
    const auto n = to_integer(line[0].text);
    if (!n || *n < 3) {
      return fmt::format("line {}: face {} must start with its vertex count (at least 3), found '{}'", line[0].line, f,
                         line[0].text);
    }
    if (static_cast<long long>(line.size()) < 1 + *n) {
      return fmt::format("line {}: face {} declares {} vertices but lists {}", line[0].line, f, *n, line.size() - 1);
    }
    for (long long k = 1; k <= *n; ++k) {
      const auto& token = line[static_cast<std::size_t>(k)];
      const auto id = to_integer(token.text);
      if (!id) return fmt::format("line {}: face {}: '{}' is not a vertex index", token.line, f, token.text);
      if (*id < 0 || *id >= nv) {
        return fmt::format("line {}: face {} references vertex {}, but the file declares {} vertices", token.line, f,
                           *id, nv);
      }
    }
  }
  return {};
}

// ---------------------------------------------------------------- PLY
struct PlyProperty {
  std::string name;
  std::string type;        // scalar type, or the item type of a list
  std::string count_type;  // empty for a scalar
};
struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;
};

int ply_type_size(std::string_view type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

/// Reads an integer PLY scalar (the count of a list) from binary data.
long long read_binary_integer(const unsigned char* p, std::string_view type, bool big_endian) {
  const int size = ply_type_size(type);
  std::uint64_t raw = 0;
  for (int i = 0; i < size; ++i) {
    const int byte = big_endian ? i : size - 1 - i;
    raw = (raw << 8) | p[byte];
  }
  const bool is_signed =
      type == "char" || type == "short" || type == "int" || type == "int8" || type == "int16" || type == "int32";
  if (is_signed && size < 8 && (raw >> (8 * size - 1)) != 0U) {
    return static_cast<long long>(raw) - (1LL << (8 * size));
  }
  return static_cast<long long>(raw);
}

std::string diagnose_ply(std::string_view text) {
  // Header: lines up to "end_header".
  std::size_t pos = 0;
  int line_number = 0;
  std::string format;
  std::vector<PlyElement> elements;
  bool ended = false;
  while (pos < text.size() && !ended) {
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    std::string_view line = text.substr(pos, eol - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = eol + 1;
    ++line_number;
    std::istringstream words{std::string(line)};
    std::string keyword;
    words >> keyword;
    if (line_number == 1) {
      if (keyword != "ply") return fmt::format("line 1: wrong header: expected 'ply', found {}", shown(keyword));
      continue;
    }
    if (keyword == "format") {
      std::string version;
      words >> format >> version;
      if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian") {
        return fmt::format("line {}: unknown PLY format '{}'", line_number, format);
      }
    } else if (keyword == "element") {
      PlyElement element;
      words >> element.name >> element.count;
      if (!words || element.count < 0) return fmt::format("line {}: malformed element line '{}'", line_number, line);
      elements.push_back(element);
    } else if (keyword == "property") {
      if (elements.empty()) return fmt::format("line {}: property before any element", line_number);
      PlyProperty property;
      std::string type;
      words >> type;
      if (type == "list")
        words >> property.count_type >> property.type >> property.name;
      else {
        property.type = type;
        words >> property.name;
      }
      if (!words || ply_type_size(property.type) == 0 ||
          (!property.count_type.empty() && ply_type_size(property.count_type) == 0)) {
        return fmt::format("line {}: malformed property line '{}'", line_number, line);
      }
      elements.back().properties.push_back(property);
    } else if (keyword == "end_header") {
      ended = true;
    } else if (keyword != "comment" && keyword != "obj_info" && !keyword.empty()) {
      return fmt::format("line {}: unknown PLY header keyword '{}'", line_number, keyword);
    }
  }
  if (!ended) return "the PLY header has no 'end_header' line";
  if (format.empty()) return "the PLY header has no 'format' line";
  const PlyElement* vertex = nullptr;
  for (const auto& e : elements)
    if (e.name == "vertex") vertex = &e;
  if (vertex == nullptr) return "the PLY header declares no 'vertex' element";
  for (const char* axis : {"x", "y", "z"}) {
    bool found = false;
    for (const auto& p : vertex->properties) found = found || p.name == axis;
    if (!found) return fmt::format("the PLY 'vertex' element has no '{}' property", axis);
  }
  const long long nv = vertex->count;

  if (format == "ascii") {
    Tokens tokens(text.substr(pos), false);
    for (const auto& element : elements) {
      for (long long i = 0; i < element.count; ++i) {
        for (const auto& property : element.properties) {
          long long items = 1;
          if (!property.count_type.empty()) {
            const auto token = tokens.next();
            const auto count = to_integer(token.text);
            if (!count || *count < 0) {
              return fmt::format("line {}: {} {}: expected a list length, found {}", token.line + line_number,
                                 element.name, i, shown(token.text));
            }
            items = *count;
          }
          for (long long k = 0; k < items; ++k) {
            const auto token = tokens.next();
            const int line = token.line + line_number;
            if (token.end()) {
              return fmt::format("the file ends inside {} {} of the {} its header declares", element.name, i,
                                 element.count);
            }
            if (element.name == "vertex" && property.count_type.empty()) {
              if (auto problem = coordinate_problem(token.text)) {
                return fmt::format("line {}: vertex {}: {}", line, i, *problem);
              }
            } else if (!to_double(token.text)) {
              return fmt::format("line {}: {} {}: '{}' is not a number", line, element.name, i, token.text);
            }
            if (element.name == "face" && !property.count_type.empty()) {
              const auto id = to_integer(token.text);
              if (id && (*id < 0 || *id >= nv)) {
                return fmt::format("line {}: face {} references vertex {}, but the file declares {} vertices", line, i,
                                   *id, nv);
              }
            }
          }
        }
      }
    }
    return {};
  }

  // Binary: walk the body to find where it ends early.
  const bool big_endian = format == "binary_big_endian";
  const auto* data = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t size = text.size();
  std::size_t offset = pos;
  for (const auto& element : elements) {
    for (long long i = 0; i < element.count; ++i) {
      for (const auto& property : element.properties) {
        long long items = 1;
        if (!property.count_type.empty()) {
          const auto bytes = static_cast<std::size_t>(ply_type_size(property.count_type));
          if (offset + bytes > size) {
            return fmt::format("the file is truncated: it ends inside {} {} of the {} its header declares (at byte {})",
                               element.name, i, element.count, size);
          }
          items = read_binary_integer(data + offset, property.count_type, big_endian);
          offset += bytes;
          if (items < 0) return fmt::format("{} {} has a negative list length {}", element.name, i, items);
        }
        const std::size_t item_size = static_cast<std::size_t>(ply_type_size(property.type));
        for (long long k = 0; k < items; ++k) {
          if (offset + item_size > size) {
            return fmt::format("the file is truncated: it ends inside {} {} of the {} its header declares (at byte {})",
                               element.name, i, element.count, size);
          }
          if (element.name == "face" && !property.count_type.empty()) {
            const long long id = read_binary_integer(data + offset, property.type, big_endian);
            if (id < 0 || id >= nv) {
              return fmt::format("face {} references vertex {}, but the file declares {} vertices", i, id, nv);
            }
          }
          offset += item_size;
        }
      }
    }
  }
  return {};
}

// ---------------------------------------------------------------- STL
std::string diagnose_stl(std::string_view text) {
  std::size_t first = 0;
  while (first < text.size() && std::isspace(static_cast<unsigned char>(text[first])) != 0) ++first;
  const bool says_solid = text.substr(first, 5) == "solid";
  std::uint32_t declared = 0;
  if (text.size() >= 84) std::memcpy(&declared, text.data() + 80, sizeof declared);  // little-endian host
  const std::size_t expected = 84 + 50 * static_cast<std::size_t>(declared);
  const bool binary = !says_solid || (text.size() >= 84 && text.size() == expected);
  if (binary) {
    if (text.size() < 84) {
      return fmt::format("too short for a binary STL: {} bytes, but its header alone is 84 bytes", text.size());
    }
    if (text.size() < expected) {
      return fmt::format(
          "the binary STL is truncated: its header declares {} triangles ({} bytes) but the file has {} bytes "
          "({} complete triangles)",
          declared, expected, text.size(), (text.size() - 84) / 50);
    }
    if (text.size() > expected) {
      return fmt::format("the binary STL has {} bytes after the {} triangles its header declares",
                         text.size() - expected, declared);
    }
    return {};
  }
  Tokens tokens(text, false);
  tokens.line();  // "solid [name]"
  auto expect = [&](std::string_view word) -> std::optional<std::string> {
    const auto token = tokens.next();
    if (token.text == word) return std::nullopt;
    return fmt::format("line {}: expected '{}', found {}", token.line, word, shown(token.text));
  };
  for (long long facet = 0;; ++facet) {
    const auto start = tokens.next();
    if (start.text == "endsolid") return {};
    if (start.end()) return fmt::format("the file ends after facet {} without 'endsolid'", facet);
    if (start.text != "facet")
      return fmt::format("line {}: expected 'facet' or 'endsolid', found '{}'", start.line, start.text);
    if (auto problem = expect("normal")) return *problem;
    for (int k = 0; k < 3; ++k) {
      const auto token = tokens.next();
      if (!to_double(token.text))
        return fmt::format("line {}: facet {}: normal component {} is not a number", token.line, facet,
                           shown(token.text));
    }
    if (auto problem = expect("outer")) return *problem;
    if (auto problem = expect("loop")) return *problem;
    for (int v = 0; v < 3; ++v) {
      if (auto problem = expect("vertex")) return *problem;
      for (int k = 0; k < 3; ++k) {
        const auto token = tokens.next();
        if (auto problem = coordinate_problem(token.text)) {
          return fmt::format("line {}: facet {}: {}", token.line, facet, *problem);
        }
      }
    }
    if (auto problem = expect("endloop")) return *problem;
    if (auto problem = expect("endfacet")) return *problem;
  }
}

}  // namespace

std::string find_format_problem(const std::filesystem::path& path, MeshFormat format) {
  const std::string text = read_all(path);
  switch (format) {
    case MeshFormat::off:
      return diagnose_off(text);
    case MeshFormat::ply:
      return diagnose_ply(text);
    case MeshFormat::stl:
      return diagnose_stl(text);
    case MeshFormat::obj:
      return {};  // obj_reader.cpp checks OBJ as it reads
  }
  return {};
}

}  // namespace goo::io::detail
