#include "io/run_file.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <type_traits>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "io/atomic_file.h"
#include "io/detail/hdf5_handle.h"

namespace goo::io {

namespace {

using detail::H5Handle;
using detail::io_reason;

std::string frame_group(int frame) { return fmt::format("/frames/{:05d}", frame); }

void check(herr_t status, const std::filesystem::path& path, std::string_view what) {
  if (status < 0) throw WriteError(fmt::format("{}: HDF5 failed to {}{}", path.string(), what, io_reason()));
}

template <class Matrix>
void write_matrix(hid_t group, const char* name, const Matrix& m, hid_t file_type, hid_t memory_type,
                  const std::filesystem::path& path) {
  const hsize_t dims[2] = {static_cast<hsize_t>(m.rows()), static_cast<hsize_t>(m.cols())};
  H5Handle space(H5Screate_simple(2, dims, nullptr), H5Sclose);
  H5Handle set(H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!set.valid()) throw WriteError(fmt::format("{}: HDF5 failed to create {}{}", path.string(), name, io_reason()));
  if (m.size() > 0) check(H5Dwrite(set, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, m.data()), path, name);
}

long long rows_of(hid_t group, const char* name) {
  if (H5Lexists(group, name, H5P_DEFAULT) <= 0) return 0;
  H5Handle set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  H5Handle space(H5Dget_space(set), H5Sclose);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  return static_cast<long long>(dims[0]);
}

/// One XDMF grid: elements of `corners` nodes and XYZ points, both datasets
/// of run.h5; with `body_set`, each element's body as a cell attribute.
std::string uniform_grid(const char* name, const char* topology, int corners, long long elements,
                         const std::string& elements_set, long long points, const std::string& points_set,
                         const std::string& body_set = "") {
  const std::string body =
      body_set.empty()
          ? std::string()
          : fmt::format("     <Attribute Name=\"body\" AttributeType=\"Scalar\" Center=\"Cell\">\n"
                        "      <DataItem Dimensions=\"{}\" NumberType=\"Int\" Precision=\"4\" "
                        "Format=\"HDF\">run.h5:{}</DataItem>\n"
                        "     </Attribute>\n",
                        elements, body_set);
  return fmt::format(
      "    <Grid Name=\"{0}\" GridType=\"Uniform\">\n"
      "     <Topology TopologyType=\"{1}\" NumberOfElements=\"{3}\">\n"
      "      <DataItem Dimensions=\"{3} {2}\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">run.h5:{4}</DataItem>\n"
      "     </Topology>\n"
      "     <Geometry GeometryType=\"XYZ\">\n"
      "      <DataItem Dimensions=\"{5} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">run.h5:{6}</DataItem>\n"
      "     </Geometry>\n"
      "{7}"
      "    </Grid>\n",
      name, topology, corners, elements, elements_set, points, points_set, body);
}

}  // namespace

RunFile::RunFile(const std::filesystem::path& folder, int first_frame) : folder_(folder) {
  detail::SilenceHdf5Errors quiet;
  const std::filesystem::path path = folder / "run.h5";
  std::error_code ec;
  hid_t f = -1;
  if (first_frame > 0 && std::filesystem::exists(path, ec)) {
    // A damaged run file is the earlier run's frames: never replaced unasked.
    if (!std::filesystem::is_regular_file(path, ec) || H5Fis_hdf5(path.c_str()) <= 0 ||
        (f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT)) < 0)
      throw Error(fmt::format("{}: the earlier run's frames are in this file, and HDF5 cannot open it (damaged?); "
                              "resuming would replace it: move it away to go on with a new run file (the frames "
                              "are in {} too)",
                              path.string(), (folder / "frames").string()));
  }
  if (f >= 0) {
    // Keep the frames before first_frame, drop the rest.
    for (int frame = 0;; ++frame) {
      const std::string name = frame_group(frame);
      if (H5Lexists(f, "/frames", H5P_DEFAULT) <= 0 || H5Lexists(f, name.c_str(), H5P_DEFAULT) <= 0) break;
      if (frame >= first_frame) {
        H5Ldelete(f, name.c_str(), H5P_DEFAULT);
        continue;
      }
      H5Handle g(H5Gopen2(f, name.c_str(), H5P_DEFAULT), H5Gclose);
      double time = 0.0;
      H5Handle attr(H5Aopen(g, "time", H5P_DEFAULT), H5Aclose);
      if (attr.valid()) H5Aread(attr, H5T_NATIVE_DOUBLE, &time);
      frames_.push_back({frame, time, rows_of(g, "surface_vertices"), rows_of(g, "surface_triangles"),
                         rows_of(g, "tet_positions"), rows_of(g, "tet_elements"), rows_of(g, "surface_bodies") > 0});
    }
  } else {
    f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (f < 0) throw WriteError(fmt::format("{}: cannot create the run file", path.string()));
  }
  file_ = f;
  if (H5Lexists(f, "/frames", H5P_DEFAULT) <= 0) {
    H5Handle g(H5Gcreate2(f, "/frames", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!g.valid()) {
      H5Fclose(f);
      throw WriteError(fmt::format("{}: HDF5 failed to create /frames", path.string()));
    }
  }
}

RunFile::~RunFile() {
  if (file_ >= 0) H5Fclose(file_);
}

void RunFile::write_frame(int frame, double time, const TriangleMesh& surface, const TetMesh* tets,
                          std::span<const std::int32_t> face_body) {
  detail::SilenceHdf5Errors quiet;
  const std::filesystem::path path = folder_ / "run.h5";
  const std::string name = frame_group(frame);
  if (H5Lexists(file_, name.c_str(), H5P_DEFAULT) > 0) H5Ldelete(file_, name.c_str(), H5P_DEFAULT);
  H5Handle g(H5Gcreate2(file_, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw WriteError(fmt::format("{}: HDF5 failed to create {}{}", path.string(), name, io_reason()));
  {
    H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    H5Handle attr(H5Acreate2(g, "time", H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    check(H5Awrite(attr, H5T_NATIVE_DOUBLE, &time), path, "write the frame time");
  }
  write_matrix(g, "surface_vertices", surface.vertices, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, path);
  write_matrix(g, "surface_triangles", surface.triangles, H5T_STD_I32LE, H5T_NATIVE_INT32, path);
  Frame record{frame, time, surface.vertices.rows(), surface.triangles.rows(), 0, 0, false};
  if (!face_body.empty()) {
    if (face_body.size() != static_cast<std::size_t>(surface.triangles.rows()))
      throw Error(fmt::format("{}: {} body labels for {} triangles", path.string(), face_body.size(),
                              surface.triangles.rows()));
    const Eigen::Map<const Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1>> bodies(
        face_body.data(), static_cast<Eigen::Index>(face_body.size()));
    write_matrix(g, "surface_bodies", bodies, H5T_STD_I32LE, H5T_NATIVE_INT32, path);
    record.bodies = true;
  }
  if (tets) {
    write_matrix(g, "tet_positions", tets->positions, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, path);
    write_matrix(g, "tet_elements", tets->tets, H5T_STD_I32LE, H5T_NATIVE_INT32, path);
    record.nodes = tets->positions.rows();
    record.tets = tets->tets.rows();
  }
  check(H5Fflush(file_, H5F_SCOPE_GLOBAL), path, "flush");
  std::erase_if(frames_, [&](const Frame& f) { return f.frame >= frame; });
  frames_.push_back(record);
  write_xdmf();
}

void RunFile::write_xdmf() const {
  std::ostringstream x;
  x << "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n <Domain>\n"
       "  <Grid Name=\"run\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Frame& f : frames_) {
    const std::string g = frame_group(f.frame);
    x << fmt::format("   <Grid Name=\"frame {:05d}\" GridType=\"Collection\" CollectionType=\"Spatial\">\n", f.frame);
    x << fmt::format("    <Time Value=\"{:.17g}\"/>\n", f.time);
    x << uniform_grid("surface", "Triangle", 3, f.triangles, g + "/surface_triangles", f.vertices,
                      g + "/surface_vertices", f.bodies ? g + "/surface_bodies" : "");
    if (f.tets > 0)
      x << uniform_grid("tets", "Tetrahedron", 4, f.tets, g + "/tet_elements", f.nodes, g + "/tet_positions");
    x << "   </Grid>\n";
  }
  x << "  </Grid>\n </Domain>\n</Xdmf>\n";
  const std::string text = x.str();
  write_file_atomically(folder_ / "run.xdmf", [&](std::ostream& out) { out << text; });
}

void write_tet_mesh_vtk(const std::filesystem::path& path, const TetMesh& mesh) {
  // Legacy VTK binary is big-endian.
  auto be = [](auto value) {
    using T = decltype(value);
    std::array<char, sizeof(T)> b{};
    std::memcpy(b.data(), &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::little) std::reverse(b.begin(), b.end());
    return b;
  };
  write_file_atomically(path, [&](std::ostream& out) {
    const auto nn = mesh.positions.rows(), ne = mesh.tets.rows();
    out << "# vtk DataFile Version 3.0\ngoo tetrahedral mesh\nBINARY\nDATASET UNSTRUCTURED_GRID\n";
    out << "POINTS " << nn << " double\n";
    for (Eigen::Index i = 0; i < nn; ++i)
      for (int k = 0; k < 3; ++k) out.write(be(mesh.positions(i, k)).data(), sizeof(double));
    out << "\nCELLS " << ne << " " << 5 * ne << "\n";
    for (Eigen::Index e = 0; e < ne; ++e) {
      out.write(be(std::int32_t{4}).data(), 4);
      for (int k = 0; k < 4; ++k) out.write(be(std::int32_t{mesh.tets(e, k)}).data(), 4);
    }
    out << "\nCELL_TYPES " << ne << "\n";
    for (Eigen::Index e = 0; e < ne; ++e) out.write(be(std::int32_t{10}).data(), 4);
    out << "\n";
  });
}

TetMesh read_tet_mesh_vtk(const std::filesystem::path& path) {
  std::error_code error;
  require_regular_file(path, "a tetrahedral mesh file");
  std::ifstream in(path, std::ios::binary);
  auto fail = [&](std::string_view what) {
    throw Error(fmt::format("{}: not a tetrahedral mesh goo wrote ({})", path.string(), what));
  };
  auto line = [&] {
    std::string l;
    if (!std::getline(in, l) || l.size() > 256) fail("truncated header");
    return l;
  };
  auto from_be = [](auto& value) {
    using T = std::remove_reference_t<decltype(value)>;
    std::array<char, sizeof(T)> b{};
    std::memcpy(b.data(), &value, sizeof(T));
    if constexpr (std::endian::native == std::endian::little) std::reverse(b.begin(), b.end());
    std::memcpy(&value, b.data(), sizeof(T));
  };
  if (line() != "# vtk DataFile Version 3.0") fail("not legacy VTK 3.0");
  line();
  if (line() != "BINARY" || line() != "DATASET UNSTRUCTURED_GRID") fail("not a binary unstructured grid");
  long long nn = -1, ne = -1, size = -1;
  if (std::sscanf(line().c_str(), "POINTS %lld double", &nn) != 1 || nn < 0) fail("no POINTS");
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error || static_cast<std::uintmax_t>(nn) > bytes / 24) fail("truncated POINTS");
  TetMesh mesh;
  mesh.positions.resize(nn, 3);
  for (long long i = 0; i < nn; ++i)
    for (int k = 0; k < 3; ++k) {
      double v = 0.0;
      in.read(reinterpret_cast<char*>(&v), sizeof v);
      from_be(v);
      mesh.positions(i, k) = v;
    }
  line();  // the newline after the binary block
  if (std::sscanf(line().c_str(), "CELLS %lld %lld", &ne, &size) != 2 || ne < 0 || size != 5 * ne) fail("no CELLS");
  if (static_cast<std::uintmax_t>(ne) > bytes / 20) fail("truncated CELLS");
  mesh.tets.resize(ne, 4);
  for (long long e = 0; e < ne; ++e) {
    std::int32_t v[5] = {};
    in.read(reinterpret_cast<char*>(v), sizeof v);
    for (auto& x : v) from_be(x);
    if (v[0] != 4) fail(fmt::format("cell {} is not a tetrahedron", e));
    for (int k = 0; k < 4; ++k) {
      if (v[k + 1] < 0 || v[k + 1] >= nn) fail(fmt::format("cell {} names node {} of {}", e, v[k + 1], nn));
      mesh.tets(e, k) = v[k + 1];
    }
  }
  if (!in) fail("truncated");
  return mesh;
}

}  // namespace goo::io
