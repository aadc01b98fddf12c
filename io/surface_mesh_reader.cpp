#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>

#include "core/error.h"
#include "core/log.h"
#include "core/polygon_soup.h"
#include "io/detail/polygon_soup_readers.h"
#include "io/atomic_file.h"
#include "io/surface_mesh_io.h"

namespace goo::io {

MeshFormat mesh_format_of(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".off") return MeshFormat::off;
  if (ext == ".obj") return MeshFormat::obj;
  if (ext == ".ply") return MeshFormat::ply;
  if (ext == ".stl") return MeshFormat::stl;
  throw Error(fmt::format("{}: unknown surface mesh format '{}' (expected .off, .obj, .ply or .stl)", path.string(),
                          path.extension().string()));
}

std::string_view to_string(MeshFormat format) {
  switch (format) {
    case MeshFormat::off:
      return "OFF";
    case MeshFormat::obj:
      return "OBJ";
    case MeshFormat::ply:
      return "PLY";
    case MeshFormat::stl:
      return "STL";
  }
  return "?";
}

namespace {

/// Polygons to triangles, with each face's ids checked against the vertices.
TriangleMesh triangulate(const detail::PolygonSoup& soup, const std::string& name) {
  TriangleMesh mesh;
  const std::size_t nv = soup.points.size();
  if (nv > static_cast<std::size_t>(std::numeric_limits<Index>::max())) {
    throw Error(fmt::format("{}: {} vertices is more than goo's 32-bit ids hold", name, nv));
  }
  mesh.vertices.resize(static_cast<Eigen::Index>(nv), 3);
  for (std::size_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k)
      mesh.vertices(static_cast<Eigen::Index>(i), k) = soup.points[i][static_cast<std::size_t>(k)];

  std::vector<Eigen::Vector3i> triangles;
  triangles.reserve(soup.polygons.size());
  std::vector<Index> polygon;
  for (std::size_t f = 0; f < soup.polygons.size(); ++f) {
    const auto& face = soup.polygons[f];
    if (face.size() < 3)
      throw Error(fmt::format("{}: face {} has {} vertices; a face needs at least 3", name, f, face.size()));
    polygon.clear();
    for (const std::size_t id : face) {
      if (id >= nv) {
        throw Error(fmt::format(
            "{}: face {} references vertex {}, but the file has {} vertices", name, f,
            id == std::numeric_limits<std::size_t>::max() ? std::string("below 0") : std::to_string(id), nv));
      }
      polygon.push_back(static_cast<Index>(id));
    }
    triangulate_polygon(polygon, mesh.vertices, triangles);
  }
  if (triangles.size() > static_cast<std::size_t>(std::numeric_limits<Index>::max())) {
    throw Error(fmt::format("{}: {} triangles is more than goo's 32-bit ids hold", name, triangles.size()));
  }
  mesh.triangles.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    mesh.triangles.row(static_cast<Eigen::Index>(t)) = triangles[t].transpose();
  return mesh;
}

}  // namespace

TriangleMesh read_surface_mesh(const std::filesystem::path& path, const ReadOptions& options) {
  const std::string name = path.string();
  const MeshFormat format = mesh_format_of(path);
  require_regular_file(path, "a mesh file");
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw Error(fmt::format("{}: cannot open: {}", name, std::strerror(errno)));
    if (probe.peek() == std::ifstream::traits_type::eof()) throw Error(fmt::format("{}: the file is empty", name));
  }
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw Error(fmt::format("{}: is a folder, not a mesh file", name));

  detail::PolygonSoup soup;
  if (format == MeshFormat::obj) {
    soup = detail::read_obj(path);
  } else {
    if (const std::string problem = detail::read_polygon_soup(path, format, soup); !problem.empty()) {
      throw Error(fmt::format("{}: {}", name, problem));
    }
  }

  TriangleMesh mesh = triangulate(soup, name);
  if (format == MeshFormat::stl) {
    const WeldResult weld = weld_vertices(mesh, options.weld_tolerance);
    log().debug("{}: merged {} duplicate vertices (tolerance {:.3g} m)", name, weld.merged, weld.tolerance);
  }
  if (const Index dropped = remove_unreferenced_vertices(mesh); dropped > 0) {
    log().info("{}: dropped {} vertices that no face uses", name, dropped);
  }
  if (options.validate) validate_surface(mesh, name);
  return mesh;
}

}  // namespace goo::io
