// goo run when its output cannot be written: a file-size limit or a full
// disk ends the run with exit code 4, the files written before are kept
// whole, no temporary file is left, and summary.json says why; a damaged
// run file is never replaced on resume.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <fmt/format.h>

#include <algorithm>
#include <nlohmann/json.hpp>

#include "tests/app/run_goo.h"

namespace goo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string quoted(const fs::path& p) { return fmt::format("'{}'", p.string()); }

/// run_goo.h's dropped cube to frame 2, its checkpoint there: it re-meshes,
/// so frames 1 and 2 are finer than frame 0.
const std::string kDropToFrame2 = [] {
  std::string scene = kDrop;
  scene.replace(scene.find("\"frames\": 4"), 11, "\"frames\": 2");
  return scene;
}();

std::uintmax_t size_of(const fs::path& p) { return fs::file_size(p); }

/// Every file under `folder` whose name says it is a temporary file.
std::vector<std::string> temporaries(const fs::path& folder) {
  std::vector<std::string> found;
  for (const auto& entry : fs::recursive_directory_iterator(folder))
    if (entry.path().filename().string().find(".tmp-") != std::string::npos) found.push_back(entry.path().string());
  return found;
}

/// goo with its files limited to `bytes` each (RLIMIT_FSIZE: a write past it fails with EFBIG).
CommandResult goo_limited(std::uintmax_t bytes, const std::string& arguments) {
  return goo(arguments, fmt::format("prlimit --fsize={}", bytes));
}

TEST(GooRunOutput, ACheckpointThatCannotBeWrittenEndsTheRunWithExitFourKeepingTheFrames) {
  test::TempDir dir;
  dir.write("drop.json", kDropToFrame2);
  ASSERT_EQ(goo(fmt::format("run {} --out {} --quiet", quoted(dir / "drop.json"), quoted(dir / "free"))).exit_code, 0);
  // A limit between every other file and the checkpoint: only the checkpoint fails.
  const std::uintmax_t checkpoint = size_of(dir / "free/checkpoints/frame_00002.h5");
  std::uintmax_t others = 0;
  for (const char* f : {"frames/frame_00000.ply", "frames/frame_00001.ply", "frames/frame_00002.ply", "run.h5",
                        "run.xdmf", "summary.json"})
    others = std::max(others, size_of(dir / "free" / f));
  ASSERT_GT(checkpoint, 2 * others);
  const CommandResult run =
      goo_limited((checkpoint + others) / 2, fmt::format("run {} --out {} --quiet", quoted(dir / "drop.json"), quoted(dir / "out")));
  // Exit 4, not a crash in HDF5 at exit (the file it could not flush).
  EXPECT_EQ(run.exit_code, 4) << run.err;
  EXPECT_THAT(run.err, HasSubstr("checkpoints/frame_00002.h5"));
  EXPECT_THAT(run.err, HasSubstr("File too large"));
  // Every frame was written whole and is the run's own; no checkpoint, no temporary file.
  for (const char* f : {"frames/frame_00000.ply", "frames/frame_00001.ply", "frames/frame_00002.ply"})
    EXPECT_EQ(slurp(dir / "out" / f), slurp(dir / "free" / f)) << f;
  EXPECT_TRUE(fs::is_empty(dir / "out/checkpoints"));
  EXPECT_THAT(temporaries(dir / "out"), ::testing::IsEmpty());
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_EQ(summary["status"], "failed");
  EXPECT_THAT(summary["failure"].get<std::string>(), HasSubstr("checkpoints/frame_00002.h5"));
  EXPECT_EQ(summary["frames"], 2);
}

TEST(GooRunOutput, AFrameThatCannotBeWrittenEndsTheRunWithExitFourAndASummary) {
  test::TempDir dir;
  std::string scene = kDropToFrame2;
  scene.replace(scene.find("\"subdivisions\": 4"), 17, "\"subdivisions\": 12");  // frame 0 four times the summary
  dir.write("drop.json", scene);
  ASSERT_EQ(goo(fmt::format("run {} --frames 1 --out {} --quiet", quoted(dir / "drop.json"), quoted(dir / "free"))).exit_code, 0);
  const std::uintmax_t frame = size_of(dir / "free/frames/frame_00000.ply");
  const std::uintmax_t summary_size = size_of(dir / "free/summary.json");
  ASSERT_GT(frame, 2 * summary_size);
  const CommandResult run = goo_limited((frame + summary_size) / 2, fmt::format("run {} --frames 1 --out {} --quiet",
                                                                             quoted(dir / "drop.json"), quoted(dir / "out")));
  EXPECT_EQ(run.exit_code, 4) << run.err;
  EXPECT_THAT(run.err, HasSubstr("frames/frame_00000.ply"));
  EXPECT_FALSE(fs::exists(dir / "out/frames/frame_00000.ply"));
  EXPECT_FALSE(fs::exists(dir / "out/frames/frame_00001.ply"));  // the run stopped at the first failure
  EXPECT_THAT(temporaries(dir / "out"), ::testing::IsEmpty());
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_EQ(summary["status"], "failed");
  EXPECT_THAT(summary["failure"].get<std::string>(), HasSubstr("frame_00000.ply"));
  EXPECT_EQ(summary["steps"], 0);
}

