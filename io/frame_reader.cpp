// Reading goo's own frames back (goo render): the binary PLY that
// write_surface_mesh produces, at the speed of the disk.
#include <fmt/format.h>

#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/surface_mesh_io.h"

namespace goo::io {
namespace {

/// The header of a PLY file as goo writes it; false for anything else.
struct GooPly {
  Index vertices = 0, faces = 0;
  bool labelled = false;
};

bool parse_goo_header(std::istream& in, GooPly& out) {
  std::string line;
  std::vector<std::string> lines;
  std::size_t bytes = 0;
  while (std::getline(in, line)) {
    bytes += line.size() + 1;
    if (bytes > 4096) return false;  // goo's headers are a few hundred bytes
    if (line == "end_header") break;
    if (line.rfind("comment", 0) == 0) continue;
    lines.push_back(line);
  }
  if (!in) return false;
  const std::vector<std::string> fixed = {"ply", "format binary_little_endian 1.0"};
  if (lines.size() < 9 || lines[0] != fixed[0] || lines[1] != fixed[1]) return false;
  long long vertices = -1, faces = -1;
  char name[32] = {};
  if (std::sscanf(lines[2].c_str(), "element vertex %lld", &vertices) != 1 || vertices < 0) return false;
  if (lines[3] != "property double x" || lines[4] != "property double y" || lines[5] != "property double z")
    return false;
  if (std::sscanf(lines[6].c_str(), "element face %lld", &faces) != 1 || faces < 0) return false;
  if (lines[7] != "property list uchar int vertex_indices") return false;
  if (lines.size() == 9 && std::sscanf(lines[8].c_str(), "property int %31s", name) == 1 &&
      std::strcmp(name, "body") == 0)
    out.labelled = true;
  else if (lines.size() != 8)
    return false;
  out.vertices = static_cast<Index>(vertices);
  out.faces = static_cast<Index>(faces);
  return true;
}

}  // namespace

FrameSurface read_frame_surface(const std::filesystem::path& path) {
  FrameSurface frame;
  std::error_code error;
  require_regular_file(path, "a frame file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the frame", path.string()));
  GooPly header;
  if (mesh_format_of(path) != MeshFormat::ply || !parse_goo_header(in, header)) {
    frame.mesh = read_surface_mesh(path, {.validate = false});
    frame.face_body.assign(static_cast<std::size_t>(frame.mesh.num_triangles()), 0);
    return frame;
  }
  const auto start = static_cast<std::uintmax_t>(in.tellg());
  const std::size_t record = header.labelled ? 17 : 13;
  const std::uintmax_t expected = start + 24 * static_cast<std::uintmax_t>(header.vertices) +
                                  record * static_cast<std::uintmax_t>(header.faces);
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error || size != expected)
    throw Error(fmt::format("{}: truncated or padded frame ({} bytes where its header promises {})", path.string(),
                            size, expected));
  frame.mesh.vertices.resize(header.vertices, 3);
  in.read(reinterpret_cast<char*>(frame.mesh.vertices.data()),
          static_cast<std::streamsize>(24 * static_cast<std::size_t>(header.vertices)));
  std::vector<char> faces(record * static_cast<std::size_t>(header.faces));
  in.read(faces.data(), static_cast<std::streamsize>(faces.size()));
  if (!in) throw Error(fmt::format("{}: cannot read the frame", path.string()));
  frame.mesh.triangles.resize(header.faces, 3);
  frame.face_body.assign(static_cast<std::size_t>(header.faces), 0);
  for (Index t = 0; t < header.faces; ++t) {
    const char* p = faces.data() + record * static_cast<std::size_t>(t);
    if (*p != 3) throw Error(fmt::format("{}: face {} is not a triangle", path.string(), t));
    for (int k = 0; k < 3; ++k) {
      std::int32_t v = 0;
      std::memcpy(&v, p + 1 + 4 * k, 4);
      if (v < 0 || v >= header.vertices)
        throw Error(fmt::format("{}: face {} names vertex {} of {}", path.string(), t, v, header.vertices));
      frame.mesh.triangles(t, k) = v;
    }
    if (header.labelled) std::memcpy(&frame.face_body[static_cast<std::size_t>(t)], p + 13, 4);
  }
  if (!frame.mesh.vertices.allFinite()) throw Error(fmt::format("{}: a vertex is not finite", path.string()));
  return frame;
}

}  // namespace goo::io
