// goo run end to end, as a user runs it: frames, summary, checkpoints,
// exact restart (also after SIGINT), refusal of bad input, diagnosis of a
// numerical failure.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/info.h>

#include <chrono>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/primitives.h"
#include "io/checkpoint.h"
#include "io/surface_mesh_io.h"
#include "tests/app/run_goo.h"

namespace goo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string quoted(const fs::path& p) { return fmt::format("'{}'", p.string()); }

/// The arguments joined by spaces (fmt, not operator+: GCC 12 warns wrongly on long + chains).
std::string args(std::initializer_list<std::string> parts) { return fmt::format("{}", fmt::join(parts, " ")); }

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void expect_same_frames(const fs::path& a, const fs::path& b, int frames) {
  for (int f = 0; f <= frames; ++f) {
    const std::string name = fmt::format("frames/frame_{:05d}.ply", f);
    ASSERT_TRUE(fs::exists(a / name) && fs::exists(b / name)) << name;
    EXPECT_TRUE(bytes_of(a / name) == bytes_of(b / name)) << name << " differs";
  }
}

TEST(GooRun, FramesAndSummaryOfAFreelyMovingCubeAreExact) {
  // No gravity, no obstacle: a stress-free cube translates; every frame is
  // frame 0 moved by v t, and mass, volume and momentum do not change.
  test::TempDir dir;
  dir.write("free.json", R"({
    "gravity": [0, 0, 0],
    "objects": [{"primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 3},
                 "velocity": [0.1, 0.2, -0.3], "material": "jiggly_gelatin", "lattice_spacing": 0.05}],
    "output": {"fps": 24, "frames": 3, "formats": ["ply", "obj"]}
  })");
  const CommandResult run = goo(args({"run", quoted(dir / "free.json"), "--out", quoted(dir / "out"), "--quiet"}));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const TriangleMesh first = io::read_surface_mesh(dir / "out/frames/frame_00000.ply");
  EXPECT_EQ(first.triangles.rows(), 3 * 3 * 2 * 6);
  for (int f = 0; f <= 3; ++f) {
    const TriangleMesh frame = io::read_surface_mesh(dir / fmt::format("out/frames/frame_{:05d}.ply", f));
    const TriangleMesh obj = io::read_surface_mesh(dir / fmt::format("out/frames/frame_{:05d}.obj", f));
    EXPECT_TRUE(test::matrices_near(obj.vertices, frame.vertices, 1e-15));
    Points expected = first.vertices;
    expected.rowwise() += Eigen::RowVector3d(0.1, 0.2, -0.3) * (f / 24.0);
    EXPECT_TRUE(test::matrices_near(frame.vertices, expected, 1e-14)) << "frame " << f;
  }
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_EQ(summary["status"], "completed");
  EXPECT_EQ(summary["frames"], 3);
  EXPECT_NEAR(summary["initial_volume"].get<double>(), 1e-3, 1e-17);
  EXPECT_NEAR(summary["final_volume"].get<double>(), 1e-3, 1e-16);
  const double mass = summary["total_mass"];
  EXPECT_NEAR(mass, summary["initial_mass"].get<double>(), 1e-14 * mass);
  EXPECT_GE(mass, 1.0);  // ρ V = 1 kg, plus the clamp of light nodes (min_mass_fraction)
  EXPECT_LT(summary["momentum_drift"].get<double>(), 1e-14 * mass);
  for (const char* key : {"wall_seconds", "steps", "remeshes", "elements", "surface_triangles", "stages"})
    EXPECT_TRUE(summary.contains(key)) << key;
  // The peak memory is at least what the process holds, and the per-frame
  // profile adds up: one record a frame, whose steps and stages sum to the totals.
  EXPECT_GT(summary["peak_memory_bytes"].get<double>(), 1e6);
  const auto& per_frame = summary["per_frame"];
  ASSERT_EQ(per_frame.size(), 3u);
  long steps = 0;
  double integrate = 0.0;
  for (std::size_t k = 0; k < per_frame.size(); ++k) {
    EXPECT_EQ(per_frame[k]["frame"], k + 1);
    EXPECT_GT(per_frame[k]["elements"].get<long>(), 0);
    // The surface of every frame: the translated box, clean and whole.
    const auto& surface = per_frame[k]["surface"];
    EXPECT_EQ(surface["triangles"], 108);
    EXPECT_EQ(surface["edges"], 162);
    EXPECT_EQ(surface["self_intersecting_pairs"], 0);
    EXPECT_EQ(surface["creased_edges"], 0);  // the box's edges are at 90°, not past it
    EXPECT_NEAR(surface["volume"].get<double>(), 1e-3, 1e-16);
    EXPECT_NEAR(surface["area"].get<double>(), 0.06, 1e-15);
    EXPECT_EQ(surface["facing_sheets_triangles"], 0);  // a convex box faces nothing
    EXPECT_EQ(surface["facing_sheets_area"], 0.0);
    steps += per_frame[k]["steps"].get<long>();
    integrate += per_frame[k]["stages"]["integrate"].get<double>();
  }
  EXPECT_EQ(steps, summary["steps"].get<long>());
  EXPECT_EQ(summary["initial_surface"]["self_intersecting_pairs"], 0);
  EXPECT_NEAR(summary["initial_surface"]["volume"].get<double>(), 1e-3, 1e-17);
  // The stages of a step are laps inside it: none negative, and together no
  // more than the step's own time, measured around it.
  double stage_sum = 0.0;
  for (const auto& [name, seconds] : summary["integrate_stages"].items()) {
    EXPECT_GE(seconds.get<double>(), 0.0) << name;
    stage_sum += seconds.get<double>();
  }
  EXPECT_GT(stage_sum, 0.0);
  EXPECT_LE(stage_sum, summary["stages"]["integrate"].get<double>());
  EXPECT_NEAR(integrate, summary["stages"]["integrate"].get<double>(), 1e-9);
  EXPECT_TRUE(fs::exists(dir / "out/run.h5"));
  // Every dataset the XDMF sidecar points at is in run.h5 (h5dump, an independent reader).
  const std::string xdmf = slurp(dir / "out/run.xdmf");
  EXPECT_THAT(xdmf, HasSubstr("run.h5:/frames/00003/surface_vertices"));
  ASSERT_EQ(std::system(fmt::format("h5dump -n {} > {}", quoted(dir / "out/run.h5"), quoted(dir / "names")).c_str()), 0);
  const std::string names = slurp(dir / "names");
  int referenced = 0;
  for (std::size_t at = xdmf.find("run.h5:"); at != std::string::npos; at = xdmf.find("run.h5:", at + 1)) {
    const std::string path = xdmf.substr(at + 7, xdmf.find('<', at) - at - 7);
    EXPECT_THAT(names, HasSubstr("dataset    " + path)) << path;
    ++referenced;
  }
  EXPECT_EQ(referenced, 3 * 4);  // triangles, vertices and bodies of frames 0 to 3
  EXPECT_TRUE(fs::exists(dir / "out/checkpoints/frame_00003.h5"));  // the run's end
}

