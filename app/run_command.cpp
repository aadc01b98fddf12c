#include "app/run_command.h"

#include <fmt/format.h>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "app/checkpoint_errors.h"
#include "app/numbered_name.h"
#include "app/render_command.h"
#include "core/error.h"
#include "core/log.h"
#include "core/surface_check.h"
#include "core/svd3_batch.h"
#include "io/atomic_file.h"
#include "io/checkpoint.h"
#include "io/run_file.h"
#include "io/scene_io.h"
#include "io/surface_mesh_io.h"
#include "meshing/surface_intersections.h"
#include "solvers/checkpoint_schema.h"
#include "solvers/simulation.h"

namespace goo::app {

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

volatile std::sig_atomic_t g_signal = 0;   // the last signal
/// Seconds a signalled run waits for the frame under way to end.
constexpr double kSignalGrace = 10.0;
volatile std::sig_atomic_t g_signals = 0;  // how many arrived

extern "C" void on_signal(int signal) {
  g_signal = signal;
  g_signals = g_signals + 1;
}

/// Progress to stderr, ignoring write errors (fmt::print would throw when
/// nobody reads stderr any more, and a progress line is not worth a run).
void to_stderr(const std::string& text) {
  if (std::fwrite(text.data(), 1, text.size(), stderr) == text.size()) std::fflush(stderr);
}

/// Installs the SIGINT/SIGTERM handler for the lifetime of a run (goo's
/// main ignores SIGPIPE for the whole process).
class SignalGuard {
 public:
  SignalGuard() {
    g_signal = 0;
    g_signals = 0;
    struct sigaction action {};
    action.sa_handler = on_signal;
    sigemptyset(&action.sa_mask);
    sigaction(SIGINT, &action, &old_int_);
    sigaction(SIGTERM, &action, &old_term_);
  }
  ~SignalGuard() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  SignalGuard(const SignalGuard&) = delete;
  SignalGuard& operator=(const SignalGuard&) = delete;

 private:
  struct sigaction old_int_ {};
  struct sigaction old_term_ {};
};

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// The wall seconds of an integrator's stages (a − b), keyed as summary.json has them.
nlohmann::json step_stages(const StepTimes& a, const StepTimes& b) {
  return {{"forces", a.forces - b.forces},           {"damping", a.damping - b.damping},
          {"hessian", a.hessian - b.hessian},        {"linear_solve", a.linear_solve - b.linear_solve},
          {"collisions", a.collisions - b.collisions}, {"self_collisions", a.self_collisions - b.self_collisions},
          {"volume", a.volume - b.volume},             {"surface", a.surface - b.surface},
          {"other", a.other - b.other}};
}

/// The same for a re-mesh's stages.
nlohmann::json remesh_stages(const RemeshTimes& a, const RemeshTimes& b) {
  return {{"upkeep", a.upkeep - b.upkeep},
          {"lattice", a.lattice - b.lattice},
          {"transfer", a.transfer - b.transfer},
          {"masses", a.masses - b.masses},
          {"separation", a.separation - b.separation},
          {"conservation", a.conservation - b.conservation}};
}

/// The process's peak resident memory so far: VmHWM of /proc/self/status.
/// (getrusage's ru_maxrss would do, but Linux carries it over from the
/// parent across fork and exec: under a 60 MB Python harness every small run
/// "peaked" at 60 MB.) getrusage where /proc is missing.
long long peak_memory_bytes() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6)) * 1024;  // "VmHWM:   1234 kB"
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<long long>(usage.ru_maxrss) * 1024;  // Linux reports KiB
}

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the scene file", path.string()));
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string clock_text(double seconds) {
  if (!(seconds >= 0.0) || seconds > 1e7) return "--:--";
  const auto s = static_cast<long>(seconds + 0.5);
  return s >= 3600 ? fmt::format("{}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60)
                   : fmt::format("{}:{:02d}", s / 60, s % 60);
}

/// Progress on stderr: a bar redrawn in place on a terminal, a plain line
/// every few seconds otherwise.
class Progress {
 public:
  Progress(bool quiet, int first, int last) : quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0), first_(first), last_(last) {}

  void update(int frame, double time, std::int64_t steps, std::int64_t remeshes, bool force = false) {
    if (quiet_) return;
    const double now = seconds_since(start_);
    if (!force && now - shown_ < (tty_ ? 0.1 : 5.0)) return;
    shown_ = now;
    const double rate = now > 0.0 ? static_cast<double>(steps - steps0_) / now : 0.0;
    const int done = frame - first_, total = last_ - first_;
    const double eta = done > 0 ? now / done * (total - done) : -1.0;
    const std::string text =
        fmt::format("frame {}/{}  t = {:.3f} s  {:.0f} steps/s  {} re-meshes  ETA {}", frame, last_, time, rate,
                    remeshes, done >= total ? "0:00" : clock_text(eta));
    if (tty_) {
      constexpr int width = 24;
      const int filled = total > 0 ? width * done / total : width;
      to_stderr(fmt::format("\r[{}{}] {}\x1b[K", std::string(static_cast<std::size_t>(filled), '#'),
                            std::string(static_cast<std::size_t>(width - filled), '.'), text));
    } else {
      to_stderr(fmt::format("goo: {}\n", text));
    }
  }
  void set_steps0(std::int64_t steps) { steps0_ = steps; }
  void finish() {
    if (!quiet_ && tty_) to_stderr("\n");
  }

 private:
  bool quiet_, tty_;
  int first_, last_;
  std::int64_t steps0_ = 0;
  Clock::time_point start_ = Clock::now();
  double shown_ = -1e9;
};

