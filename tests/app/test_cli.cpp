// The goo command, run as a user runs it.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <fmt/format.h>

#include "core/primitives.h"
#include "core/surface_check.h"
#include "io/surface_mesh_io.h"
#include "tests/common/test_common.h"
#include "tests/app/run_goo.h"
#include "tests/io/bad_mesh_fixtures.h"

namespace goo {
namespace {

using ::testing::HasSubstr;

TEST(GooCommand, VersionAndHelp) {
  const CommandResult version = goo("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_THAT(version.out, HasSubstr("goo 0."));
  const CommandResult help = goo("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_THAT(help.out, HasSubstr("info"));
}

TEST(GooCommand, UnknownCommandOrOptionIsAUsageError) {
  EXPECT_EQ(goo("frobnicate").exit_code, 2);
  EXPECT_EQ(goo("info").exit_code, 2);  // MESH is required
  EXPECT_EQ(goo("--no-such-flag").exit_code, 2);
}

TEST(GooInfo, ReportsAValidMesh) {
  test::TempDir dir;
  const TriangleMesh sphere = make_sphere(2.0, 32);  // 32 around, 16 bands
  io::write_surface_mesh(dir / "sphere.ply", sphere);
  const CommandResult run = goo("info '" + (dir / "sphere.ply").string() + "'");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.out, HasSubstr("triangles      960\n"));  // 2·32 at the poles + 2·32·14
  EXPECT_THAT(run.out, HasSubstr("closed         yes"));
  EXPECT_THAT(run.out, HasSubstr("manifold       yes"));
  EXPECT_THAT(run.out, HasSubstr("euler char.    2 (genus 0)"));
  EXPECT_THAT(run.out, HasSubstr(fmt::format("volume         {:.10g}\n", analyze_surface(sphere).volume)));
  EXPECT_TRUE(run.err.empty()) << run.err;
}

TEST(GooInfo, JsonReportParsesAndCarriesTheMeasures) {
  test::TempDir dir;
  io::write_surface_mesh(dir / "box.obj", make_box({1.0, 2.0, 3.0}, 2));
  const CommandResult run = goo("info --json '" + (dir / "box.obj").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_NEAR(j["volume"].get<double>(), 6.0, 1e-14);
  EXPECT_NEAR(j["area"].get<double>(), 22.0, 1e-13);
  EXPECT_EQ(j["euler_characteristic"].get<int>(), 2);
  EXPECT_TRUE(j["closed"].get<bool>());
  EXPECT_TRUE(j["simulable"].get<bool>());
}

TEST(GooCommand, FileNamesThatAreNotUtf8AreReportedNotFatal) {
  // Linux file names are bytes; JSON is UTF-8: such bytes become U+FFFD in
  // goo info --json and in summary.json (the JSON writer threw: exit 1).
  test::TempDir dir;
  const std::string name = "box\xff\xfe.off";
  io::write_surface_mesh(dir / name, make_box({1.0, 2.0, 3.0}, 2));
  const CommandResult info = goo("info --json '" + (dir / name).string() + "'");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_THAT(nlohmann::json::parse(info.out)["file"].get<std::string>(), ::testing::HasSubstr("box\uFFFD\uFFFD.off"));
  const std::string scene = "s\xff.json";
  dir.write(scene, R"({"gravity": [0, 0, 0], "objects": [{"primitive": {"type": "box", "size": [0.1, 0.1, 0.1]},
                        "material": "jiggly_gelatin", "lattice_spacing": 0.05}], "output": {"frames": 1}})");
  const CommandResult run = goo("run '" + (dir / scene).string() + "' --quiet --out '" + (dir / "out").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_THAT(summary["scene"].get<std::string>(), ::testing::HasSubstr("s\uFFFD.json"));
}

class GooInfoBadInput : public ::testing::TestWithParam<test::BadMesh> {};

TEST_P(GooInfoBadInput, ExitsTwoWithTheErrorOnStderr) {
  const test::BadMesh& bad = GetParam();
  test::TempDir dir;
  const auto path = dir.write(bad.name, bad.contents);
  const CommandResult run = goo("info '" + path.string() + "'");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.err, HasSubstr("goo: error: " + path.string() + ": "));
  EXPECT_THAT(run.err, HasSubstr(bad.expected));
}

INSTANTIATE_TEST_SUITE_P(Fixtures, GooInfoBadInput, ::testing::ValuesIn(test::bad_meshes()),
                         [](const auto& param_info) {
                           std::string name = param_info.param.name;
                           for (char& c : name)
                             if (c == '.') c = '_';
                           return name;
                         });

TEST(GooInfo, OpenMeshIsDescribedThenRefused) {
  test::TempDir dir;
  const auto path =
      dir.write("open.off", test::off_tetrahedron(test::kTetVertices, "3 0 2 1\n3 0 1 3\n3 0 3 2\n", "OFF\n4 3 0\n"));
  const CommandResult run = goo("info '" + path.string() + "'");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_THAT(run.out, HasSubstr("closed         no (3 boundary edges)"));
}

TEST(GooInfo, BunnyIsAClosedManifold) {
  const auto path = test::asset("bunny00.off");
  ASSERT_TRUE(std::filesystem::exists(path)) << "run scripts/fetch-assets";
  const CommandResult run = goo("info --json '" + path.string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_TRUE(j["closed"].get<bool>());
  EXPECT_TRUE(j["manifold"].get<bool>());
  EXPECT_GT(j["volume"].get<double>(), 0.0);
}

}  // namespace
}  // namespace goo