/// The uninterrupted run of kDrop that the restart tests compare with, run once.
class GooRestart : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new test::TempDir;
    dir_->write("drop.json", kDrop);
    ASSERT_EQ(goo(args({"run", quoted(*dir_ / "drop.json"), "--out", quoted(*dir_ / "a"), "--quiet"})).exit_code, 0);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static test::TempDir* dir_;
};
test::TempDir* GooRestart::dir_ = nullptr;

TEST_F(GooRestart, ResumingContinuesBitwiseIdentically) {
  const test::TempDir& dir = *dir_;
  const std::string scene = quoted(dir / "drop.json");
  ASSERT_EQ(goo(args({"run", scene, "--frames 2 --out", quoted(dir / "b"), "--quiet"})).exit_code, 0);
  const CommandResult resumed = goo(args({"run --resume", quoted(dir / "b/checkpoints/frame_00002.h5"), "--out", quoted(dir / "b"), "--quiet"}));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  expect_same_frames(dir / "a", dir / "b", 4);
  EXPECT_TRUE(bytes_of(dir / "a/checkpoints/frame_00004.h5") == bytes_of(dir / "b/checkpoints/frame_00004.h5"));
  const auto summary = nlohmann::json::parse(slurp(dir / "a/summary.json"));
  EXPECT_GT(summary["remeshes"].get<int>(), 0);  // the case exercises re-meshing
  // goo info describes the checkpoint.
  const CommandResult info = goo(args({"info", quoted(dir / "a/checkpoints/frame_00002.h5")}));
  EXPECT_EQ(info.exit_code, 0);
  EXPECT_THAT(info.out, HasSubstr("frame          2"));
  EXPECT_THAT(info.out, HasSubstr("cube:"));
}

// The element kernels' vector width (GOO_SIMD caps it) changes the speed and
// never the results: the run at every narrower width writes the frames and
// the last checkpoint of the widest one byte for byte.
TEST_F(GooRestart, EveryVectorWidthWritesTheSameFrames) {
  const test::TempDir& dir = *dir_;
  const auto widest = nlohmann::json::parse(slurp(dir / "a/summary.json"))["simd"].get<std::string>();
  EXPECT_THAT((std::vector<std::string>{"sse2", "avx2", "avx512"}), ::testing::Contains(widest));
  for (const std::string width : {"scalar", "sse2", "avx2"}) {
    if (width == widest) break;
    const fs::path out = dir / ("simd_" + width);
    const CommandResult run =
        goo(args({"run", quoted(dir / "drop.json"), "--out", quoted(out), "--quiet"}), "GOO_SIMD=" + width);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(nlohmann::json::parse(slurp(out / "summary.json"))["simd"], width);
    expect_same_frames(dir / "a", out, 4);
    EXPECT_TRUE(bytes_of(dir / "a/checkpoints/frame_00004.h5") == bytes_of(out / "checkpoints/frame_00004.h5"))
        << width;
  }
}