nlohmann::json to_json(const SelfCollisionStats& a, const SelfCollisionStats& b) {
  return {{"candidates", a.candidates - b.candidates},
          {"repulsions", a.repulsions - b.repulsions},
          {"impacts", a.impacts - b.impacts},
          {"rounds", a.rounds - b.rounds},
          {"zone_rounds", a.zone_rounds - b.zone_rounds},
          {"zone_nodes", a.zone_nodes - b.zone_nodes},
          {"touching_at_start", a.touching_at_start - b.touching_at_start},
          {"broad_phases", a.list_builds - b.list_builds},
          {"list_extensions", a.list_extensions - b.list_extensions},
          {"pairs_listed", a.listed - b.listed},
          {"steps_waited", a.waited - b.waited}};
}

nlohmann::json to_json(const VolumeProjectionStats& v) {
  return {{"newton_iterations", v.newton_iterations},
          {"cg_iterations", v.cg_iterations},
          {"max_error_before", v.error_before},
          {"max_error", v.error},
          {"steps_waited", v.waited}};
}

nlohmann::json to_json(const DampingSolveStats& d) {
  return {{"solves", d.solves},
          {"cg_iterations", d.iterations},
          {"max_cg_iterations", d.max_iterations},
          {"max_residual", d.max_residual},
          {"unconverged", d.unconverged},
          {"preconditioners", d.preconditioners}};
}

nlohmann::json to_json(const SurfaceQuality& q, const FacingSheets& facing) {
  return {{"triangles", q.triangles},
          {"edges", q.edges},
          {"self_intersecting_pairs", q.self_intersecting_pairs},
          {"creased_edges", q.creased_edges},
          {"degenerate_triangles", q.degenerate_triangles},
          {"area", q.area},
          {"volume", q.volume},
          {"facing_sheets_area", facing.area},
          {"facing_sheets_triangles", facing.triangles}};
}

struct Outputs {
  fs::path folder;
  const OutputSettings* settings;
  std::unique_ptr<io::RunFile> run_file;
  double seconds = 0.0;          ///< writing frames
  double quality_seconds = 0.0;  ///< measuring them
  SurfaceQuality quality;        ///< of the last frame written
  FacingSheets facing;           ///< of the last frame written, each body's surface within its lattice spacing

