#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "io/surface_mesh_io.h"
#include "tests/common/test_common.h"
#include "tests/io/bad_mesh_fixtures.h"

namespace goo {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

class BadInput : public ::testing::TestWithParam<test::BadMesh> {};

TEST_P(BadInput, RaisesAnErrorNamingTheFileAndTheProblem) {
  const test::BadMesh& bad = GetParam();
  test::TempDir dir;
  const auto path = dir.write(bad.name, bad.contents);
  try {
    io::read_surface_mesh(path);
    FAIL() << bad.name << " was accepted";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), StartsWith(path.string() + ": "));
    EXPECT_THAT(e.what(), HasSubstr(bad.expected));
  }
}

INSTANTIATE_TEST_SUITE_P(Fixtures, BadInput, ::testing::ValuesIn(test::bad_meshes()), [](const auto& param_info) {
  std::string name = param_info.param.name;
  for (char& c : name)
    if (c == '.') c = '_';
  return name;
});

TEST(BadInput, MissingFileAndFolderAreNamed) {
  test::TempDir dir;
  EXPECT_THROW(
      {
        try {
          io::read_surface_mesh(dir / "missing.off");
        } catch (const Error& e) {
          EXPECT_THAT(e.what(), HasSubstr("missing.off: cannot open"));
          throw;
        }
      },
      Error);
  std::filesystem::create_directory(dir / "folder.off");
  EXPECT_THROW(io::read_surface_mesh(dir / "folder.off"), Error);
}

TEST(BadInput, ValidationCanBeDeferredToTheCaller) {
  test::TempDir dir;
  const auto path =
      dir.write("open.off", test::off_tetrahedron(test::kTetVertices, "3 0 2 1\n3 0 1 3\n3 0 3 2\n", "OFF\n4 3 0\n"));
  io::ReadOptions options;
  options.validate = false;
  EXPECT_EQ(io::read_surface_mesh(path, options).num_triangles(), 3);
}

}  // namespace
}  // namespace goo
