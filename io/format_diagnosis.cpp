// OFF, PLY and STL files read into a polygon soup by one walk that checks
// their structure as it goes and names the first problem with its line or
// byte offset (general parsers say only that they failed, and some accept
// broken files: a 40-byte or truncated ASCII STL read as an empty mesh).
// Numbers are read as their declared type, correctly rounded (from_chars);
// an STL's corners are merged where their coordinates are equal, numbered
// in order of first appearance. A test holds the soups to CGAL's readers.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
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
std::string diagnose_off(std::string_view text, PolygonSoup& soup) {
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
  soup.points.reserve(static_cast<std::size_t>(std::min(nv, 1LL << 24)));
  for (long long v = 0; v < nv; ++v) {
    const auto line = tokens.line();
    if (line.empty()) return fmt::format("the file ends after {} of the {} vertices it declares", v, nv);
    if (line.size() < 3) {
      return fmt::format("line {}: vertex {} has {} coordinates, expected 3", line[0].line, v, line.size());
    }
    std::array<double, 3> point{};
    for (int k = 0; k < 3; ++k) {
      if (auto problem = coordinate_problem(line[static_cast<std::size_t>(k)].text)) {
        return fmt::format("line {}: vertex {}: {}", line[0].line, v, *problem);
      }
      point[static_cast<std::size_t>(k)] = *to_double(line[static_cast<std::size_t>(k)].text);
    }
    soup.points.push_back(point);
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
    std::vector<std::size_t>& polygon = soup.polygons.emplace_back();
    for (long long k = 1; k <= *n; ++k) {
      const auto& token = line[static_cast<std::size_t>(k)];
      const auto id = to_integer(token.text);
      if (!id) return fmt::format("line {}: face {}: '{}' is not a vertex index", token.line, f, token.text);
      if (*id < 0 || *id >= nv) {
        return fmt::format("line {}: face {} references vertex {}, but the file declares {} vertices", token.line, f,
                           *id, nv);
      }
      polygon.push_back(static_cast<std::size_t>(*id));
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

/// Reads a PLY scalar of any type from binary data, as a double.
double read_binary_real(const unsigned char* p, std::string_view type, bool big_endian) {
  const int size = ply_type_size(type);
  const bool real = type == "float" || type == "float32" || type == "double" || type == "float64";
  if (!real) return static_cast<double>(read_binary_integer(p, type, big_endian));
  std::uint64_t raw = 0;
  for (int i = 0; i < size; ++i) {
    const int byte = big_endian ? i : size - 1 - i;
    raw = (raw << 8) | p[byte];
  }
  if (size == 4) {
    float value = 0.0F;
    const auto bits = static_cast<std::uint32_t>(raw);
    std::memcpy(&value, &bits, sizeof value);
    return static_cast<double>(value);
  }
  double value = 0.0;
  std::memcpy(&value, &raw, sizeof value);
  return value;
}

/// An ASCII PLY scalar read as its declared type: a float correctly rounded
/// to float, then widened (as a reader storing floats would), others as double.
std::optional<double> ascii_real(std::string_view token, std::string_view type) {
  if (type == "float" || type == "float32") {
    float value = 0.0F;
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (error != std::errc() || end != token.data() + token.size()) return std::nullopt;
    return static_cast<double>(value);
  }
  return to_double(token);
}

bool is_face_element(std::string_view name) { return name == "face" || name == "faces"; }
bool is_face_list(const PlyProperty& p) {
  return !p.count_type.empty() && (p.name == "vertex_indices" || p.name == "vertex_index");
}

std::string diagnose_ply(std::string_view text, PolygonSoup& soup) {
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
  for (const auto& e : elements) {
    if (!is_face_element(e.name)) continue;
    if (std::none_of(e.properties.begin(), e.properties.end(), is_face_list))
      return fmt::format("the PLY '{}' element has no 'vertex_indices' list", e.name);
    for (const auto& p : e.properties)
      if (is_face_list(p) && (p.type == "float" || p.type == "float32" || p.type == "double" || p.type == "float64"))
        return fmt::format("the PLY '{}' list '{}' holds {} values, not vertex indices", e.name, p.name, p.type);
  }
  // Where a value goes: a vertex's coordinate (0, 1, 2), a face's index list, or nowhere.
  auto axis_of = [](const PlyElement& element, const PlyProperty& property) {
    if (element.name != "vertex" || !property.count_type.empty()) return -1;
    return property.name == "x" ? 0 : property.name == "y" ? 1 : property.name == "z" ? 2 : -1;
  };
  auto starts_item = [&](const PlyElement& element) {
    if (element.name == "vertex") soup.points.push_back({0.0, 0.0, 0.0});
  };
  auto add_value = [&](const PlyElement& element, const PlyProperty& property, bool first_item, double value) {
    if (const int axis = axis_of(element, property); axis >= 0) soup.points.back()[static_cast<std::size_t>(axis)] = value;
    if (is_face_element(element.name) && is_face_list(property)) {
      if (first_item) soup.polygons.emplace_back();
      soup.polygons.back().push_back(static_cast<std::size_t>(value));
    }
  };
  auto face_list_done = [&](const PlyElement& element, const PlyProperty& property, long long items) {
    // An empty index list is still a polygon (then refused as one).
    if (items == 0 && is_face_element(element.name) && is_face_list(property)) soup.polygons.emplace_back();
  };
  // The first index list of a face element is its polygon; later ones are ignored.
  auto first_list = [](const PlyElement& element, const PlyProperty& property) {
    for (const auto& p : element.properties)
      if (is_face_list(p)) return &p == &property;
    return false;
  };

  if (format == "ascii") {
    Tokens tokens(text.substr(pos), false);
    for (const auto& element : elements) {
      for (long long i = 0; i < element.count; ++i) {
        starts_item(element);
        for (const auto& property : element.properties) {
          const bool polygon = first_list(element, property);
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
            if (polygon) {
              const auto id = to_integer(token.text);
              if (!id) return fmt::format("line {}: face {}: '{}' is not a vertex index", line, i, token.text);
              if (*id < 0 || *id >= nv) {
                return fmt::format("line {}: face {} references vertex {}, but the file declares {} vertices", line, i,
                                   *id, nv);
              }
              add_value(element, property, k == 0, static_cast<double>(*id));
            } else if (axis_of(element, property) >= 0) {
              const auto value = ascii_real(token.text, property.type);
              if (!value)
                return fmt::format("line {}: vertex {}: '{}' is out of range for a {}", line, i, token.text,
                                   property.type);
              add_value(element, property, false, *value);
            }
          }
          if (polygon) face_list_done(element, property, items);
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
      starts_item(element);
      for (const auto& property : element.properties) {
        const bool polygon = first_list(element, property);
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
          if (polygon) {
            const long long id = read_binary_integer(data + offset, property.type, big_endian);
            if (id < 0 || id >= nv) {
              return fmt::format("face {} references vertex {}, but the file declares {} vertices", i, id, nv);
            }
            add_value(element, property, k == 0, static_cast<double>(id));
          } else if (axis_of(element, property) >= 0) {
            add_value(element, property, false, read_binary_real(data + offset, property.type, big_endian));
          }
          offset += item_size;
        }
        if (polygon) face_list_done(element, property, items);
      }
    }
  }
  return {};
}

// ---------------------------------------------------------------- STL
/// An STL's corners merged where their coordinates are equal, numbered in
/// order of first appearance (an STL lists each triangle's corners apart).
class CornerMerger {
 public:
  explicit CornerMerger(PolygonSoup& soup) : soup_(soup) {}
  void add_triangle(const std::array<std::array<double, 3>, 3>& corners) {
    std::vector<std::size_t>& polygon = soup_.polygons.emplace_back();
    for (const auto& p : corners) {
      if (std::isnan(p[0]) || std::isnan(p[1]) || std::isnan(p[2])) {  // unordered: a point of its own (refused later)
        polygon.push_back(soup_.points.size());
        soup_.points.push_back(p);
        continue;
      }
      const auto [it, inserted] = ids_.emplace(p, soup_.points.size());
      if (inserted) soup_.points.push_back(p);
      polygon.push_back(it->second);
    }
  }

 private:
  PolygonSoup& soup_;
  std::map<std::array<double, 3>, std::size_t> ids_;  // ordered by <: 0 and −0 are one point
};

std::string diagnose_stl(std::string_view text, PolygonSoup& soup) {
  CornerMerger merger(soup);
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
    const auto* data = reinterpret_cast<const unsigned char*>(text.data());
    for (std::uint32_t t = 0; t < declared; ++t) {
      std::array<std::array<double, 3>, 3> corners{};
      for (std::size_t v = 0; v < 3; ++v)
        for (std::size_t k = 0; k < 3; ++k)  // non-finite values are refused by the surface's validation
          corners[v][k] = read_binary_real(data + 84 + 50 * std::size_t{t} + 12 * (v + 1) + 4 * k, "float", false);
      merger.add_triangle(corners);
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
    std::array<std::array<double, 3>, 3> corners{};
    for (std::size_t v = 0; v < 3; ++v) {
      if (auto problem = expect("vertex")) return *problem;
      for (std::size_t k = 0; k < 3; ++k) {
        const auto token = tokens.next();
        if (auto problem = coordinate_problem(token.text)) {
          return fmt::format("line {}: facet {}: {}", token.line, facet, *problem);
        }
        corners[v][k] = *to_double(token.text);
      }
    }
    if (auto problem = expect("endloop")) return *problem;
    if (auto problem = expect("endfacet")) return *problem;
    merger.add_triangle(corners);
  }
}

}  // namespace

std::string read_polygon_soup(const std::filesystem::path& path, MeshFormat format, PolygonSoup& soup) {
  const std::string text = read_all(path);
  soup = PolygonSoup{};
  switch (format) {
    case MeshFormat::off:
      return diagnose_off(text, soup);
    case MeshFormat::ply:
      return diagnose_ply(text, soup);
    case MeshFormat::stl:
      return diagnose_stl(text, soup);
    case MeshFormat::obj:
      break;  // read_obj
  }
  return "OBJ files are read by read_obj";
}

}  // namespace goo::io::detail