  void write_frame(int frame, const Simulation& sim) {
    const TriangleMesh surface = sim.surface();
    const auto measured = Clock::now();
    quality = measure_surface_quality(surface);
    facing = FacingSheets{};
    for (const auto& b : sim.bodies()) {  // a re-mesh glues sheets of one body only (docs/lattice.md)
      const FacingSheets own = facing_sheets(b.body.surface(), b.h);
      facing.area += own.area;
      facing.triangles += own.triangles;
    }
    quality_seconds += seconds_since(measured);
    const auto start = Clock::now();
    const fs::path frames = folder / "frames";
    const std::vector<std::int32_t> bodies = sim.surface_bodies();
    if (settings->ply) {
      io::WriteOptions options;
      options.face_body = bodies;  // each triangle's body, for colouring (docs/running.md)
      io::write_surface_mesh(frames / fmt::format("frame_{:05d}.ply", frame), surface, options);
    }
    if (settings->obj) io::write_surface_mesh(frames / fmt::format("frame_{:05d}.obj", frame), surface);
    TetMesh tets;
    if (settings->tet_mesh) {
      Index nodes = 0, elements = 0;
      for (const auto& b : sim.bodies()) {
        nodes += b.body.num_nodes();
        elements += b.body.num_elements();
      }
      tets.positions.resize(nodes, 3);
      tets.tets.resize(elements, 4);
      Index n0 = 0, e0 = 0;
      for (const auto& b : sim.bodies()) {
        tets.positions.middleRows(n0, b.body.num_nodes()) = b.body.positions;
        tets.tets.middleRows(e0, b.body.num_elements()) = b.body.tets.array() + n0;
        n0 += b.body.num_nodes();
        e0 += b.body.num_elements();
      }
      io::write_tet_mesh_vtk(frames / fmt::format("tets_{:05d}.vtk", frame), tets);
    }
    if (run_file) run_file->write_frame(frame, sim.time(), surface, settings->tet_mesh ? &tets : nullptr, bodies);
    seconds += seconds_since(start);
  }
};

/// What a checkpoint adds to the simulation's own state.
void add_run_fields(StateSink& record, const Scene& scene, int frame, const SimulationTotals& initial) {
  checkpoint::put_run(record, checkpoint::RunFields{frame, initial.mass, initial.volume, initial.momentum});
  checkpoint::put_scene(record, scene);
}

/// RUN for a checkpoint RUN/checkpoints/frame_NNNNN.h5, if it is one.
std::optional<fs::path> run_folder_of(const fs::path& checkpoint) {
  const fs::path absolute = fs::absolute(checkpoint);
  if (absolute.parent_path().filename() != "checkpoints") return std::nullopt;
  return absolute.parent_path().parent_path();
}

/// The files a goo run writes into its folder (docs/running.md).
bool is_run_file(const fs::path& relative) {
  const std::string folder = relative.parent_path().generic_string(), name = relative.filename().string();
  if (folder.empty()) return name == "run.h5" || name == "run.xdmf" || name == "summary.json";
  if (folder == "checkpoints") return numbered_name(name, "frame_", ".h5").has_value();
  return folder == "frames" && (numbered_name(name, "frame_", ".ply") || numbered_name(name, "frame_", ".obj") ||
                                numbered_name(name, "tets_", ".vtk"));
}

std::vector<fs::path> run_files(const fs::path& folder) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) return out;
  for (const fs::path& sub : {fs::path(), fs::path("frames"), fs::path("checkpoints")}) {
    if (!fs::is_directory(folder / sub, ec)) continue;
    for (const auto& entry : fs::directory_iterator(folder / sub, ec))
      if (is_run_file(sub / entry.path().filename())) out.push_back(entry.path());
  }
  return out;
}

bool holds_a_run(const fs::path& folder) { return !run_files(folder).empty(); }

/// --overwrite: the earlier run's files go (a shorter new run must not leave
/// the old one's later frames beside its own); nothing else in the folder.
void remove_run(const fs::path& folder) {
  for (const fs::path& file : run_files(folder)) {
    std::error_code ec;
    fs::remove(file, ec);
    if (ec) throw WriteError(fmt::format("{}: cannot remove the earlier run's file ({})", file.string(), ec.message()));
  }
}

bool no_external_force(const Scene& scene) {
  if (scene.gravity.norm() > 0.0 || scene.ground || !scene.obstacles.empty()) return false;
  for (const auto& o : scene.objects)
    if (!o.pinned.empty()) return false;
  return true;
}

/// What a run starts from, read and checked before anything is written.
struct RunPlan {
  Scene scene;
  std::optional<StateRecord> resumed;  ///< the checkpoint, when resuming
  std::optional<fs::path> own_folder;  ///< a resumed run's own folder
  fs::path folder;
  int last_frame = 0;
};