// A GOO_SIMD the run does not know is refused by name (exit 2) before
// anything is written, rather than ignored: a misspelt cap would run at
// full width and a speed comparison compare nothing.
TEST(GooRun, TheRunsPassesSplitBetweenTheThreadsAsked) {
  // --threads N runs the simulation in an arena of N slots: the passes
  // split evenly between the threads (static partitions) split in N, on
  // any machine; without it, every core. summary.json says which.
  test::TempDir dir;
  dir.write("cube.json", R"({
    "objects": [{"primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 2},
                 "transform": {"translate": [0, 0, 0.2]}, "material": "jiggly_gelatin", "lattice_spacing": 0.05}],
    "output": {"fps": 24, "frames": 1}
  })");
  for (const int threads : {0, 1, 3}) {
    SCOPED_TRACE(threads);
    const fs::path out = dir / fmt::format("out{}", threads);
    std::string command = args({"run", quoted(dir / "cube.json"), "--out", quoted(out), "--quiet"});
    if (threads > 0) command += fmt::format(" --threads {}", threads);
    const CommandResult run = goo(command);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto summary = nlohmann::json::parse(slurp(out / "summary.json"));
    EXPECT_EQ(summary["threads"], threads);
    EXPECT_EQ(summary["concurrency"], threads > 0 ? threads : static_cast<int>(tbb::info::default_concurrency()));
  }
}

