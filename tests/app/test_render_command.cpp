// goo render and goo run --preview end to end: pictures of a real run, each
// body's triangles labelled in the frames, refusal of bad options.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "io/surface_mesh_io.h"
#include "render/image.h"
#include "tests/app/run_goo.h"

namespace goo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string quoted(const fs::path& p) { return fmt::format("'{}'", p.string()); }

render::Image read_png(const fs::path& path) {
  const std::string bytes = slurp(path);
  return render::decode_png(std::vector<std::uint8_t>(bytes.begin(), bytes.end()), path.string());
}

/// Two cubes of two materials under a press, with the tet mesh in the output.
const char* kTwoBodies = R"({
  "ground": {"height": 0.0, "friction": 0.4},
  "obstacles": [{"name": "press", "shape": {"type": "box", "size": [0.4, 0.2, 0.05]},
                 "motion": [{"time": 0, "translate": [0, 0, 0.3]}, {"time": 1, "translate": [0, 0, 0.2]}]}],
  "objects": [
    {"name": "jelly", "primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 3},
     "transform": {"translate": [-0.08, 0, 0.06]}, "material": "gooey_jelly", "lattice_spacing": 0.05},
    {"name": "brick", "primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 3},
     "transform": {"translate": [0.08, 0, 0.06]}, "material": "rigid_brick", "lattice_spacing": 0.05}],
  "output": {"fps": 24, "frames": 2, "tet_mesh": true}
})";

class GooRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    dir_->write("two.json", kTwoBodies);
    preview_ = new CommandResult(goo(fmt::format("run {} --out {} --preview --quiet", quoted(*dir_ / "two.json"),
                                                 quoted(*dir_ / "run"))));
  }
  static void TearDownTestSuite() {
    delete preview_;
    delete dir_;
  }
  static fs::path run() { return *dir_ / "run"; }
  static test::TempDir* dir_;
  static CommandResult* preview_;
};
test::TempDir* GooRender::dir_ = nullptr;
CommandResult* GooRender::preview_ = nullptr;

TEST_F(GooRender, PreviewWritesTheContactSheetAndPrintsItsPath) {
  ASSERT_EQ(preview_->exit_code, 0) << preview_->err;
  const fs::path sheet = run() / "render" / "sheet.png";
  EXPECT_THAT(preview_->out, HasSubstr("contact sheet: " + sheet.string()));
  const render::Image image = read_png(sheet);
  // Three frames (0, 1, 2) of 480×360 on a 2×2 grid with a title.
  EXPECT_GT(image.width, 2 * 480);
  EXPECT_GT(image.height, 2 * 360);
}

TEST_F(GooRender, FramesLabelEachTriangleWithItsBody) {
  const io::FrameSurface frame = io::read_frame_surface(run() / "frames" / "frame_00002.ply");
  ASSERT_EQ(frame.face_body.size(), static_cast<std::size_t>(frame.mesh.num_triangles()));
  // Body 0 (the jelly, at x < 0) and body 1 (the brick, at x > 0).
  int counts[2] = {0, 0};
  for (Index t = 0; t < frame.mesh.num_triangles(); ++t) {
    const int body = frame.face_body[static_cast<std::size_t>(t)];
    ASSERT_TRUE(body == 0 || body == 1);
    ++counts[body];
    const double x = frame.mesh.vertices(frame.mesh.triangles(t, 0), 0);
    EXPECT_EQ(body == 0, x < 0.0);
  }
  EXPECT_GT(counts[0], 0);
  EXPECT_GT(counts[1], 0);
  // run.h5 holds the same labels, a cell field of the XDMF sidecar (h5dump, an independent reader).
  EXPECT_THAT(slurp(run() / "run.xdmf"), HasSubstr("<Attribute Name=\"body\""));
  const fs::path dump = *dir_ / "bodies.txt";
  ASSERT_EQ(std::system(fmt::format("h5dump -d /frames/00002/surface_bodies -y -w 0 {} > {}", quoted(run() / "run.h5"),
                                    quoted(dump))
                            .c_str()),
            0);
  const std::string text = slurp(dump);
  EXPECT_THAT(text, HasSubstr(fmt::format("( {}, 1 )", frame.mesh.num_triangles())));
  // The generic reader (CGAL's PLY) still reads the file.
  EXPECT_EQ(io::read_surface_mesh(run() / "frames" / "frame_00002.ply").num_triangles(), frame.mesh.num_triangles());
}

