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
/// index checked against the vertices defined before it (OBJ's rule) and
/// resolved (negative: counted back from the last vertex), into `soup`.
void scan_obj(const std::string& text, const std::string& name, PolygonSoup& soup) {
  std::vector<std::array<double, 3>>& points = soup.points;
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
      std::vector<std::size_t>& polygon = soup.polygons.emplace_back();
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
        polygon.push_back(static_cast<std::size_t>(id > 0 ? id - 1 : count + id));
      }
    }
  }
}

}  // namespace

PolygonSoup read_obj(const std::filesystem::path& path) {
  const std::string name = path.string();
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  PolygonSoup soup;
  scan_obj(text, name, soup);

  // The OBJ library checks the syntax goo's scan does not; the faces are
  // the scan's own: the library keeps a face's vertex count in one byte, so
  // a face of 256 vertices or more would come back cut short.
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
  std::size_t faces = 0;
  for (const auto& shape : reader.GetShapes()) faces += shape.mesh.num_face_vertices.size();
  if (faces != soup.polygons.size()) {
    throw Error(fmt::format("{}: the OBJ reader found {} faces where goo counts {} 'f' lines", name, faces,
                            soup.polygons.size()));
  }
  return soup;
}

}  // namespace goo::io::detail
