#include <fmt/format.h>
#include <tiny_obj_loader.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>

#include "core/error.h"
#include "io/detail/polygon_soup_readers.h"

namespace goo::io::detail {
namespace {

std::string_view next_word(std::string_view& line) {
  std::size_t begin = line.find_first_not_of(" \t\r");
  if (begin == std::string_view::npos) {
    line = {};
    return {};
  }
  std::size_t end = line.find_first_of(" \t\r", begin);
  if (end == std::string_view::npos) end = line.size();
  const std::string_view word = line.substr(begin, end - begin);
  line.remove_prefix(end);
  return word;
}

/// Walks the OBJ text: exact coordinates of every 'v' line, and every face
/// index checked against the vertices defined before it (OBJ's rule).
std::vector<std::array<double, 3>> scan_obj(const std::string& text, const std::string& name) {
  std::vector<std::array<double, 3>> points;
  std::size_t pos = 0;
  for (int line_number = 1; pos < text.size(); ++line_number) {
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    std::string_view line(text.data() + pos, eol - pos);
    pos = eol + 1;
    const std::string_view keyword = next_word(line);
    if (keyword == "v") {
      std::array<double, 3> p{};
      for (int k = 0; k < 3; ++k) {
        const std::string_view word = next_word(line);
        double value = 0.0;
        const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), value);
        if (word.empty() || error != std::errc() || end != word.data() + word.size()) {
          throw Error(fmt::format("{}: line {}: vertex {}: {} is not a number", name, line_number, points.size(),
                                  word.empty() ? std::string("a missing coordinate") : fmt::format("'{}'", word)));
        }
        if (!std::isfinite(value)) {
          throw Error(fmt::format("{}: line {}: vertex {}: the coordinate '{}' is not finite", name, line_number,
                                  points.size(), word));
        }
        p[static_cast<std::size_t>(k)] = value;
      }
      points.push_back(p);
    } else if (keyword == "f") {
      for (std::string_view word = next_word(line); !word.empty(); word = next_word(line)) {
        const std::string_view index = word.substr(0, word.find('/'));
        long long id = 0;
        const auto [end, error] = std::from_chars(index.data(), index.data() + index.size(), id);
        const auto count = static_cast<long long>(points.size());
        if (error != std::errc() || end != index.data() + index.size()) {
          throw Error(fmt::format("{}: line {}: '{}' is not a vertex index", name, line_number, word));
        }
        if (id == 0 || id > count || id < -count) {
          throw Error(fmt::format("{}: line {}: face references vertex {}, but {} vertices are defined before it", name,
                                  line_number, id, count));
        }
      }
    }
  }
  return points;
}

}  // namespace

PolygonSoup read_obj(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  PolygonSoup soup;
  soup.points = scan_obj(text, name);

  tinyobj::ObjReaderConfig config;
  config.triangulate = false;  // goo triangulates (ear clipping, polygon_soup.h)
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromString(text, "", config)) {
    std::string message = reader.Error();
    while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
    throw Error(fmt::format("{}: not a readable OBJ file: {}", name, message));
  }
  if (reader.GetAttrib().vertices.size() != 3 * soup.points.size()) {
    throw Error(fmt::format("{}: the OBJ reader found {} vertices where goo counts {} 'v' lines", name,
                            reader.GetAttrib().vertices.size() / 3, soup.points.size()));
  }
  for (const auto& shape : reader.GetShapes()) {
    std::size_t offset = 0;
    for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      const std::size_t n = shape.mesh.num_face_vertices[f];
      std::vector<std::size_t> polygon(n);
      for (std::size_t k = 0; k < n; ++k) {
        const int id = shape.mesh.indices[offset + k].vertex_index;
        // Out-of-range ids are kept (as a huge number) for the range check.
        polygon[k] = id < 0 ? std::numeric_limits<std::size_t>::max() : static_cast<std::size_t>(id);
      }
      soup.polygons.push_back(std::move(polygon));
      offset += n;
    }
  }
  return soup;
}

}  // namespace goo::io::detail