/// The scene (from its file, the checkpoint or the demo), the frames and the
/// folder: everything that can be refused, before anything is written.
RunPlan plan_run(const RunOptions& options) {
  RunPlan plan;
  Scene& scene = plan.scene;
  (void)active_simd_level();  // refuses a GOO_SIMD it does not know before anything is read or written
  if (options.resume) {
    plan.resumed = io::read_checkpoint(*options.resume);
    const StateRecord& resumed = *plan.resumed;
    const std::string& text = reading_checkpoint(*options.resume, "", [&]() -> const std::string& {
      return checkpoint::get_scene_text(resumed);
    });
    if (options.scene) io::require_regular_file(*options.scene, "the scene file");
    if (options.scene && slurp(*options.scene) != text)
      throw Error(fmt::format("{}: differs from the scene stored in the checkpoint {}; resume without a scene file, "
                              "or with the one the run started from",
                              *options.scene, *options.resume));
    // The bodies come from the checkpoint and the obstacles' meshes too: a
    // run resumes without the files it began from.
    const std::map<std::string, TriangleMesh> obstacle_meshes =
        reading_checkpoint(*options.resume, "", [&] { return checkpoint::get_obstacle_meshes(resumed); });
    io::SceneInputs inputs;
    inputs.objects_from_checkpoint = true;
    inputs.obstacle_meshes = &obstacle_meshes;
    scene = reading_checkpoint(*options.resume, "its scene: ", [&] {
      return io::parse_scene(text, checkpoint::get_scene_source(resumed), checkpoint::get_scene_base_folder(resumed),
                             inputs);
    });
  } else if (options.scene) {
    scene = io::read_scene(*options.scene);
  } else {
    scene = io::demo_scene();
  }
  plan.last_frame = options.frames.value_or(scene.output.frames);
  if (plan.last_frame < 0) throw Error(fmt::format("--frames must be non-negative, got {}", plan.last_frame));
  if (options.out && options.out->empty()) throw Error("--out must name a folder, got an empty path");
  // A resumed run goes on in its own folder (the checkpoint's
  // RUN/checkpoints/frame_NNNNN.h5), not in the scene's folder relative to
  // wherever goo is started.
  if (options.resume) plan.own_folder = run_folder_of(*options.resume);
  if (options.resume && !options.out && !plan.own_folder)
    throw Error(fmt::format("{}: is not in a run's checkpoints/ folder; give the folder to go on in with --out",
                            *options.resume));
  plan.folder = options.out ? fs::path(*options.out) : plan.own_folder ? *plan.own_folder : fs::path(scene.output.folder);
  if (options.threads < 0) throw Error(fmt::format("--threads must be positive, got {}", options.threads));
  return plan;
}

/// Another run's output is never replaced unless asked: a new run into a
/// folder holding one, or a run resumed into a folder other than its own.
void claim_folder(const RunOptions& options, const RunPlan& plan) {
  const fs::path& folder = plan.folder;
  std::error_code ec;
  if (fs::exists(folder, ec) && !fs::is_directory(folder, ec))
    throw Error(fmt::format("{}: --out must be a folder", folder.string()));
  const bool its_own = plan.own_folder && fs::exists(folder, ec) && fs::equivalent(folder, *plan.own_folder, ec);
  if (holds_a_run(folder) && !its_own && !options.overwrite)
    throw Error(fmt::format("{}: holds {}; pass --overwrite to replace it, --resume with one of its checkpoints to "
                            "continue it, or choose another --out",
                            folder.string(), options.resume ? "another run" : "an earlier run"));
  if (holds_a_run(folder) && !its_own && options.overwrite) remove_run(folder);
}

/// The frame a resumed run goes on from and the totals its first frame had,
/// from the checkpoint; values no run writes are refused, naming the field
/// (a frame number names files, and the clock is the frame's).
int resumed_frame(const fs::path& checkpoint, const StateRecord& resumed, const Scene& scene, const Simulation& sim,
                  int last_frame, SimulationTotals& initial) {
  const SimulationTotals loaded = sim.totals();  // the meshes the run goes on from
  initial.nodes = loaded.nodes, initial.elements = loaded.elements;
  initial.surface_vertices = loaded.surface_vertices, initial.surface_triangles = loaded.surface_triangles;
  const checkpoint::RunFields run = checkpoint::get_run(resumed);
  const std::int64_t stored_frame = run.frame;
  if (stored_frame < 0 || stored_frame > 99999)
    throw Error(fmt::format("{}: run/frame is {}, not a frame number (0 to 99999)", checkpoint.string(), stored_frame));
  const int frame = static_cast<int>(stored_frame);
  if (const double expected = frame / scene.output.fps; !(std::abs(sim.time() - expected) <= 1e-9 * std::max(1.0, expected)))
    throw Error(fmt::format("{}: time is {} s, but frame {} at {} fps is at {} s", checkpoint.string(), sim.time(),
                            frame, scene.output.fps, expected));
  initial.mass = run.initial_mass;
  initial.volume = run.initial_volume;
  initial.momentum = run.initial_momentum;
  if (!(std::isfinite(initial.mass) && initial.mass > 0.0 && std::isfinite(initial.volume) && initial.volume > 0.0 &&
        initial.momentum.allFinite()))
    throw Error(fmt::format("{}: run/initial_mass, run/initial_volume or run/initial_momentum is not a body's "
                            "(non-positive or not finite)",
                            checkpoint.string()));
  if (frame > last_frame)
    throw Error(fmt::format("{}: the checkpoint is at frame {}, past the last frame {} asked for", checkpoint.string(),
                            frame, last_frame));
  return frame;
}

