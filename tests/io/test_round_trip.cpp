#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <fstream>

#include "core/error.h"
#include "core/primitives.h"
#include "core/surface_check.h"
#include "io/atomic_file.h"
#include "io/run_file.h"
#include "io/surface_mesh_io.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using ::testing::HasSubstr;

/// A torus placed off the origin with coordinates that are not short decimals.
TriangleMesh test_surface() {
  TriangleMesh mesh = make_torus(1.0 / 3.0, 0.1, 24, 12);
  mesh.vertices.rowwise() += Eigen::RowVector3d(0.1, -2.0 / 7.0, 1e3);
  return mesh;
}

/// Corner positions of every triangle: equal for two meshes that describe
/// the same surface, whatever the vertex numbering.
Eigen::MatrixXd corners(const TriangleMesh& mesh) {
  Eigen::MatrixXd out(mesh.num_triangles(), 9);
  for (Index t = 0; t < mesh.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) out.block<1, 3>(t, 3 * k) = mesh.vertices.row(mesh.triangles(t, k));
  return out;
}

struct Case {
  const char* file;
  io::Encoding encoding;
  bool exact;  // false: stored as float
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.file << (c.encoding == io::Encoding::ascii ? " ascii" : " binary");
}

class RoundTrip : public ::testing::TestWithParam<Case> {};

TEST_P(RoundTrip, PreservesTheSurface) {
  const Case c = GetParam();
  test::TempDir dir;
  const TriangleMesh mesh = test_surface();
  io::WriteOptions options;
  options.encoding = c.encoding;
  io::write_surface_mesh(dir / c.file, mesh, options);
  const TriangleMesh back = io::read_surface_mesh(dir / c.file);
  ASSERT_EQ(back.num_triangles(), mesh.num_triangles());
  ASSERT_EQ(back.num_vertices(), mesh.num_vertices());
  if (c.exact) {
    EXPECT_TRUE(test::matrices_near(corners(back), corners(mesh), 0.0));
  } else {
    // float: a rounding of at most 2⁻²⁴ relative per coordinate (|x| ≤ 1001).
    EXPECT_TRUE(test::matrices_near(corners(back), corners(mesh), 1001.0 * 0x1p-24));
  }
}

INSTANTIATE_TEST_SUITE_P(
    EveryFormat, RoundTrip,
    ::testing::Values(Case{"m.off", io::Encoding::ascii, true}, Case{"m.obj", io::Encoding::ascii, true},
                      Case{"m.ply", io::Encoding::ascii, true}, Case{"m.ply", io::Encoding::binary, true},
                      Case{"m.stl", io::Encoding::ascii, true}, Case{"m.stl", io::Encoding::binary, false}),
    [](const auto& param_info) {
      std::string name = param_info.param.file;
      name = name.substr(2) + (param_info.param.encoding == io::Encoding::ascii ? "_ascii" : "_binary");
      return name;
    });

TEST(ReadSurfaceMesh, ObjQuadsAreTriangulatedAndNegativeIndicesResolved) {
  test::TempDir dir;
  const auto path = dir.write("cube.obj",
                              "# a unit cube of quads\n"
                              "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                              "o cube\ng sides\n"
                              "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\n"
                              "f 3 4 8 7\nf -8 -4 -1 -5\n");
  const TriangleMesh mesh = io::read_surface_mesh(path);
  EXPECT_EQ(mesh.num_triangles(), 12);
  EXPECT_NEAR(analyze_surface(mesh).volume, 1.0, 1e-15);
}

