#include <fmt/format.h>

#include <array>
#include <bit>
#include <cstring>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/surface_mesh_io.h"

namespace goo::io {
namespace {

static_assert(std::endian::native == std::endian::little, "binary writers assume a little-endian host");

template <typename T>
void put(std::ostream& out, T value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof value);
}

/// 17 significant digits: every double survives the text round trip exactly.
void write_xyz(fmt::memory_buffer& buffer, const TriangleMesh& mesh, Index v) {
  fmt::format_to(std::back_inserter(buffer), "{:.17g} {:.17g} {:.17g}", mesh.vertices(v, 0), mesh.vertices(v, 1),
                 mesh.vertices(v, 2));
}

void flush(std::ostream& out, fmt::memory_buffer& buffer) {
  out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
  buffer.clear();
}

void write_off(std::ostream& out, const TriangleMesh& mesh) {
  fmt::memory_buffer b;
  fmt::format_to(std::back_inserter(b), "OFF\n{} {} 0\n", mesh.num_vertices(), mesh.num_triangles());
  for (Index v = 0; v < mesh.num_vertices(); ++v) {
    write_xyz(b, mesh, v);
    b.push_back('\n');
  }
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    fmt::format_to(std::back_inserter(b), "3 {} {} {}\n", mesh.triangles(t, 0), mesh.triangles(t, 1),
                   mesh.triangles(t, 2));
  flush(out, b);
}

void write_obj(std::ostream& out, const TriangleMesh& mesh) {
  fmt::memory_buffer b;
  fmt::format_to(std::back_inserter(b), "# goo surface: {} vertices, {} triangles\n", mesh.num_vertices(),
                 mesh.num_triangles());
  for (Index v = 0; v < mesh.num_vertices(); ++v) {
    fmt::format_to(std::back_inserter(b), "v ");
    write_xyz(b, mesh, v);
    b.push_back('\n');
  }
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    fmt::format_to(std::back_inserter(b), "f {} {} {}\n", mesh.triangles(t, 0) + 1, mesh.triangles(t, 1) + 1,
                   mesh.triangles(t, 2) + 1);
  flush(out, b);
}

void write_ply(std::ostream& out, const TriangleMesh& mesh, const WriteOptions& options) {
  const bool labelled = !options.face_body.empty();
  if (labelled && options.face_body.size() != static_cast<std::size_t>(mesh.num_triangles()))
    throw Error(fmt::format("{} body labels for {} triangles", options.face_body.size(), mesh.num_triangles()));
  const Encoding encoding = options.encoding;
  fmt::memory_buffer b;
  fmt::format_to(std::back_inserter(b),
                 "ply\nformat {} 1.0\ncomment written by goo\nelement vertex {}\nproperty double x\n"
                 "property double y\nproperty double z\nelement face {}\nproperty list uchar int vertex_indices\n"
                 "{}end_header\n",
                 encoding == Encoding::binary ? "binary_little_endian" : "ascii", mesh.num_vertices(),
                 mesh.num_triangles(), labelled ? "property int body\n" : "");
  if (encoding == Encoding::ascii) {
    for (Index v = 0; v < mesh.num_vertices(); ++v) {
      write_xyz(b, mesh, v);
      b.push_back('\n');
    }
    for (Index t = 0; t < mesh.num_triangles(); ++t) {
      fmt::format_to(std::back_inserter(b), "3 {} {} {}", mesh.triangles(t, 0), mesh.triangles(t, 1),
                     mesh.triangles(t, 2));
      if (labelled) fmt::format_to(std::back_inserter(b), " {}", options.face_body[static_cast<std::size_t>(t)]);
      b.push_back('\n');
    }
    flush(out, b);
    return;
  }
  flush(out, b);
  // Rows of a row-major #V×3 matrix are contiguous: write them as they are.
  out.write(reinterpret_cast<const char*>(mesh.vertices.data()),
            static_cast<std::streamsize>(sizeof(double) * 3 * static_cast<std::size_t>(mesh.num_vertices())));
  const std::size_t record = labelled ? 17 : 13;
  std::vector<char> faces(static_cast<std::size_t>(mesh.num_triangles()) * record);
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    char* p = faces.data() + static_cast<std::size_t>(t) * record;
    *p = 3;
    std::memcpy(p + 1, &mesh.triangles(t, 0), 4);
    std::memcpy(p + 5, &mesh.triangles(t, 1), 4);
    std::memcpy(p + 9, &mesh.triangles(t, 2), 4);
    if (labelled) std::memcpy(p + 13, &options.face_body[static_cast<std::size_t>(t)], 4);
  }
  out.write(faces.data(), static_cast<std::streamsize>(faces.size()));
}

Eigen::Vector3d unit_normal(const TriangleMesh& mesh, Index t) {
  const auto [a, b, c] = mesh.corners(t);
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double length = n.norm();
  return length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
}

void write_stl(std::ostream& out, const TriangleMesh& mesh, Encoding encoding) {
  if (encoding == Encoding::ascii) {
    fmt::memory_buffer b;
    fmt::format_to(std::back_inserter(b), "solid goo\n");
    for (Index t = 0; t < mesh.num_triangles(); ++t) {
      const Eigen::Vector3d n = unit_normal(mesh, t);
      fmt::format_to(std::back_inserter(b), "facet normal {:.9g} {:.9g} {:.9g}\nouter loop\n", n.x(), n.y(), n.z());
      for (int k = 0; k < 3; ++k) {
        fmt::format_to(std::back_inserter(b), "vertex ");
        write_xyz(b, mesh, mesh.triangles(t, k));
        b.push_back('\n');
      }
      fmt::format_to(std::back_inserter(b), "endloop\nendfacet\n");
    }
    fmt::format_to(std::back_inserter(b), "endsolid goo\n");
    flush(out, b);
    return;
  }
  std::array<char, 80> header{};
  const char title[] = "goo binary STL";  // must not start with "solid"
  std::memcpy(header.data(), title, sizeof title - 1);
  out.write(header.data(), header.size());
  put(out, static_cast<std::uint32_t>(mesh.num_triangles()));
  std::vector<char> records(static_cast<std::size_t>(mesh.num_triangles()) * 50);
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    std::array<float, 12> values{};
    const Eigen::Vector3d n = unit_normal(mesh, t);
    for (int k = 0; k < 3; ++k) values[static_cast<std::size_t>(k)] = static_cast<float>(n[k]);
    for (int v = 0; v < 3; ++v)
      for (int k = 0; k < 3; ++k)
        values[static_cast<std::size_t>(3 + 3 * v + k)] = static_cast<float>(mesh.vertices(mesh.triangles(t, v), k));
    char* p = records.data() + static_cast<std::size_t>(t) * 50;
    std::memcpy(p, values.data(), 48);
    p[48] = p[49] = 0;  // attribute byte count
  }
  out.write(records.data(), static_cast<std::streamsize>(records.size()));
}

}  // namespace

void write_surface_mesh(const std::filesystem::path& path, const TriangleMesh& mesh, const WriteOptions& options) {
  const MeshFormat format = mesh_format_of(path);
  write_file_atomically(path, [&](std::ostream& out) {
    switch (format) {
      case MeshFormat::off:
        write_off(out, mesh);
        break;
      case MeshFormat::obj:
        write_obj(out, mesh);
        break;
      case MeshFormat::ply:
        write_ply(out, mesh, options);
        break;
      case MeshFormat::stl:
        write_stl(out, mesh, options.encoding);
        break;
    }
  });
}

}  // namespace goo::io