/// One run from its first frame to its last: the frame loop, the frames and
/// checkpoints it writes, and the report it keeps for summary.json.
class Run {
 public:
  Run(const RunOptions& options, const Scene& scene, Simulation& sim, const fs::path& folder, int frame,
      int last_frame, const SimulationTotals& initial)
      : options_(options), scene_(scene), sim_(sim), folder_(folder), frame_(frame), first_frame_(frame),
        last_frame_(last_frame), initial_(initial), outputs_{folder, &scene.output, nullptr, 0.0, 0.0, {}, {}},
        progress_(options.quiet, frame, last_frame) {}

  /// The output folder, run.h5, and frame 0 unless resuming.
  void open(bool resuming) {
    std::error_code ec;
    fs::create_directories(folder_ / "frames", ec);
    if (!ec) fs::create_directories(folder_ / "checkpoints", ec);
    if (ec) throw WriteError(fmt::format("{}: cannot create the output folder: {}", folder_.string(), ec.message()));
    if (scene_.output.hdf5) outputs_.run_file = std::make_unique<io::RunFile>(folder_, resuming ? frame_ + 1 : 0);
    if (!options_.quiet) {
      const SimulationTotals t = sim_.totals();
      log().info("{}: {} objects, {} elements, {} surface triangles, {} integrator, frames {} to {} at {} fps into {}",
                 scene_.source, scene_.objects.size(), t.elements, t.surface_triangles, to_string(scene_.integrator),
                 frame_, last_frame_, scene_.output.fps, folder_.string());
    }
    if (!resuming) written([&] { outputs_.write_frame(0, sim_); });
    // Frame 0's surface (a resumed run wrote it before).
    initial_surface_ = resuming ? nlohmann::json(nullptr) : to_json(outputs_.quality, outputs_.facing);
  }

  /// 3. Frames. Each frame boundary is a restart point, so a checkpoint
  /// taken there resumes bitwise identically. A first SIGINT or SIGTERM
  /// finishes the frame under way, writes it and its checkpoint, and exits
  /// with 130; a second stops at once, keeping the checkpoints already
  /// written. (Holding a copy of the last frame's state instead, to write
  /// when a signal comes, cost 430 bytes per tet: 40% of the Newmark path's
  /// memory.)
  void frames() {
    progress_.set_steps0(sim_.steps());
    begin_frame_record();
    while (exit_code_ == 0) {
      sim_.make_restart_point();
      if (frame_ >= last_frame_) break;
      if (g_signals > 0) {  // a whole frame after the signal: its checkpoint is written below
        if (!told_) log().warn("signal {} during setup: stopping after frame {}", static_cast<int>(g_signal), frame_);
        end("interrupted", kExitInterrupted);
        break;
      }
      const int every = scene_.checkpoint_every_frames;
      if (every > 0 && frame_ > first_frame_ && frame_ % every == 0 && !written([&] { write_checkpoint(frame_); }))
        break;
      if (!advance()) break;
      ++frame_;
      const double output_before = outputs_.seconds, quality_before = outputs_.quality_seconds;
      if (!written([&] { outputs_.write_frame(frame_, sim_); })) {
        --frame_;  // the last frame written whole
        progress_.finish();
        break;
      }
      per_frame_.push_back(frame_record(output_before, quality_before));
      progress_.update(frame_, sim_.time(), sim_.steps(), sim_.remeshes(), frame_ == last_frame_);
    }
    stepping_peak_bytes_ = peak_memory_bytes();  // before the final checkpoint
    if (exit_code_ == 0 || (exit_code_ == kExitInterrupted && g_signals == 1 && !stopped_in_frame_)) {
      progress_.finish();
      if (exit_code_ == kExitInterrupted) log().warn("interrupted: writing the checkpoint of frame {}", frame_);
      written([&] { write_checkpoint(frame_); });  // the run's end, or the frame finished after a signal
    }
  }