TEST(ReadSurfaceMesh, ObjFacesOfHundredsOfVerticesReadAsOffReadsThem) {
  // A prism whose caps are 400-gons (the OBJ library keeps a face's vertex
  // count in one byte: 400 became 144 and the prism was "not closed").
  const int n = 400;
  std::string obj, off = fmt::format("OFF\n{} {} 0\n", 2 * n, n + 2);
  for (int z = 0; z < 2; ++z)
    for (int k = 0; k < n; ++k) {
      const double a = 2.0 * M_PI * k / n;
      const std::string v = fmt::format("{} {} {}\n", std::cos(a), std::sin(a), z);
      obj += "v " + v;
      off += v;
    }
  std::string bottom = "f", top = "f", off_bottom = fmt::format("{}", n), off_top = fmt::format("{}", n);
  for (int k = 0; k < n; ++k) {
    bottom += fmt::format(" {}", n - k), off_bottom += fmt::format(" {}", n - 1 - k);  // downward
    top += fmt::format(" {}", n + 1 + k), off_top += fmt::format(" {}", n + k);
  }
  obj += bottom + "\n" + top + "\n";
  off += off_bottom + "\n" + off_top + "\n";
  for (int k = 0; k < n; ++k) {
    const int a = k, b = (k + 1) % n;
    obj += fmt::format("f {} {} {} {}\n", a + 1, b + 1, n + b + 1, n + a + 1);
    off += fmt::format("4 {} {} {} {}\n", a, b, n + b, n + a);
  }
  test::TempDir dir;
  const TriangleMesh from_obj = io::read_surface_mesh(dir.write("prism.obj", obj));
  const TriangleMesh from_off = io::read_surface_mesh(dir.write("prism.off", off));
  EXPECT_EQ(from_obj.num_triangles(), from_off.num_triangles());
  EXPECT_EQ(from_obj.num_triangles(), 2 * (n - 2) + 2 * n);
  EXPECT_TRUE(from_obj.vertices == from_off.vertices);
  EXPECT_TRUE(from_obj.triangles == from_off.triangles);
  EXPECT_NEAR(analyze_surface(from_obj).volume, 0.5 * n * std::sin(2.0 * M_PI / n), 1e-12);
}

TEST(ReadSurfaceMesh, PlyVariantsReadTheSameSurface) {
  // Big-endian floats, extra vertex properties, 'vertex_index', int8 counts.
  test::TempDir dir;
  std::string header =
      "ply\nformat binary_big_endian 1.0\ncomment tetrahedron\nelement vertex 4\nproperty float x\n"
      "property float y\nproperty float z\nproperty uchar red\nelement face 4\n"
      "property list char uint vertex_index\nend_header\n";
  std::string body;
  auto put_be = [&](const void* p, std::size_t n) {
    const auto* b = static_cast<const char*>(p);
    for (std::size_t i = 0; i < n; ++i) body.push_back(b[n - 1 - i]);
  };
  const float v[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (const auto& p : v) {
    for (const float x : p) put_be(&x, 4);
    body.push_back(static_cast<char>(200));
  }
  const std::uint32_t f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& t : f) {
    body.push_back(3);
    for (const std::uint32_t i : t) put_be(&i, 4);
  }
  const TriangleMesh mesh = io::read_surface_mesh(dir.write("tet.ply", header + body));
  EXPECT_EQ(mesh.num_triangles(), 4);
  EXPECT_NEAR(analyze_surface(mesh).volume, 1.0 / 6.0, 1e-16);
}

TEST(ReadSurfaceMesh, OffWithCommentsColoursAndPolygons) {
  test::TempDir dir;
  const auto path = dir.write("pyramid.off",
                              "OFF\n# square pyramid, base polygon as one face\n5 5 0\n"
                              "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n"
                              "4 0 3 2 1 255 0 0\n3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4\n");
  const TriangleMesh mesh = io::read_surface_mesh(path);
  EXPECT_EQ(mesh.num_triangles(), 6);
  EXPECT_NEAR(analyze_surface(mesh).volume, 1.0 / 3.0, 1e-15);
}

TEST(ReadSurfaceMesh, InsideOutFileIsFlippedOnLoad) {
  test::TempDir dir;
  TriangleMesh mesh = make_sphere(1.0, 12);
  flip_orientation(mesh);
  io::write_surface_mesh(dir / "inside_out.ply", mesh);
  const TriangleMesh back = io::read_surface_mesh(dir / "inside_out.ply");
  EXPECT_GT(analyze_surface(back).volume, 0.0);
}