TEST_F(GooRender, EachFrameAndATurntable) {
  const fs::path out = *dir_ / "each";
  const CommandResult each = goo(fmt::format("render {} --each --size 160x120 --wireframe --out {}", quoted(run()), quoted(out)));
  ASSERT_EQ(each.exit_code, 0) << each.err;
  for (int f = 0; f <= 2; ++f) {
    const render::Image image = read_png(out / fmt::format("frame_{:05d}.png", f));
    EXPECT_EQ(image.width, 160);
    EXPECT_EQ(image.height, 120);
  }
  const CommandResult turn = goo(fmt::format("render {} --turntable 1 --views 4 --size 64x48 --quiet", quoted(run())));
  ASSERT_EQ(turn.exit_code, 0) << turn.err;
  std::vector<render::Image> views;
  for (int k = 0; k < 4; ++k) views.push_back(read_png(run() / "render/turntable_00001" / fmt::format("view_{:03d}.png", k)));
  EXPECT_FALSE(views[0].rgb == views[1].rgb);  // it turns
  EXPECT_FALSE(fs::exists(run() / "render/turntable_00001/view_004.png"));
}

TEST_F(GooRender, WithoutFfmpegTheVideoIsRefusedClearlyAndThePicturesStay) {
  const fs::path out = *dir_ / "video";
  const CommandResult r =
      goo(fmt::format("render {} --mp4 --size 64x48 --out {}", quoted(run()), quoted(out)), "PATH=/nonexistent");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("ffmpeg is not installed"));
  EXPECT_TRUE(fs::exists(out / "frame_00002.png"));
  EXPECT_FALSE(fs::exists(out / "frames.mp4"));
}

TEST_F(GooRender, BadOptionsExitTwoNamingWhatIsWrong) {
  test::TempDir empty;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {fmt::format("render {}", quoted(empty / "missing")), "not a run folder"},
      {fmt::format("render {}", quoted(empty.path())), "holds no frames"},
      {fmt::format("render {} --size 10x10", quoted(run())), "--size"},
      {fmt::format("render {} --size big", quoted(run())), "--size"},
      {fmt::format("render {} --turntable 9", quoted(run())), "no such frame"},
      {fmt::format("render {} --each --turntable 1", quoted(run())), "choose one"},
      {fmt::format("render {} --first 5", quoted(run())), "no frame between"},
      {fmt::format("render {} --elevation 90", quoted(run())), "--elevation"},
      {fmt::format("render {} --scene {}", quoted(run()), quoted(empty / "none.json")), "none.json"},
  };
  for (const auto& [arguments, message] : cases) {
    const CommandResult r = goo(arguments);
    EXPECT_EQ(r.exit_code, 2) << arguments;
    EXPECT_THAT(r.err, HasSubstr(message)) << arguments;
  }
  // A copy of the frames without the summary that names the scene.
  fs::create_directories(empty / "copy");
  fs::copy(run() / "frames", empty / "copy" / "frames");
  const CommandResult r = goo(fmt::format("render {}", quoted(empty / "copy")));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--scene"));
  const CommandResult given = goo(fmt::format("render {} --scene {} --sheet 2 --quiet", quoted(empty / "copy"),
                                              quoted(*dir_ / "two.json")));
  EXPECT_EQ(given.exit_code, 0) << given.err;
}

TEST_F(GooRender, WireframeNeedsTheTetMesh) {
  test::TempDir copy;
  fs::create_directories(copy / "frames");
  fs::copy(run() / "frames" / "frame_00000.ply", copy / "frames" / "frame_00000.ply");
  const CommandResult r =
      goo(fmt::format("render {} --scene {} --wireframe", quoted(copy.path()), quoted(*dir_ / "two.json")));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("tets_00000.vtk"));
}

}  // namespace
}  // namespace goo
