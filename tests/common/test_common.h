#pragma once
// Helpers shared by goo's tests.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <string_view>

#include "core/material.h"
#include "core/state_record.h"
#include "core/tet_mesh.h"
#include "core/triangle_mesh.h"

#include "core/error.h"

namespace goo::test {

/// The elastic models every model-wise test runs over.
inline constexpr ElasticModel kModels[] = {ElasticModel::neo_hookean, ElasticModel::fixed_corotated,
                                           ElasticModel::stable_neo_hookean};

/// Two surfaces as one mesh: b's vertices after a's, its triangles
/// renumbered to match.
inline TriangleMesh joined(const TriangleMesh& a, const TriangleMesh& b) {
  TriangleMesh both;
  both.vertices.resize(a.num_vertices() + b.num_vertices(), 3);
  both.vertices << a.vertices, b.vertices;
  both.triangles.resize(a.num_triangles() + b.num_triangles(), 3);
  both.triangles << a.triangles, (b.triangles.array() + a.num_vertices()).matrix();
  return both;
}

/// A material of the given model and constants (viscosity in Pa·s).
inline Material material(ElasticModel model, double E, double nu, double viscosity = 0.0) {
  Material m;
  m.model = model;
  m.youngs_modulus = E;
  m.poisson_ratio = nu;
  m.viscosity = viscosity;
  return m;
}

/// Expects two saved states to hold the same arrays, bit for bit (a
/// resumed or multi-threaded run against a straight or serial one).
inline void expect_same_records(const StateRecord& a, const StateRecord& b) {
  ASSERT_EQ(a.arrays().size(), b.arrays().size());
  for (const auto& [name, array] : a.arrays()) {
    ASSERT_TRUE(b.arrays().contains(name)) << name;
    EXPECT_TRUE(array == b.arrays().at(name)) << name << " differs";
  }
}

/// One tetrahedron: the origin and the three points `size` along each axis.
inline TetMesh corner_tetrahedron(double size = 1.0) {
  TetMesh mesh;
  mesh.positions.resize(4, 3);
  mesh.positions << 0, 0, 0, size, 0, 0, 0, size, 0, 0, 0, size;
  mesh.tets.resize(1, 4);
  mesh.tets << 0, 1, 2, 3;
  return mesh;
}

/// Expects every entry of `actual` within `tolerance` of `expected`, and
/// names the first index that is not (libigl's test_common.h does the same).
template <typename A, typename B>
::testing::AssertionResult matrices_near(const Eigen::MatrixBase<A>& actual, const Eigen::MatrixBase<B>& expected,
                                         double tolerance) {
  if (actual.rows() != expected.rows() || actual.cols() != expected.cols()) {
    return ::testing::AssertionFailure() << "shape " << actual.rows() << "x" << actual.cols()
                                         << " != " << expected.rows() << "x" << expected.cols();
  }
  for (Eigen::Index i = 0; i < actual.rows(); ++i)
    for (Eigen::Index j = 0; j < actual.cols(); ++j) {
      const double a = static_cast<double>(actual(i, j)), e = static_cast<double>(expected(i, j));
      if (!(std::abs(a - e) <= tolerance)) {
        return ::testing::AssertionFailure() << "at (" << i << ", " << j << "): " << a << " vs " << e << " (difference "
                                             << a - e << ", tolerance " << tolerance << ")";
      }
    }
  return ::testing::AssertionSuccess();
}

/// Runs `call` and expects a goo::Error whose message contains `expected`
/// (an exception alone passes for the wrong reason).
template <typename Call>
::testing::AssertionResult throws_error_containing(Call&& call, std::string_view expected) {
  try {
    call();
  } catch (const goo::Error& e) {
    if (std::string_view(e.what()).find(expected) != std::string_view::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "error \"" << e.what() << "\" does not mention \"" << expected << "\"";
  }
  return ::testing::AssertionFailure() << "no goo::Error thrown (expected one mentioning \"" << expected << "\")";
}

/// A fresh folder under the system temporary folder, removed at destruction.
class TempDir {
 public:
  TempDir() {
    std::random_device device;
    path_ =
        std::filesystem::temp_directory_path() / ("goo_test_" + std::to_string(device()) + std::to_string(device()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::filesystem::path operator/(std::string_view name) const { return path_ / name; }

  /// Writes `bytes` to a file of this folder and returns its path.
  std::filesystem::path write(std::string_view name, std::string_view bytes) const {
    const std::filesystem::path file = path_ / name;
    std::ofstream out(file, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return file;
  }

 private:
  std::filesystem::path path_;
};

/// The real models extracted by scripts/fetch-assets.
inline std::filesystem::path asset(std::string_view name) {
  return std::filesystem::path(GOO_ASSETS_DIR) / name;
}

}  // namespace goo::test
