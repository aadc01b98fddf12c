#pragma once
// Internal to goo::io: the format parsers behind read_surface_mesh and the
// diagnosis of files they refuse.
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "io/surface_mesh_io.h"

namespace goo::io::detail {

/// What a file holds before triangulation and checks.
struct PolygonSoup {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<std::size_t>> polygons;  // 0-based vertex ids
};

/// OFF, PLY or STL into `soup`, the structure checked on the way: returns
/// the first problem (wrong header, a token that is not a number, a
/// non-finite coordinate, an index out of range, truncation) with its line
/// (text) or byte count (binary), for a user to act on; empty when the file
/// was read whole. Numbers are read as their declared type, correctly
/// rounded; an STL's equal corners are one point, in order of first
/// appearance.
std::string read_polygon_soup(const std::filesystem::path& path, MeshFormat format, PolygonSoup& soup);

/// OBJ: faces (polygons, groups, relative indices) by tinyobjloader;
/// coordinates by std::from_chars, which rounds correctly where
/// tinyobjloader's own parser can be an ulp off and reads "inf" as 0. Throws
/// goo::Error naming the file and line of the first problem.
PolygonSoup read_obj(const std::filesystem::path& path);

}  // namespace goo::io::detail