TEST(WriteFileAtomically, FailureLeavesThePreviousFileIntact) {
  test::TempDir dir;
  const auto path = dir.write("frame.ply", "previous contents");
  EXPECT_THROW(io::write_file_atomically(path,
                                         [](std::ostream& out) {
                                           out << "half a frame";
                                           throw Error("simulated failure");
                                         }),
               Error);
  std::ifstream in(path);
  std::string contents((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(contents, "previous contents");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), std::filesystem::directory_iterator{}), 1)
      << "a temporary file was left behind";
}

TEST(WriteSurfaceMesh, MissingFolderIsAClearError) {
  test::TempDir dir;
  try {
    io::write_surface_mesh(dir / "no" / "such" / "m.ply", make_sphere(1.0, 8));
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("m.ply: cannot write: folder"));
  }
}

TEST(ReadFrameSurface, ReadsBackGoosFramesWithTheirBodies) {
  test::TempDir dir;
  const TriangleMesh mesh = make_torus(1.0 / 3.0, 0.1, 24, 12);
  std::vector<std::int32_t> bodies(static_cast<std::size_t>(mesh.num_triangles()));
  for (std::size_t t = 0; t < bodies.size(); ++t) bodies[t] = static_cast<std::int32_t>(t % 3);
  io::WriteOptions labelled;
  labelled.face_body = bodies;
  io::write_surface_mesh(dir / "frame.ply", mesh, labelled);
  const io::FrameSurface back = io::read_frame_surface(dir / "frame.ply");
  EXPECT_TRUE(back.mesh.vertices == mesh.vertices);
  EXPECT_TRUE(back.mesh.triangles == mesh.triangles);
  EXPECT_EQ(back.face_body, bodies);
  // Without labels, every triangle is body 0; an OBJ goes the generic way.
  io::write_surface_mesh(dir / "plain.ply", mesh);
  EXPECT_EQ(io::read_frame_surface(dir / "plain.ply").face_body, std::vector<std::int32_t>(bodies.size(), 0));
  io::write_surface_mesh(dir / "frame.obj", mesh);
  EXPECT_EQ(io::read_frame_surface(dir / "frame.obj").mesh.num_triangles(), mesh.num_triangles());
  // A truncated frame, a missing one and a folder are refused, naming the file.
  std::filesystem::resize_file(dir / "frame.ply", std::filesystem::file_size(dir / "frame.ply") - 5);
  EXPECT_TRUE(test::throws_error_containing([&] { (void)io::read_frame_surface(dir / "frame.ply"); }, "frame.ply: truncated"));
  EXPECT_TRUE(test::throws_error_containing([&] { (void)io::read_frame_surface(dir / "none.ply"); }, "none.ply: cannot open a frame file"));
  EXPECT_TRUE(test::throws_error_containing([&] { (void)io::read_frame_surface(dir.path()); }, "a frame file must be a regular file, and this is a folder"));
}

TEST(ReadTetMeshVtk, ReadsBackWhatGooWrote) {
  test::TempDir dir;
  TetMesh mesh;
  mesh.positions.resize(5, 3);
  mesh.positions << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1.5;
  mesh.tets.resize(2, 4);
  mesh.tets << 0, 1, 2, 3, 1, 2, 3, 4;
  io::write_tet_mesh_vtk(dir / "tets.vtk", mesh);
  const TetMesh back = io::read_tet_mesh_vtk(dir / "tets.vtk");
  EXPECT_TRUE(back.positions == mesh.positions);
  EXPECT_TRUE(back.tets == mesh.tets);
  std::filesystem::resize_file(dir / "tets.vtk", std::filesystem::file_size(dir / "tets.vtk") - 40);
  EXPECT_TRUE(test::throws_error_containing([&] { (void)io::read_tet_mesh_vtk(dir / "tets.vtk"); }, "tets.vtk"));
  dir.write("text.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n");
  EXPECT_TRUE(test::throws_error_containing([&] { (void)io::read_tet_mesh_vtk(dir / "text.vtk"); }, "not a binary unstructured grid"));
}

}  // namespace
}  // namespace goo
