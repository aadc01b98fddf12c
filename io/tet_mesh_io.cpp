#include "io/tet_mesh_io.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/log.h"
#include "io/detail/text_tokens.h"

namespace goo::io {
namespace {

using detail::Tokens;

/// The text of a file, refusing missing and empty files.
std::string load(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw Error(fmt::format("{}: cannot open: no such file", path.string()));
  std::string text = detail::read_all(path);
  if (text.empty()) throw Error(fmt::format("{}: the file is empty", path.string()));
  return text;
}

long long integer(const Tokens::Token& token, const std::string& name, std::string_view what) {
  const auto value = detail::to_integer(token.text);
  if (!value) {
    throw Error(fmt::format("{}: line {}: expected {}, found {}", name, token.line, what,
                            token.end() ? std::string("the end of the file") : fmt::format("'{}'", token.text)));
  }
  return *value;
}

double coordinate(const Tokens::Token& token, const std::string& name, long long node) {
  const auto value = detail::to_double(token.text);
  if (!value || !std::isfinite(*value)) {
    throw Error(fmt::format(
        "{}: line {}: node {}: {}", name, token.line, node,
        token.end() ? std::string("the file ends inside it") : fmt::format("'{}' is not a finite number", token.text)));
  }
  return *value;
}

Index checked_count(long long count, const Tokens::Token& token, const std::string& name, std::string_view what) {
  if (count < 0 || count > std::numeric_limits<Index>::max()) {
    throw Error(fmt::format("{}: line {}: impossible number of {}: {}", name, token.line, what, count));
  }
  return static_cast<Index>(count);
}

/// A node id of an element, translated to 0-based and checked.
Index node_id(const Tokens::Token& token, const std::string& name, long long element, long long base, Index count) {
  const long long id = integer(token, name, "a node id") - base;
  if (id < 0 || id >= count) {
    throw Error(
        fmt::format("{}: line {}: tetrahedron {} references node {}, but the mesh has {} nodes (ids start at {})", name,
                    token.line, element, id + base, count, base));
  }
  return static_cast<Index>(id);
}

TetMesh read_tetgen(const std::filesystem::path& node_path, const std::filesystem::path& ele_path) {
  TetMesh mesh;
  long long base = 0;
  {
    const std::string name = node_path.string();
    const std::string text = load(node_path);
    Tokens tokens(text, true);
    auto header = tokens.line();
    if (header.size() < 2)
      throw Error(fmt::format("{}: line {}: expected '<nodes> 3 <attributes> <markers>'", name, tokens.line_number()));
    const Index count = checked_count(integer(header[0], name, "the node count"), header[0], name, "nodes");
    const long long dimension = integer(header[1], name, "the dimension");
    if (dimension != 3)
      throw Error(fmt::format("{}: line {}: dimension {} (goo needs 3)", name, header[1].line, dimension));
    mesh.positions.resize(count, 3);
    for (Index n = 0; n < count; ++n) {
      auto line = tokens.line();
      if (line.empty())
        throw Error(fmt::format("{}: the file ends after {} of the {} nodes it declares", name, n, count));
      const long long id = integer(line[0], name, "a node id");
      if (n == 0) base = id;
      if (id != base + n) {
        throw Error(
            fmt::format("{}: line {}: node id {} out of sequence (expected {})", name, line[0].line, id, base + n));
      }
      if (line.size() < 4)
        throw Error(fmt::format("{}: line {}: node {} has fewer than 3 coordinates", name, line[0].line, id));
      for (int k = 0; k < 3; ++k) mesh.positions(n, k) = coordinate(line[static_cast<std::size_t>(k) + 1], name, id);
    }
  }
  {
    const std::string name = ele_path.string();
    const std::string text = load(ele_path);
    Tokens tokens(text, true);
    auto header = tokens.line();
    if (header.size() < 2)
      throw Error(fmt::format("{}: line {}: expected '<tetrahedra> <nodes per tetrahedron> <attributes>'", name,
                              tokens.line_number()));
    const Index count = checked_count(integer(header[0], name, "the tetrahedron count"), header[0], name, "tetrahedra");
    const long long per = integer(header[1], name, "the nodes per tetrahedron");
    if (per != 4 && per != 10)
      throw Error(fmt::format("{}: line {}: {} nodes per tetrahedron (expected 4 or 10)", name, header[1].line, per));
    mesh.tets.resize(count, 4);
    for (Index e = 0; e < count; ++e) {
      auto line = tokens.line();
      if (line.empty())
        throw Error(fmt::format("{}: the file ends after {} of the {} tetrahedra it declares", name, e, count));
      if (static_cast<long long>(line.size()) < 1 + per) {
        throw Error(fmt::format("{}: line {}: tetrahedron {} lists {} nodes, expected {}", name, line[0].line, e,
                                line.size() - 1, per));
      }
      for (int k = 0; k < 4; ++k)
        mesh.tets(e, k) = node_id(line[static_cast<std::size_t>(k) + 1], name, e, base, mesh.num_nodes());
    }
  }
  return mesh;
}

TetMesh read_medit(const std::filesystem::path& path) {
  const std::string name = path.string();
  const std::string text = load(path);
  Tokens tokens(text, true);
  TetMesh mesh;
  bool have_vertices = false, have_tets = false;
  // Entries per record of the sections goo skips, after their count.
  auto skip_width = [](std::string_view keyword) -> int {
    if (keyword == "Edges") return 3;
    if (keyword == "Triangles") return 4;
    if (keyword == "Quadrilaterals") return 5;
    if (keyword == "Hexahedra") return 9;
    if (keyword == "Corners" || keyword == "Ridges" || keyword == "RequiredVertices" || keyword == "RequiredEdges" ||
        keyword == "RequiredTriangles")
      return 1;
    if (keyword == "Normals" || keyword == "Tangents") return 3;
    if (keyword == "NormalAtVertices" || keyword == "TangentAtVertices") return 2;
    return -1;
  };
  for (auto token = tokens.next(); !token.end() && token.text != "End"; token = tokens.next()) {
    const std::string_view keyword = token.text;
    if (keyword == "MeshVersionFormatted") {
      tokens.next();
    } else if (keyword == "Dimension") {
      const auto d = tokens.next();
      if (integer(d, name, "the dimension") != 3)
        throw Error(fmt::format("{}: line {}: dimension {} (goo needs 3)", name, d.line, d.text));
    } else if (keyword == "Vertices") {
      const auto c = tokens.next();
      const Index count = checked_count(integer(c, name, "the vertex count"), c, name, "vertices");
      mesh.positions.resize(count, 3);
      for (Index n = 0; n < count; ++n) {
        for (int k = 0; k < 3; ++k) mesh.positions(n, k) = coordinate(tokens.next(), name, n + 1);
        integer(tokens.next(), name, "a vertex reference number");
      }
      have_vertices = true;
    } else if (keyword == "Tetrahedra") {
      if (!have_vertices) throw Error(fmt::format("{}: line {}: 'Tetrahedra' before 'Vertices'", name, token.line));
      const auto c = tokens.next();
      const Index count = checked_count(integer(c, name, "the tetrahedron count"), c, name, "tetrahedra");
      mesh.tets.resize(count, 4);
      for (Index e = 0; e < count; ++e) {
        for (int k = 0; k < 4; ++k) mesh.tets(e, k) = node_id(tokens.next(), name, e, 1, mesh.num_nodes());
        integer(tokens.next(), name, "a tetrahedron reference number");
      }
      have_tets = true;
    } else if (const int width = skip_width(keyword); width > 0) {
      const auto c = tokens.next();
      const long long count = integer(c, name, fmt::format("the {} count", keyword));
      for (long long i = 0; i < count * width; ++i) {
        if (tokens.next().end()) throw Error(fmt::format("{}: the file ends inside its '{}' section", name, keyword));
      }
    } else {
      throw Error(fmt::format("{}: line {}: unknown MEDIT keyword '{}'", name, token.line, keyword));
    }
  }
  if (!have_vertices || !have_tets) throw Error(fmt::format("{}: no 'Vertices' and 'Tetrahedra' sections", name));
  return mesh;
}

}  // namespace

TetMesh read_tet_mesh(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  TetMesh mesh;
  if (ext == ".mesh") {
    mesh = read_medit(path);
  } else if (ext == ".node" || ext == ".ele" || ext == ".") {
    std::filesystem::path stem = path;
    if (ext == ".")
      stem = path.parent_path() / path.stem();
    else
      stem.replace_extension();
    mesh = read_tetgen(std::filesystem::path(stem.string() + ".node"), std::filesystem::path(stem.string() + ".ele"));
  } else {
    throw Error(fmt::format("{}: unknown tetrahedral mesh format '{}' (expected .mesh, .node or .ele)", path.string(),
                            path.extension().string()));
  }
  if (const Index flipped = check_and_orient(mesh, path.string()); flipped > 0) {
    log().info("{}: reoriented {} negatively oriented tetrahedra", path.string(), flipped);
  }
  return mesh;
}

}  // namespace goo::io