  /// 4. The summary (summary.json, docs/running.md); returns the exit code.
  int report(Clock::time_point wall_start, long long setup_peak_bytes) {
    const std::string text = summary(wall_start, setup_peak_bytes).dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    try {  // file names (the scene's, the bodies') need not be UTF-8: such bytes became U+FFFD
      io::write_file_atomically(folder_ / "summary.json", [&](std::ostream& out) { out << text; });
    } catch (const WriteError& e) {
      log().error("no summary: {}", e.what());
      if (exit_code_ == 0) exit_code_ = kExitWriteFailure;
    }
    if (!options_.quiet && exit_code_ == 0)
      log().info("{} frames, {} steps, {} re-meshes in {:.1f} s; volume {:.6g} → {:.6g} m³; summary in {}", frame_,
                 sim_.steps(), sim_.remeshes(), seconds_since(wall_start), initial_.volume, sim_.totals().volume,
                 (folder_ / "summary.json").string());
    return exit_code_;
  }

 private:
  void end(const char* status, int exit_code) {
    status_ = status;
    exit_code_ = exit_code;
  }

  /// A file that cannot be written (the disk full, a quota or size limit,
  /// the folder removed) ends the run: the files written before stay, and
  /// the summary says why (if it can still be written).
  bool written(const std::function<void()>& write) {
    try {
      write();
      return true;
    } catch (const WriteError& e) {
      failure_ = fmt::format("cannot write the output: {}", e.what());
      log().error("{}", failure_);
      log().error("the frames and checkpoints written before are kept in {}", folder_.string());
      end("failed", kExitWriteFailure);
      return false;
    }
  }

  /// Each array goes to the file as the simulation hands it over: a second
  /// copy of the whole state would be the run's peak of memory.
  void write_checkpoint(int f) {
    const auto start = Clock::now();
    io::CheckpointWriter writer(folder_ / "checkpoints" / fmt::format("frame_{:05d}.h5", f));
    sim_.save(writer);
    add_run_fields(writer, scene_, f, initial_);
    writer.commit();
    checkpoint_seconds_ += seconds_since(start);
  }

  /// Whether a signal stops the frame under way: a second one, or a first
  /// one whose frame has not ended within kSignalGrace (a huge frame time or
  /// a tiny time step must not hold a signalled run forever).
  bool stop_now() {
    if (g_signals == 1 && !told_) {
      told_ = true;
      signalled_ = Clock::now();
      progress_.finish();
      log().warn("signal {}: finishing frame {}, then writing its checkpoint (another signal stops at once; so "
                 "does a frame not finished within {:.0f} s)",
                 static_cast<int>(g_signal), frame_ + 1, kSignalGrace);
    }
    return g_signals >= 2 || (told_ && seconds_since(signalled_) > kSignalGrace);
  }

  /// Steps to the next frame's time; false when the run ends there.
  bool advance() {
    bool completed = false;
    try {
      completed = sim_.advance_to((frame_ + 1) / scene_.output.fps, [this] { return stop_now(); });
    } catch (const std::exception& e) {
      // The input passed every check before the first step: what fails
      // while stepping (a NaN, a runaway node, a time step that underflows
      // to zero) is a numerical failure, diagnosed, with the summary written.
      const bool diagnosed = dynamic_cast<const NumericalFailure*>(&e) != nullptr;
      if (!diagnosed && dynamic_cast<const Error*>(&e) == nullptr) throw;  // a bug: exit 1
      progress_.finish();
      failure_ = diagnosed ? e.what()
                           : fmt::format("numerical failure in frame {} (t = {:.6g} s): {}", frame_ + 1, sim_.time(), e.what());
      log().error("{}", failure_);
      log().error("the last good checkpoint is kept in {}", (folder_ / "checkpoints").string());
      end("failed", kExitNumericalFailure);
      return false;
    }
    if (!completed) {
      stopped_in_frame_ = true;
      progress_.finish();
      log().warn("{}: stopping now, in frame {}; the checkpoints already written are kept",
                 g_signals >= 2 ? "a second signal" : "the frame did not finish in time", frame_ + 1);
      end("interrupted", kExitInterrupted);
    }
    return completed;
  }

