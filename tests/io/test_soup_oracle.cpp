// goo reads OFF, PLY and STL itself (io/format_diagnosis.cpp); CGAL's
// readers are the oracle: on the test models and on files of every variant
// goo accepts (ASCII and binary PLY of both byte orders, float and double
// coordinates, extra properties and lists, index lists of any name CGAL
// takes; ASCII and binary STL with shared corners; OFF with comments,
// colours and counts on the header line), both give the same points, bit
// for bit, and the same polygons.
#include <CGAL/IO/OFF.h>
#include <CGAL/IO/PLY.h>
#include <CGAL/IO/STL.h>
#include <CGAL/Simple_cartesian.h>
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "core/primitives.h"
#include "io/detail/polygon_soup_readers.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

using io::detail::PolygonSoup;

PolygonSoup read_with_cgal(const std::filesystem::path& path, io::MeshFormat format) {
  using Point = CGAL::Simple_cartesian<double>::Point_3;
  std::vector<Point> points;
  PolygonSoup soup;
  const auto quiet = CGAL::parameters::verbose(false);
  bool ok = false;
  if (format == io::MeshFormat::off) ok = CGAL::IO::read_OFF(path.string(), points, soup.polygons, quiet);
  if (format == io::MeshFormat::ply) ok = CGAL::IO::read_PLY(path.string(), points, soup.polygons, quiet);
  if (format == io::MeshFormat::stl) {
    std::vector<std::array<std::size_t, 3>> triangles;
    ok = CGAL::IO::read_STL(path.string(), points, triangles, quiet);
    for (const auto& t : triangles) soup.polygons.push_back({t[0], t[1], t[2]});
  }
  EXPECT_TRUE(ok) << path;
  for (const Point& p : points) soup.points.push_back({p.x(), p.y(), p.z()});
  return soup;
}

void expect_same_soup(const std::filesystem::path& path) {
  SCOPED_TRACE(path.string());
  const io::MeshFormat format = io::mesh_format_of(path);
  PolygonSoup ours;
  ASSERT_EQ(io::detail::read_polygon_soup(path, format, ours), "");
  const PolygonSoup oracle = read_with_cgal(path, format);
  ASSERT_EQ(ours.points.size(), oracle.points.size());
  for (std::size_t v = 0; v < ours.points.size(); ++v)
    for (std::size_t k = 0; k < 3; ++k)
      ASSERT_EQ(std::bit_cast<std::uint64_t>(ours.points[v][k]), std::bit_cast<std::uint64_t>(oracle.points[v][k]))
          << "vertex " << v << " coordinate " << k << ": " << ours.points[v][k] << " against " << oracle.points[v][k];
  EXPECT_EQ(ours.polygons, oracle.polygons);
  EXPECT_FALSE(ours.polygons.empty());
}

/// Little- or big-endian bytes of a value.
template <class T>
std::string bytes(T value, bool big_endian = false) {
  std::string out(sizeof(T), '\0');
  std::memcpy(out.data(), &value, sizeof(T));
  if (big_endian) std::reverse(out.begin(), out.end());
  return out;
}

/// Coordinates that round differently as float and double, a negative
/// zero, large and tiny magnitudes.
const double kCoordinates[] = {0.1, -0.0, 1.0 / 3.0, 123456.789, 1e-7, -2.5, 0.3, 7.0, 1e10, -1e-30, 0.7, 5.5};

/// A tetrahedron (and a quad on its first four points) whose coordinates
/// come from kCoordinates.
std::vector<std::array<double, 3>> points() {
  std::vector<std::array<double, 3>> out;
  for (int v = 0; v < 4; ++v) out.push_back({kCoordinates[3 * v], kCoordinates[3 * v + 1], kCoordinates[3 * v + 2]});
  return out;
}
const std::vector<std::vector<int>> kFaces = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}, {0, 1, 2, 3}};

std::string ply_header(const std::string& format, const std::string& coordinate, const std::string& list,
                       const std::string& list_name) {
  return fmt::format(
      "ply\nformat {0} 1.0\ncomment made by a test\nelement vertex 4\nproperty {1} x\nproperty {1} y\n"
      "property uchar red\nproperty {1} z\nelement face 5\nproperty list uchar int texture\nproperty list {2} {3}\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n",
      format, coordinate, list, list_name);
}

TEST(SoupOracle, TheTestModels) {
  for (const char* model : {"bunny00.off", "armadillo.off", "hand.off", "elephant.off"}) expect_same_soup(test::asset(model));
}

