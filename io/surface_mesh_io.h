#pragma once
// Reading and writing triangle surface meshes: OFF, OBJ, PLY (ASCII and
// binary) and STL (ASCII and binary). The format follows the file extension.
#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>
#include <string_view>

#include "core/surface_check.h"
#include "core/triangle_mesh.h"

namespace goo::io {

enum class MeshFormat { off, obj, ply, stl };
enum class Encoding { ascii, binary };

/// The format named by a file's extension (case-insensitive); goo::Error for
/// any other extension.
MeshFormat mesh_format_of(const std::filesystem::path& path);
std::string_view to_string(MeshFormat format);

struct ReadOptions {
  /// Triangle soups (STL) repeat each vertex in every triangle; copies closer
  /// than this fraction of the bounding-box diagonal are merged. The default
  /// is a little above the float precision STL stores (2⁻²⁴ ≈ 6·10⁻⁸).
  double weld_tolerance = 1e-7;
  /// Run validate_surface (closed, manifold, oriented, ...) after parsing.
  bool validate = true;
};

/// Reads a surface mesh, triangulates its polygons, welds soups, drops
/// unreferenced vertices and (by default) validates it. Every failure throws
/// goo::Error naming the file and the first offending line, face or edge.
TriangleMesh read_surface_mesh(const std::filesystem::path& path, const ReadOptions& options = {});

struct WriteOptions {
  /// Binary where the format has it (PLY, STL); OFF and OBJ are ASCII only.
  Encoding encoding = Encoding::binary;
  /// PLY only: each triangle's body (the `int body` face property), one per
  /// triangle; empty: no such property.
  std::span<const std::int32_t> face_body;
};

/// A frame goo wrote: the surfaces of every body, and each triangle's body.
struct FrameSurface {
  TriangleMesh mesh;
  std::vector<std::int32_t> face_body;  ///< per triangle; all 0 when the file has no `body` property
};

/// Reads a frame (frames/frame_NNNNN.ply or .obj) without validating it
/// (a frame may legitimately touch itself): goo's own binary PLY directly,
/// any other file through read_surface_mesh. Throws goo::Error naming the
/// file when it is truncated or malformed.
FrameSurface read_frame_surface(const std::filesystem::path& path);

/// Writes a surface mesh in the format of the path's extension. ASCII
/// coordinates carry 17 significant digits (exact round trip); binary PLY
/// stores doubles, binary STL floats (the format allows nothing else). The
/// file is written beside its destination and renamed over it, so a failure
/// leaves any earlier file intact. Throws goo::Error naming the file.
void write_surface_mesh(const std::filesystem::path& path, const TriangleMesh& mesh, const WriteOptions& options = {});

}  // namespace goo::io