  void begin_frame_record() {
    stages_before_ = sim_.stage_times();
    steps_before_ = sim_.steps();
    self_before_ = sim_.self_collision_totals();
  }

  /// Per frame (the profile of docs/benchmarks.md): the wall time of each
  /// stage spent on it, and the mesh sizes at its end.
  nlohmann::json frame_record(double output_before, double quality_before) {
    const StageTimes& st = sim_.stage_times();
    const SimulationTotals t = sim_.totals();
    nlohmann::json r = {{"frame", frame_},
                        {"time", sim_.time()},
                        {"steps", sim_.steps() - steps_before_},
                        {"remeshes", sim_.remeshes()},
                        {"elements", t.elements},
                        {"nodes", t.nodes},
                        {"separation",
                         {{"split_elements", t.separation.split_elements},
                          {"node_copies", t.separation.node_copies},
                          {"degenerate_elements", t.separation.degenerate_elements}}},
                        {"surface_triangles", t.surface_triangles},
                        {"stages",
                         {{"integrate", st.integrate - stages_before_.integrate},
                          {"remesh_check", st.remesh_check - stages_before_.remesh_check},
                          {"remesh", st.remesh - stages_before_.remesh},
                          {"safety_checks", st.safety - stages_before_.safety},
                          {"frames_output", outputs_.seconds - output_before},
                          {"surface_quality", outputs_.quality_seconds - quality_before}}},
                        {"surface", to_json(outputs_.quality, outputs_.facing)},
                        {"self_collisions", to_json(sim_.self_collision_totals(), self_before_)},
                        {"volume_projection", to_json(sim_.take_frame_volume_stats())},
                        {"damping_solve", to_json(sim_.take_frame_damping_stats())},
                        {"integrate_stages", step_stages(st.step, stages_before_.step)},
                        {"remesh_stages", remesh_stages(st.remesh_stages, stages_before_.remesh_stages)}};
    begin_frame_record();
    return r;
  }

  nlohmann::json summary(Clock::time_point wall_start, long long setup_peak_bytes) const {
    const SimulationTotals now = sim_.totals();
    const StageTimes& st = sim_.stage_times();
    nlohmann::json j;
    j["status"] = status_;
    if (!failure_.empty()) j["failure"] = failure_;
    {
      // Where the scene is, from anywhere (goo render finds it there).
      std::error_code absolute_error;
      const bool file = fs::is_regular_file(scene_.source, absolute_error);
      j["scene"] = file ? fs::absolute(scene_.source, absolute_error).lexically_normal().string() : scene_.source;
    }
    j["integrator"] = std::string(to_string(scene_.integrator));
    j["frames"] = frame_;
    j["fps"] = scene_.output.fps;
    j["simulated_seconds"] = sim_.time();
    j["wall_seconds"] = seconds_since(wall_start);
    j["stages"] = {{"integrate", st.integrate},       {"remesh_check", st.remesh_check}, {"remesh", st.remesh},
                   {"safety_checks", st.safety},       {"frames_output", outputs_.seconds},
                   {"surface_quality", outputs_.quality_seconds}, {"checkpoints", checkpoint_seconds_}};
    j["integrate_stages"] = step_stages(st.step, StepTimes{});
    j["remesh_stages"] = remesh_stages(st.remesh_stages, RemeshTimes{});
    j["steps"] = sim_.steps();
    j["remeshes"] = sim_.remeshes();
    j["nodes"] = now.nodes;
    j["elements"] = now.elements;
    j["surface_vertices"] = now.surface_vertices;
    j["surface_triangles"] = now.surface_triangles;
    j["initial_elements"] = initial_.elements;
    j["initial_surface_triangles"] = initial_.surface_triangles;
    j["initial_mass"] = initial_.mass;
    j["total_mass"] = now.mass;
    j["initial_volume"] = initial_.volume;
    j["final_volume"] = now.volume;
    j["linear_momentum"] = {now.momentum.x(), now.momentum.y(), now.momentum.z()};
    if (no_external_force(scene_)) {
      j["momentum_drift"] = (now.momentum - initial_.momentum).norm();
    } else {
      j["momentum_drift"] = nullptr;  // gravity, the ground, obstacles or pins act on the bodies
    }
    j["threads"] = options_.threads;
    j["concurrency"] = tbb::this_task_arena::max_concurrency();  // the threads the run's passes split between
    j["simd"] = std::string(simd_level_name(active_simd_level()));
    j["peak_memory_bytes"] = peak_memory_bytes();
    j["setup_peak_memory_bytes"] = setup_peak_bytes;
    j["stepping_peak_memory_bytes"] = stepping_peak_bytes_;
    j["initial_surface"] = initial_surface_;
    j["self_collisions"] = to_json(sim_.self_collision_totals(), SelfCollisionStats{});
    j["volume_projection"] = to_json(sim_.volume_totals());
    j["damping_solve"] = to_json(sim_.damping_totals());
    j["per_frame"] = per_frame_;
    return j;
  }