/// A tmpfs of `kib` KiB at `path`, unmounted when it goes; unavailable
/// without the privilege to mount.
class SmallDisk {
 public:
  SmallDisk(const fs::path& path, int kib) : path_(path) {
    fs::create_directories(path);
    mounted_ = ::mount("tmpfs", path.c_str(), "tmpfs", 0, fmt::format("size={}k", kib).c_str()) == 0;
  }
  ~SmallDisk() {
    if (mounted_) ::umount(path_.c_str());
  }
  SmallDisk(const SmallDisk&) = delete;
  SmallDisk& operator=(const SmallDisk&) = delete;
  [[nodiscard]] bool mounted() const { return mounted_; }

 private:
  fs::path path_;
  bool mounted_ = false;
};

TEST(GooRunOutput, AFullDiskEndsTheRunWithExitFourWhereverItFills) {
  // The same promise when the disk itself fills, at every size from frame
  // 0 not fitting to the last checkpoint not fitting.
  test::TempDir dir;
  dir.write("drop.json", kDropToFrame2);
  for (const int kib : {8, 64, 160, 320}) {
    SCOPED_TRACE(fmt::format("{} KiB", kib));
    SmallDisk disk(dir / fmt::format("disk{}", kib), kib);
    if (!disk.mounted()) GTEST_SKIP() << "mounting a tmpfs needs privileges this test runs without";
    const fs::path out = dir / fmt::format("disk{}", kib) / "out";
    const CommandResult run = goo(fmt::format("run {} --out {} --quiet", quoted(dir / "drop.json"), quoted(out)));
    EXPECT_EQ(run.exit_code, 4) << run.err;
    EXPECT_THAT(run.err, HasSubstr("No space left on device"));
    EXPECT_THAT(temporaries(out), ::testing::IsEmpty());
    // What was written is whole: every frame file reads back.
    for (const auto& entry : fs::directory_iterator(out / "frames")) {
      const std::string bytes = slurp(entry.path());
      EXPECT_THAT(bytes, HasSubstr("end_header")) << entry.path();
    }
  }
}

TEST(GooRunOutput, ADamagedRunFileIsRefusedOnResumeAndKept) {
  test::TempDir dir;
  std::string scene = kDropToFrame2;
  scene.replace(scene.find("\"every_frames\": 2"), 17, "\"every_frames\": 1");
  dir.write("drop.json", scene);
  ASSERT_EQ(goo(fmt::format("run {} --out {} --quiet", quoted(dir / "drop.json"), quoted(dir / "a"))).exit_code, 0);
  std::string damaged = slurp(dir / "a/run.h5");
  ASSERT_GT(damaged.size(), 100u);
  std::fill_n(damaged.begin(), 64, 'x');  // the superblock gone
  dir.write("a/run.h5", damaged);
  const std::string frame2 = slurp(dir / "a/frames/frame_00002.ply");
  const CommandResult resumed = goo(fmt::format("run --resume {} --quiet", quoted(dir / "a/checkpoints/frame_00001.h5")));
  EXPECT_EQ(resumed.exit_code, 2) << resumed.err;
  EXPECT_THAT(resumed.err, HasSubstr("run.h5"));
  EXPECT_THAT(resumed.err, HasSubstr("move it away"));
  EXPECT_EQ(slurp(dir / "a/run.h5"), damaged);
  EXPECT_EQ(slurp(dir / "a/frames/frame_00002.ply"), frame2);
  // Moved away, the run goes on with a new run file, from the frame resumed.
  fs::rename(dir / "a/run.h5", dir / "damaged.h5");
  const CommandResult again = goo(fmt::format("run --resume {} --quiet", quoted(dir / "a/checkpoints/frame_00001.h5")));
  ASSERT_EQ(again.exit_code, 0) << again.err;
  EXPECT_EQ(slurp(dir / "a/frames/frame_00002.ply"), frame2);
  const std::string xdmf = slurp(dir / "a/run.xdmf");
  EXPECT_THAT(xdmf, HasSubstr("frame 00002"));
  EXPECT_THAT(xdmf, ::testing::Not(HasSubstr("frame 00001")));
}

TEST(GooRenderOutput, APictureThatCannotBeWrittenIsExitFourAndAFileForAFolderExitTwo) {
  test::TempDir dir;
  dir.write("drop.json", kDropToFrame2);
  ASSERT_EQ(goo(fmt::format("run {} --frames 1 --out {} --quiet", quoted(dir / "drop.json"), quoted(dir / "run"))).exit_code, 0);
  // A contact sheet is tens of kilobytes: 4 KiB holds none of it.
  const CommandResult limited = goo_limited(4096, fmt::format("render {} --quiet", quoted(dir / "run")));
  EXPECT_EQ(limited.exit_code, 4) << limited.err;
  EXPECT_THAT(limited.err, HasSubstr("sheet.png"));
  EXPECT_THAT(temporaries(dir / "run"), ::testing::IsEmpty());
  EXPECT_FALSE(fs::exists(dir / "run/render/sheet.png"));
  dir.write("a_file", "x");
  const CommandResult file = goo(fmt::format("render {} --out {} --quiet", quoted(dir / "run"), quoted(dir / "a_file")));
  EXPECT_EQ(file.exit_code, 2) << file.err;
  EXPECT_THAT(file.err, HasSubstr("a_file: --out must be a folder"));
}

}  // namespace
}  // namespace goo