TEST(SoupOracle, AsciiPly) {
  test::TempDir dir;
  for (const std::string coordinate : {"float", "double"}) {
    std::string text = ply_header("ascii", coordinate, "uchar int", "vertex_indices");
    for (const auto& p : points()) text += fmt::format("{:.17g} {:.17g} 200 {:.17g}\n", p[0], p[1], p[2]);
    for (const auto& f : kFaces) {
      text += fmt::format("2 7 8 {} {}\n", f.size(), fmt::join(f, " "));
    }
    text += "0 1\n";
    expect_same_soup(dir.write("ascii_" + coordinate + ".ply", text));
  }
}

TEST(SoupOracle, BinaryPlyOfBothByteOrders) {
  test::TempDir dir;
  for (const bool big : {false, true}) {
    for (const std::string coordinate : {"float", "double"}) {
      for (const std::string name : {"vertex_indices", "vertex_index"}) {
        const std::string list = big ? "int uint" : "uchar int";
        std::string data = ply_header(big ? "binary_big_endian" : "binary_little_endian", coordinate, list, name);
        for (const auto& p : points()) {
          auto put = [&](double v) {
            data += coordinate == "float" ? bytes(static_cast<float>(v), big) : bytes(v, big);
          };
          put(p[0]), put(p[1]), data += bytes(std::uint8_t{200}), put(p[2]);
        }
        for (const auto& f : kFaces) {
          data += bytes(std::uint8_t{1}) + bytes(std::int32_t{9}, big);
          data += big ? bytes(static_cast<std::int32_t>(f.size()), big) : bytes(static_cast<std::uint8_t>(f.size()));
          for (int id : f) data += big ? bytes(static_cast<std::uint32_t>(id), big) : bytes(std::int32_t{id}, big);
        }
        data += bytes(std::int32_t{0}, big) + bytes(std::int32_t{1}, big);
        expect_same_soup(dir.write(fmt::format("binary_{}_{}_{}.ply", big ? "be" : "le", coordinate, name), data));
      }
    }
  }
}

TEST(SoupOracle, StlCornersSharedAsCgalSharesThem) {
  test::TempDir dir;
  const TriangleMesh box = make_box(Eigen::Vector3d(0.3, 0.1, 0.7), 2);
  std::string text = "solid box\n", binary(80, 'b');
  binary += bytes(static_cast<std::uint32_t>(box.triangles.rows() + 1));
  auto facet = [&](const std::array<Eigen::Vector3d, 3>& c) {
    text += "  facet normal 0 0 1\n    outer loop\n";
    binary += bytes(0.0F) + bytes(0.0F) + bytes(1.0F);
    for (const auto& p : c) {
      text += fmt::format("      vertex {:.17g} {:.17g} {:.17g}\n", p.x(), p.y(), p.z());
      for (int k = 0; k < 3; ++k) binary += bytes(static_cast<float>(p[k]));
    }
    text += "    endloop\n  endfacet\n";
    binary += std::string(2, '\0');
  };
  for (Index t = 0; t < box.triangles.rows(); ++t) {
    std::array<Eigen::Vector3d, 3> c;
    for (int k = 0; k < 3; ++k) c[static_cast<std::size_t>(k)] = box.vertices.row(box.triangles(t, k)).transpose();
    facet(c);
  }
  facet({Eigen::Vector3d(-0.0, 0.1, 0.0), Eigen::Vector3d(0.0, 0.1, 0.0), Eigen::Vector3d(1e-3, 0.1, -0.0)});
  text += "endsolid box\n";
  expect_same_soup(dir.write("box_ascii.stl", text));
  expect_same_soup(dir.write("box_binary.stl", binary));
}

TEST(SoupOracle, OffWithCommentsColoursAndCountsOnTheHeaderLine) {
  test::TempDir dir;
  std::string plain = "OFF\n# a comment\n4 5 0\n", colour = "COFF 4 5 0\n";
  for (const auto& p : points()) {
    plain += fmt::format("{:.17g} {:.17g} {:.17g}  # a vertex\n", p[0], p[1], p[2]);
    colour += fmt::format("{:.17g} {:.17g} {:.17g} 0.5 0.5 0.5 1\n", p[0], p[1], p[2]);
  }
  for (const auto& f : kFaces) {
    const std::string line = fmt::format("{} {}", f.size(), fmt::join(f, " "));
    plain += fmt::format("{}\n", line);
    colour += fmt::format("{} 255 0 0\n", line);
  }
  expect_same_soup(dir.write("plain.off", plain));
  expect_same_soup(dir.write("colour.off", colour));
}

}  // namespace
}  // namespace goo