  const RunOptions& options_;
  const Scene& scene_;
  Simulation& sim_;
  fs::path folder_;
  int frame_, first_frame_, last_frame_;
  SimulationTotals initial_;
  Outputs outputs_;
  Progress progress_;
  std::string status_ = "completed", failure_;
  int exit_code_ = 0;
  double checkpoint_seconds_ = 0.0;
  long long stepping_peak_bytes_ = 0;
  nlohmann::json initial_surface_, per_frame_ = nlohmann::json::array();
  StageTimes stages_before_;
  std::int64_t steps_before_ = 0;
  SelfCollisionStats self_before_;
  bool told_ = false, stopped_in_frame_ = false;
  Clock::time_point signalled_;
};

int run_in_arena(const RunOptions& options, RunPlan& plan, Clock::time_point wall_start);

}  // namespace

int run_scene(const RunOptions& options) {
  const auto wall_start = Clock::now();
  // Signals are caught from the start: one during setup stops the run after
  // frame 0, with its checkpoint and summary (exit 130), like any other.
  SignalGuard signals;
  // 1. Everything that can be refused is read and checked before anything is written.
  RunPlan plan = plan_run(options);
  std::unique_ptr<tbb::global_control> threads;
  if (options.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<std::size_t>(options.threads));
  claim_folder(options, plan);
  // The run in an arena of that many slots (the machine's cores without
  // --threads): the passes split evenly between the threads (static
  // partitions, for_each_run) split by the arena's concurrency, so that
  // --threads 2 on a 16-core machine splits them in two, not in sixteen
  // pieces for two threads. The global limit stays for any other arena.
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  return arena.execute([&] { return run_in_arena(options, plan, wall_start); });
}

namespace {

int run_in_arena(const RunOptions& options, RunPlan& plan, Clock::time_point wall_start) {
  Scene& scene = plan.scene;

  const std::unique_ptr<Simulation> simulation =
      plan.resumed
          ? reading_checkpoint(*options.resume, "", [&] { return std::make_unique<Simulation>(scene, *plan.resumed); })
          : std::make_unique<Simulation>(scene);
  Simulation& sim = *simulation;
  for (SceneObject& object : scene.objects) {  // meshed: the simulation holds them now
    object.surface.reset();
    object.tet_mesh.reset();
  }
  const long long setup_peak_bytes = peak_memory_bytes();  // meshing done, nothing stepped
  int frame = 0;
  SimulationTotals initial = sim.totals();
  const bool resuming = plan.resumed.has_value();
  if (resuming) {
    frame = reading_checkpoint(*options.resume, "", [&] {
      return resumed_frame(*options.resume, *plan.resumed, scene, sim, plan.last_frame, initial);
    });
    plan.resumed.reset();  // the simulation holds the state now; a second copy would last the whole run
  }

  // 2. The output folder; 3. the frames; 4. the summary.
  Run run(options, scene, sim, plan.folder, frame, plan.last_frame, initial);
  run.open(resuming);
  run.frames();
  const int exit_code = run.report(wall_start, setup_peak_bytes);
  // The built-in demo always ends with its contact sheet.
  if (options.preview || (!options.scene && !options.resume)) {
    // The run's own result stands whatever happens to its picture.
    try {
      const fs::path sheet = render_contact_sheet(plan.folder, scene, 12, options.quiet);
      std::fprintf(stdout, "contact sheet: %s\n", sheet.string().c_str());
      std::fflush(stdout);
    } catch (const std::exception& e) {
      to_stderr(fmt::format("goo: error: no contact sheet: {}\n", e.what()));
    }
  }
  return exit_code;
}

}  // namespace
}  // namespace goo::app