TEST(GooRun, AnUnknownVectorWidthIsRefused) {
  test::TempDir dir;
  dir.write("drop.json", kDrop);
  for (const std::string width : {"avx3", "AVX2", "none"}) {
    SCOPED_TRACE(width);
    const CommandResult run =
        goo(args({"run", quoted(dir / "drop.json"), "--out", quoted(dir / "out"), "--quiet"}), "GOO_SIMD=" + width);
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_THAT(run.err, HasSubstr("GOO_SIMD"));
    EXPECT_THAT(run.err, HasSubstr("\"" + width + "\""));
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
  // An empty value is no cap (as unset), and the widest name is a cap too,
  // never above what the processor has.
  for (const std::string width : {"", "avx512"}) {
    const CommandResult run = goo(
        args({"run", quoted(dir / "drop.json"), "--frames 1 --overwrite --out", quoted(dir / "out"), "--quiet"}),
        "GOO_SIMD=" + width);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_THAT((std::vector<std::string>{"sse2", "avx2", "avx512"}),
                ::testing::Contains(nlohmann::json::parse(slurp(dir / "out/summary.json"))["simd"].get<std::string>()));
  }
}

// A body of a tetrahedral mesh (no lattice) under the static integrator,
// its gravity ramped: a run resumed from its frame-12 checkpoint writes
// frames 13 to 24 and the last checkpoint byte for byte as the run never
// stopped. (Such a body's checkpoint once held no material volume and its
// resume was refused.)
TEST(GooRun, AStaticTetrahedralMeshRunResumesBitwiseIdentically) {
  test::TempDir dir;
  const std::string scene = quoted(fs::path(GOO_SOURCE_DIR) / "scenes/cantilever_static.json");
  ASSERT_EQ(goo(args({"run", scene, "--frames 24 --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
  const CommandResult resumed = goo(
      args({"run --resume", quoted(dir / "a/checkpoints/frame_00012.h5"), "--frames 24 --out", quoted(dir / "b"), "--quiet"}));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  for (int f = 13; f <= 24; ++f) {
    const std::string name = fmt::format("frames/frame_{:05d}.ply", f);
    EXPECT_TRUE(bytes_of(dir / "a" / name) == bytes_of(dir / "b" / name)) << name << " differs";
  }
  EXPECT_TRUE(bytes_of(dir / "a/checkpoints/frame_00024.h5") == bytes_of(dir / "b/checkpoints/frame_00024.h5"));
  const auto summary = nlohmann::json::parse(slurp(dir / "a/summary.json"));
  EXPECT_EQ(summary["integrator"].get<std::string>(), "static");
  EXPECT_EQ(summary["steps"].get<int>(), 24);  // one equilibrium a frame
  // A checkpoint as goo wrote them before, with no material volume for a
  // tetrahedral-mesh body, resumes too, to the same frames.
  StateRecord old = io::read_checkpoint(dir / "a/checkpoints/frame_00012.h5");
  ASSERT_GT(old.real("bodies/0/rest_material_volume"), 0.0);
  old.put("bodies/0/rest_material_volume", 0.0);
  io::write_checkpoint(dir / "old.h5", old);
  const CommandResult from_old =
      goo(args({"run --resume", quoted(dir / "old.h5"), "--frames 24 --out", quoted(dir / "c"), "--quiet"}));
  ASSERT_EQ(from_old.exit_code, 0) << from_old.err;
  for (int f = 13; f <= 24; ++f) {
    const std::string name = fmt::format("frames/frame_{:05d}.ply", f);
    EXPECT_TRUE(bytes_of(dir / "a" / name) == bytes_of(dir / "c" / name)) << name << " differs";
  }
  EXPECT_TRUE(bytes_of(dir / "a/checkpoints/frame_00024.h5") == bytes_of(dir / "c/checkpoints/frame_00024.h5"));
}

TEST_F(GooRestart, TheSummaryRecordsTheDampingSolves) {
  // kDrop's splashing fluid is viscous: two damping solves a step, each
  // converged to cg_tolerance (1e-6 of its impulse), the frames' records
  // adding up to the run's.
  const auto summary = nlohmann::json::parse(slurp(*dir_ / "a/summary.json"));
  const auto& total = summary["damping_solve"];
  EXPECT_EQ(total["solves"].get<long>(), 2 * summary["steps"].get<long>());
  EXPECT_EQ(total["unconverged"].get<long>(), 0);
  EXPECT_LE(total["max_residual"].get<double>(), 1e-6);
  EXPECT_GT(total["cg_iterations"].get<long>(), 0);
  long solves = 0, iterations = 0;
  int most = 0;
  for (const auto& frame : summary["per_frame"]) {
    const auto& d = frame["damping_solve"];
    solves += d["solves"].get<long>();
    iterations += d["cg_iterations"].get<long>();
    most = std::max(most, d["max_cg_iterations"].get<int>());
    EXPECT_EQ(d["solves"].get<long>(), 2 * frame["steps"].get<long>());
  }
  EXPECT_EQ(solves, total["solves"].get<long>());
  EXPECT_EQ(iterations, total["cg_iterations"].get<long>());
  EXPECT_EQ(most, total["max_cg_iterations"].get<int>());
}

/// A `goo run SCENE --out OUT` in a child process, for the signal tests.
/// Its stderr and stdout go to `output_fd` (/dev/null when -1, with --quiet).
class GooChild {
 public:
  GooChild(const fs::path& scene, const fs::path& out, int output_fd = -1) : out_(out) {
    pid_ = fork();
    if (pid_ != 0) return;
    const std::string out_text = out.string(), scene_text = scene.string();
    if (output_fd < 0) {
      ::freopen("/dev/null", "w", stderr);
    } else {
      ::dup2(output_fd, STDERR_FILENO);
      ::dup2(output_fd, STDOUT_FILENO);
    }
    ::execl(GOO_EXECUTABLE, GOO_EXECUTABLE, "run", scene_text.c_str(), "--out", out_text.c_str(),
            output_fd < 0 ? "--quiet" : static_cast<char*>(nullptr), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  [[nodiscard]] bool started() const { return pid_ > 0; }
  /// Waits until frame 1 is out (then the run is in the middle of frame 2);
  /// false if the child ended first.
  bool wait_for_frame_one() {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(300);
    while (!fs::exists(out_ / "frames/frame_00001.ply") && std::chrono::steady_clock::now() < deadline) {
      if (::waitpid(pid_, &status_, WNOHANG) != 0) return ended_ = true, false;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    return true;
  }
  void signal(int number) const { ::kill(pid_, number); }
  /// The child's wait status once it has ended.
  int wait() {
    if (!ended_) ::waitpid(pid_, &status_, 0);
    ended_ = true;
    return status_;
  }

 private:
  fs::path out_;
  pid_t pid_ = -1;
  int status_ = 0;
  bool ended_ = false;
};

/// Waits for a signalled run: it must exit (not be killed) with 130 and say
/// so in its summary.
void expect_interrupted(GooChild& child, const fs::path& out) {
  const int status = child.wait();
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  ASSERT_EQ(WEXITSTATUS(status), 130) << "the run ended before the signal arrived";
  EXPECT_EQ(nlohmann::json::parse(slurp(out / "summary.json"))["status"], "interrupted");
}

TEST_F(GooRestart, AfterSigintInTheMiddleOfAFrameResumingIsBitwiseIdentical) {
  const test::TempDir& dir = *dir_;
  GooChild child(dir / "drop.json", dir / "c");
  ASSERT_TRUE(child.started());
  // Interrupt as soon as frame 1 is out: in the middle of frame 2.
  ASSERT_TRUE(child.wait_for_frame_one());
  child.signal(SIGINT);
  ASSERT_NO_FATAL_FAILURE(expect_interrupted(child, dir / "c"));
  EXPECT_FALSE(fs::exists(dir / "c/frames/frame_00004.ply"));
  // The frame under way was finished, and the last frame written has its checkpoint.
  auto last_in = [](const fs::path& folder) {
    fs::path last;
    for (const auto& entry : fs::directory_iterator(folder))
      if (last.empty() || entry.path() > last) last = entry.path();
    return last;
  };
  const fs::path last_frame = last_in(dir / "c/frames"), latest = last_in(dir / "c/checkpoints");
  ASSERT_FALSE(latest.empty());
  EXPECT_EQ(latest.filename(), fs::path(last_frame.filename()).replace_extension(".h5"));
  const CommandResult resumed = goo(args({"run --resume", quoted(latest), "--out", quoted(dir / "c"), "--quiet"}));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  expect_same_frames(dir / "a", dir / "c", 4);
  EXPECT_TRUE(bytes_of(dir / "a/checkpoints/frame_00004.h5") == bytes_of(dir / "c/checkpoints/frame_00004.h5"));
}

// A second signal stops at once: the frame under way is not finished, and
// only the checkpoints already written remain.
TEST_F(GooRestart, ASecondSignalStopsAtOnce) {
  const test::TempDir& dir = *dir_;
  GooChild child(dir / "drop.json", dir / "e");
  ASSERT_TRUE(child.started());
  ASSERT_TRUE(child.wait_for_frame_one());
  child.signal(SIGINT);
  child.signal(SIGTERM);  // another signal number: two SIGINTs in a row may merge into one
  ASSERT_NO_FATAL_FAILURE(expect_interrupted(child, dir / "e"));
  EXPECT_FALSE(fs::exists(dir / "e/frames/frame_00002.ply"));
  // One signal would have left the last whole frame's checkpoint; two leave
  // only the periodic ones (every 2 frames: none yet).
  EXPECT_TRUE(fs::is_empty(dir / "e/checkpoints"));
}

TEST_F(GooRestart, ASignalStopsAFrameThatWouldNeverEnd) {
  // A frame a billion seconds long: the first signal's "finish the frame"
  // would wait forever. The run stops 10 s after the signal, as a second
  // signal would stop it: exit 130, the summary written, no partial frame.
  const test::TempDir& dir = *dir_;
  std::string endless = kDrop;
  endless.replace(endless.find("\"fps\": 24"), std::string("\"fps\": 24").size(), "\"fps\": 1e-9");
  dir.write("endless.json", endless);
  GooChild child(dir / "endless.json", dir / "f");
  ASSERT_TRUE(child.started());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!fs::exists(dir / "f/frames/frame_00000.ply") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(fs::exists(dir / "f/frames/frame_00000.ply"));
  // Well inside frame 1 (a signal between frames stops the run at once).
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const auto signalled = std::chrono::steady_clock::now();
  child.signal(SIGTERM);
  ASSERT_NO_FATAL_FAILURE(expect_interrupted(child, dir / "f"));
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
  EXPECT_GE(waited, 10.0);
  EXPECT_FALSE(fs::exists(dir / "f/frames/frame_00001.ply"));
}

// Whoever reads goo's log may go away (a harness killed, `goo run | head`):
// its log lines then fail (SIGPIPE ignored, EPIPE) instead of killing goo,
// and a later SIGTERM still gets the checkpoint and the summary written.
TEST_F(GooRestart, AClosedLogPipeDoesNotCostTheCheckpoint) {
  const test::TempDir& dir = *dir_;
  int pipe_ends[2];
  ASSERT_EQ(::pipe(pipe_ends), 0);
  GooChild child(dir / "drop.json", dir / "d", pipe_ends[1]);
  ASSERT_TRUE(child.started());
  ::close(pipe_ends[1]);
  ::close(pipe_ends[0]);  // nobody reads goo's output any more
  if (child.wait_for_frame_one()) child.signal(SIGTERM);  // else it ended by itself: the status says how
  ASSERT_NO_FATAL_FAILURE(expect_interrupted(child, dir / "d"));
  EXPECT_FALSE(fs::is_empty(dir / "d/checkpoints"));
}

TEST(GooRun, BadScenesExitTwoNamingThePathAndWriteNothing) {
  test::TempDir dir;
  dir.write("open.off", "OFF\n4 3 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"objects": [{"primitive": {"type": "box", "size": [1, 1, 1]}, "materal": "rigid_brick", "lattice_spacing": 0.5}]})",
       "/objects/0/materal is not a known key"},
      {R"({"objects": [{"primitive": {"type": "box", "size": [1, 1, 1]}, "material": {"poisson_ratio": 0.5}, "lattice_spacing": 0.5}]})",
       "/objects/0/material/poisson_ratio must be in [0, 0.5)"},
      {R"({"gravity": [0, 0], "objects": []})", "/gravity must be an array of 3 numbers"},
      {R"({"objects": [{"mesh": "missing.off", "material": "rigid_brick", "lattice_spacing": 0.5}]})",
       "/objects/0/mesh names no readable file"},
      {R"({"objects": [{"mesh": "open.off", "material": "rigid_brick", "lattice_spacing": 0.5}]})", "open.off"},
  };
  for (const auto& [text, expected] : cases) {
    SCOPED_TRACE(expected);
    dir.write("bad.json", text);
    const CommandResult run = goo(args({"run", quoted(dir / "bad.json"), "--out", quoted(dir / "out")}));
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_THAT(run.err, HasSubstr(expected));
    EXPECT_THAT(run.err, HasSubstr("bad.json"));
    EXPECT_FALSE(fs::exists(dir / "out"));
  }
  EXPECT_EQ(goo(args({"run", quoted(dir / "none.json"), "--out", quoted(dir / "out")})).exit_code, 2);
  EXPECT_FALSE(fs::exists(dir / "out"));
  // A damaged checkpoint is refused too, before anything is written.
  dir.write("broken.h5", "goo-checkpoint\nformat_version 1\nlength 5\n");
  const CommandResult resumed = goo(args({"run --resume", quoted(dir / "broken.h5"), "--out", quoted(dir / "out")}));
  EXPECT_EQ(resumed.exit_code, 2);
  EXPECT_THAT(resumed.err, HasSubstr("broken.h5"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(GooRun, AnEarlierRunIsNotOverwrittenUnlessAsked) {
  test::TempDir dir;
  dir.write("drop.json", kDrop);
  const std::string scene = quoted(dir / "drop.json");
  ASSERT_EQ(goo(args({"run", scene, "--frames 1 --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
  const std::string frame = bytes_of(dir / "a/frames/frame_00001.ply");
  const CommandResult again = goo(args({"run", scene, "--frames 1 --out", quoted(dir / "a")}));
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_THAT(again.err, HasSubstr("--overwrite"));
  EXPECT_EQ(bytes_of(dir / "a/frames/frame_00001.ply"), frame);
  EXPECT_EQ(goo(args({"run", scene, "--frames 1 --overwrite --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
}

TEST(GooRun, ARunWithoutFramesIsProtectedAndOverwritingLeavesNothingOfTheOldRun) {
  test::TempDir dir;
  // No frame files at all, only run.h5 and the summary: still an earlier run.
  std::string quiet = kDrop;
  quiet.replace(quiet.find("\"output\": {"), std::string("\"output\": {").size(), "\"output\": {\"formats\": [], ");
  dir.write("quiet.json", quiet);
  ASSERT_EQ(goo(args({"run", quoted(dir / "quiet.json"), "--frames 1 --out", quoted(dir / "q"), "--quiet"})).exit_code, 0);
  ASSERT_TRUE(fs::exists(dir / "q/run.h5"));
  const std::string run_file = bytes_of(dir / "q/run.h5");
  const CommandResult again = goo(args({"run", quoted(dir / "quiet.json"), "--frames 1 --out", quoted(dir / "q")}));
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_THAT(again.err, HasSubstr("holds an earlier run"));
  EXPECT_EQ(bytes_of(dir / "q/run.h5"), run_file);
  // A shorter run with --overwrite leaves none of the longer one's frames
  // or checkpoints; files that are not goo's stay.
  dir.write("drop.json", kDrop);
  ASSERT_EQ(goo(args({"run", quoted(dir / "drop.json"), "--frames 3 --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
  dir.write("a/notes.txt", "mine");
  ASSERT_TRUE(fs::exists(dir / "a/frames/frame_00003.ply"));
  ASSERT_TRUE(fs::exists(dir / "a/checkpoints/frame_00002.h5"));
  ASSERT_EQ(goo(args({"run", quoted(dir / "drop.json"), "--frames 1 --overwrite --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
  EXPECT_TRUE(fs::exists(dir / "a/frames/frame_00001.ply"));
  EXPECT_FALSE(fs::exists(dir / "a/frames/frame_00002.ply"));
  EXPECT_FALSE(fs::exists(dir / "a/frames/frame_00003.ply"));
  EXPECT_FALSE(fs::exists(dir / "a/checkpoints/frame_00002.h5"));
  EXPECT_EQ(slurp(dir / "a/notes.txt"), "mine");
  // An empty --out is refused.
  const CommandResult empty = goo(args({"run", quoted(dir / "drop.json"), "--frames 1 --out ''"}));
  EXPECT_EQ(empty.exit_code, 2);
  EXPECT_THAT(empty.err, HasSubstr("--out must name a folder"));
}

TEST(GooRun, AResumedRunGoesOnInItsOwnFolderAndNeverIntoAnothers) {
  test::TempDir dir;
  dir.write("drop.json", kDrop);
  const std::string scene = quoted(dir / "drop.json");
  ASSERT_EQ(goo(args({"run", scene, "--frames 2 --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
  ASSERT_EQ(goo(args({"run", scene, "--frames 1 --out", quoted(dir / "b"), "--quiet"})).exit_code, 0);
  const std::string b_summary = bytes_of(dir / "b/summary.json");
  // Into b, which holds another run: refused, b untouched.
  const CommandResult into_b =
      goo(args({"run --resume", quoted(dir / "a/checkpoints/frame_00002.h5"), "--frames 3 --out", quoted(dir / "b")}));
  EXPECT_EQ(into_b.exit_code, 2);
  EXPECT_THAT(into_b.err, HasSubstr("holds another run"));
  EXPECT_EQ(bytes_of(dir / "b/summary.json"), b_summary);
  EXPECT_FALSE(fs::exists(dir / "b/frames/frame_00003.ply"));
  // Without --out, from another folder: it goes on in a/.
  const CommandResult own = goo(args({"run --resume", quoted(dir / "a/checkpoints/frame_00002.h5"), "--frames 3 --quiet"}));
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_TRUE(fs::exists(dir / "a/frames/frame_00003.ply"));
}

TEST(GooRun, ACheckpointHoldingValuesNoRunWritesIsRefused) {
  // Valid checksums, impossible values: refused with the field, exit 2,
  // nothing written.
  test::TempDir dir;
  dir.write("drop.json", kDrop);
  ASSERT_EQ(goo(args({"run", quoted(dir / "drop.json"), "--frames 1 --out", quoted(dir / "a"), "--quiet"})).exit_code, 0);
  const StateRecord good = io::read_checkpoint(dir / "a/checkpoints/frame_00001.h5");
  const Eigen::Index nodes = good.points("bodies/0/positions").rows();
  struct Case {
    std::string what;
    std::function<void(StateRecord&)> tamper;
    std::string expected;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Case> cases = {
      {"negative frame", [](StateRecord& r) { r.put("run/frame", std::int64_t{-1}); }, "run/frame is -1"},
      {"frame past five digits", [](StateRecord& r) { r.put("run/frame", std::int64_t{1} << 32); }, "not a frame number"},
      {"another frame's time", [](StateRecord& r) { r.put("run/frame", std::int64_t{2}); }, "but frame 2 at 24 fps"},
      {"negative time", [](StateRecord& r) { r.put("time", -1.0); }, "time: -1"},
      {"negative steps", [](StateRecord& r) { r.put("steps", std::int64_t{-5}); }, "cannot be negative"},
      {"negative mass", [&](StateRecord& r) {
         Eigen::VectorXd m = r.vector("bodies/0/masses");
         m[nodes / 2] = -1.0;
         r.put_vector("bodies/0/masses", m);
       }, "bodies/0/masses (body 'cube'): entry"},
      {"NaN mass", [&](StateRecord& r) {
         Eigen::VectorXd m = r.vector("bodies/0/masses");
         m[0] = nan;
         r.put_vector("bodies/0/masses", m);
       }, "bodies/0/masses"},
      {"far position", [](StateRecord& r) {
         Points x = r.points("bodies/0/positions");
         x(1, 2) = 1e300;
         r.put_matrix("bodies/0/positions", x);
       }, "bodies/0/positions (body 'cube'): entry 1"},
      {"NaN barycentric coordinate", [&](StateRecord& r) {
         Eigen::MatrixXd b = r.matrix("bodies/0/embedding_bary", 4);
         b(0, 0) = nan;
         r.put_matrix("bodies/0/embedding_bary", b);
       }, "bodies/0/embedding_bary"},
      {"empty surface", [](StateRecord& r) { r.put("bodies/0/surface_triangles", Triangles(0, 3)); },
       "cannot close a surface"},
      {"flat plastic deformation", [](StateRecord& r) {
         std::vector<Eigen::Matrix3d> fp = r.matrices3("bodies/0/Fp");
         fp[0].setZero();
         r.put("bodies/0/Fp", fp);
       }, "bodies/0/Fp"},
      {"zero material volume", [](StateRecord& r) { r.put("bodies/0/rest_material_volume", 0.0); },
       "rest_material_volume"},
      {"zero initial mass", [](StateRecord& r) { r.put("run/initial_mass", 0.0); }, "run/initial_mass"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    StateRecord bad = good;
    c.tamper(bad);
    io::write_checkpoint(dir / "bad.h5", bad);
    const CommandResult r = goo(args({"run --resume", quoted(dir / "bad.h5"), "--frames 2 --out", quoted(dir / "b")}));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.expected));
    EXPECT_FALSE(fs::exists(dir / "b/frames"));
  }
}

TEST(GooRun, AResumeNeedsNoFileButTheCheckpoint) {
  // The scene given by a relative path, its object's mesh and a mesh
  // obstacle relative to it; the resume runs from another folder, after the
  // meshes (and the scene) are gone: the checkpoint holds the bodies and the
  // obstacles' meshes, and goes on bit for bit as the run not interrupted.
  test::TempDir dir;
  io::write_surface_mesh(dir / "cube.off", make_box({0.1, 0.1, 0.1}, 3));
  io::write_surface_mesh(dir / "ball.off", make_sphere(0.05, 12));
  std::string scene = kDrop;
  const std::string box = R"("primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 4})";
  scene.replace(scene.find(box), box.size(), R"("mesh": "cube.off")");
  const std::string ground = R"("ground": {"height": 0.0, "friction": 0.4},)";
  scene.replace(scene.find(ground), ground.size(),
                ground + R"( "obstacles": [{"shape": {"type": "mesh", "path": "ball.off"},
                                            "transform": {"translate": [0.4, 0, 0.05]}}],)");
  dir.write("cube.json", scene);
  const std::string in_dir = fmt::format("cd {} &&", quoted(dir.path()));
  ASSERT_EQ(goo("run cube.json --frames 3 --out whole --quiet", in_dir).exit_code, 0);
  ASSERT_EQ(goo("run cube.json --frames 2 --out run --quiet", in_dir).exit_code, 0);
  for (const char* gone : {"cube.off", "ball.off", "cube.json"}) fs::rename(dir / gone, dir / (std::string(gone) + ".away"));
  const CommandResult resumed = goo(args({"run --resume", quoted(dir / "run/checkpoints/frame_00002.h5"), "--frames 3 --quiet"}), "cd / &&");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_EQ(bytes_of(dir / "run/frames/frame_00003.ply"), bytes_of(dir / "whole/frames/frame_00003.ply"));
  EXPECT_EQ(bytes_of(dir / "run/checkpoints/frame_00003.h5"), bytes_of(dir / "whole/checkpoints/frame_00003.h5"));
  // A stored obstacle mesh that is not a closed surface is refused, naming it.
  StateRecord record = io::read_checkpoint(dir / "run/checkpoints/frame_00002.h5");
  StateRecord broken;
  for (const auto& [name, array] : record.arrays()) {
    StateArray a = array;
    if (name == "scene/obstacle_meshes/0/triangles") a.integers[0] = a.integers[1];  // a degenerate triangle
    broken.put_array(name, a);
  }
  for (const auto& [name, value] : record.strings()) broken.put_string(name, value);
  fs::create_directories(dir / "broken/checkpoints");
  io::write_checkpoint(dir / "broken/checkpoints/frame_00002.h5", broken);
  const CommandResult refused = goo(args({"run --resume", quoted(dir / "broken/checkpoints/frame_00002.h5"), "--frames 3"}));
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_THAT(refused.err, HasSubstr("broken/checkpoints/frame_00002.h5: scene/obstacle_meshes/0/"));
}

TEST(GooRun, FifosDevicesAndFoldersAreRefusedNotRead) {
  // A FIFO would block forever and /dev/zero never end: refused at once
  // (exit 2, naming the file), whichever command is given them, also through
  // a link with a mesh's name.
  test::TempDir dir;
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  fs::create_symlink("/dev/zero", dir / "zero.off");
  fs::create_directories(dir / "folder.json");
  const std::vector<std::string> commands = {
      args({"run", quoted(dir / "fifo")}),
      args({"run", quoted(dir / "folder.json")}),
      args({"info", quoted(dir / "fifo")}),
      args({"info", quoted(dir / "zero.off")}),
      args({"info", quoted(dir / "fifo") + ".h5"}),
      args({"run --resume", quoted(dir / "fifo")}),
  };
  fs::create_symlink(dir / "fifo", dir / "fifo.h5");
  for (const std::string& command : commands) {
    const CommandResult r = goo(command, "timeout 30");  // a hang fails as exit 124
    EXPECT_EQ(r.exit_code, 2) << command << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("must be a regular file")) << command;
  }
}

TEST(GooRun, ANumericalFailureIsDiagnosedAndKeepsTheLastGoodCheckpoint) {
  test::TempDir dir;
  // The cube falls from rest; 0.6 m/s is passed after about 0.06 s (frame 2 at 24 fps).
  dir.write("fall.json", R"({
    "objects": [{"primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 3},
                 "material": "jiggly_gelatin", "lattice_spacing": 0.05}],
    "output": {"fps": 24, "frames": 10},
    "checkpoint": {"every_frames": 1},
    "limits": {"max_speed": 0.6}
  })");
  const CommandResult run = goo(args({"run", quoted(dir / "fall.json"), "--out", quoted(dir / "out"), "--quiet"}));
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_THAT(run.err, HasSubstr("numerical failure at step"));
  EXPECT_THAT(run.err, HasSubstr("limits.max_speed"));
  EXPECT_THAT(run.err, HasSubstr("of element"));
  EXPECT_TRUE(fs::exists(dir / "out/checkpoints/frame_00001.h5"));
  EXPECT_EQ(goo(args({"info", quoted(dir / "out/checkpoints/frame_00001.h5")})).exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(slurp(dir / "out/summary.json"))["status"], "failed");
}

TEST(GooRun, AFailureWhileSteppingIsANumericalFailureWithItsSummary) {
  // A density the validator accepts but double precision cannot step (the
  // wave speed overflows, the time step underflows to zero): exit 3, the
  // summary written, not exit 2 after frame 0.
  test::TempDir dir;
  std::string scene = kDrop;
  scene.replace(scene.find("\"min_mass_fraction\": 0.05"), std::string("\"min_mass_fraction\": 0.05").size(),
                "\"min_mass_fraction\": 0.05, \"density\": 5e-324");
  dir.write("light.json", scene);
  const CommandResult r = goo(args({"run", quoted(dir / "light.json"), "--frames 1 --out", quoted(dir / "out")}));
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_THAT(r.err, HasSubstr("numerical failure"));
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_EQ(summary["status"], "failed");
  EXPECT_THAT(summary["failure"].get<std::string>(), HasSubstr("time step"));
}

TEST(GooRun, WithoutASceneRunsTheBuiltInDemo) {
  test::TempDir dir;
  const CommandResult run = goo(args({"run --frames 1 --out", quoted(dir / "demo")}));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::exists(dir / "demo/frames/frame_00001.ply"));
  const auto summary = nlohmann::json::parse(slurp(dir / "demo/summary.json"));
  EXPECT_EQ(summary["scene"], "<built-in demo>");
  EXPECT_EQ(summary["initial_surface_triangles"], 75408);  // the bunny
  EXPECT_THAT(run.err, HasSubstr("frame 1/1"));  // progress
  // It ends with its contact sheet, and says where.
  EXPECT_TRUE(fs::exists(dir / "demo/render/sheet.png"));
  EXPECT_THAT(run.out, HasSubstr("contact sheet: " + (dir / "demo/render/sheet.png").string()));
}

}  // namespace
}  // namespace goo
