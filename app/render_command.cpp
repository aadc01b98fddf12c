#include "app/render_command.h"

#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "app/numbered_name.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "io/run_file.h"
#include "io/scene_io.h"
#include "io/surface_mesh_io.h"
#include "render/renderer.h"

namespace goo::app {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr std::uint8_t kInk[3] = {40, 40, 48};

/// Writes a picture atomically (beside it, then renamed).
void write_picture(const fs::path& path, const render::Image& image) {
  const std::vector<std::uint8_t> bytes = render::encode_png(image);
  io::write_file_atomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  });
}

void to_stderr(const std::string& text) {
  // Progress must never stop a render (a reader that went away).
  [[maybe_unused]] const auto written = ::write(STDERR_FILENO, text.data(), text.size());
}

/// Progress on long renders: redrawn in place on a terminal, a line every
/// five seconds otherwise.
class Progress {
 public:
  Progress(bool quiet, int total, std::string what)
      : quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0), total_(total), what_(std::move(what)) {}
  void update(int done) {
    if (quiet_) return;
    const double now = std::chrono::duration<double>(Clock::now() - start_).count();
    if (done < total_ && now - shown_ < (tty_ ? 0.1 : 5.0)) return;
    shown_ = now;
    const std::string text = fmt::format("rendering {} {}/{}  {:.1f} s", what_, done, total_, now);
    to_stderr(tty_ ? fmt::format("\r{}\x1b[K{}", text, done >= total_ ? "\n" : "") : fmt::format("goo: {}\n", text));
  }

 private:
  bool quiet_, tty_;
  int total_;
  std::string what_;
  Clock::time_point start_ = Clock::now();
  double shown_ = -1e9;
};

/// The frames a run folder holds: number → file (PLY preferred over OBJ).
std::map<int, fs::path> list_frames(const fs::path& folder) {
  std::map<int, fs::path> frames;
  const fs::path dir = folder / "frames";
  std::error_code error;
  if (!fs::is_directory(dir, error)) return frames;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string file = entry.path().filename().string();
    const auto ply = numbered_name(file, "frame_", ".ply"), obj = numbered_name(file, "frame_", ".obj");
    if (!ply && !obj) continue;
    auto [it, inserted] = frames.emplace(static_cast<int>(ply ? *ply : *obj), entry.path());
    if (!inserted && ply) it->second = entry.path();
  }
  return frames;
}

/// The scene a run came from: the one given, or the one its summary.json names.
Scene find_scene(const fs::path& run, const std::optional<std::string>& given) {
  if (given) return io::read_scene(*given);
  const fs::path summary = run / "summary.json";
  std::ifstream in(summary);
  if (!in)
    throw Error(fmt::format("{}: no summary.json to name the run's scene (the run has not ended?); give the scene "
                            "with --scene",
                            run.string()));
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: not valid JSON ({}); give the scene with --scene", summary.string(), e.what()));
  }
  if (!j.is_object() || !j.contains("scene") || !j["scene"].is_string())
    throw Error(fmt::format("{}: names no scene; give it with --scene", summary.string()));
  const std::string source = j["scene"].get<std::string>();
  if (source == "<built-in demo>") return io::demo_scene();
  std::error_code error;
  if (!fs::is_regular_file(source, error))
    throw Error(fmt::format("{}: the run's scene '{}' is not there any more; give it with --scene", summary.string(),
                            source));
  return io::read_scene(source);
}

std::pair<int, int> parse_size(const std::string& text, int width, int height) {
  if (text.empty()) return {width, height};
  const std::size_t x = text.find('x');
  const auto w_part = x == std::string::npos ? std::nullopt : numbered_name(text.substr(0, x), "", "", 1);
  const auto h_part = x == std::string::npos ? std::nullopt : numbered_name(text.substr(x + 1), "", "", 1);
  if (!w_part || !h_part)
    throw Error(fmt::format("--size must be WIDTHxHEIGHT in pixels (say 960x720), got '{}'", text));
  const long w = *w_part, h = *h_part;
  if (w < 16 || h < 16 || w > 8192 || h > 8192)
    throw Error(fmt::format("--size: each side must be 16 to 8192 pixels, got {}x{}", w, h));
  return {static_cast<int>(w), static_cast<int>(h)};
}

/// A checker square of 1, 2 or 5 × 10^k m, about a tenth of the size.
double tile_for(double size) {
  const double rough = std::max(size / 10.0, 1e-6);
  const double decade = std::pow(10.0, std::floor(std::log10(rough)));
  for (const double step : {1.0, 2.0, 5.0})
    if (step * decade >= rough) return step * decade;
  return 10.0 * decade;
}

/// The executable `name` on the PATH, if any.
std::optional<fs::path> on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (!path) return std::nullopt;
  std::string all = path;
  std::size_t start = 0;
  while (start <= all.size()) {
    const std::size_t end = std::min(all.find(':', start), all.size());
    const fs::path candidate = fs::path(all.substr(start, end - start)) / name;
    if (!candidate.empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return std::nullopt;
}

/// Runs a program without a shell; its exit code (−1 if it could not start).
int run_program(const std::vector<std::string>& argv) {
  const pid_t child = ::fork();
  if (child < 0) return -1;
  if (child == 0) {
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// What is drawn of a run: the frames, the scene's floor and obstacles, a camera.
class RunPictures {
 public:
  RunPictures(fs::path run, std::map<int, fs::path> frames, const Scene& scene, bool wireframe)
      : run_(std::move(run)), frames_(std::move(frames)), scene_(scene), wireframe_(wireframe) {
    for (const Obstacle& o : scene_.obstacles) obstacle_meshes_.push_back(o.shape->boundary());
  }

  /// The box every body stays in over `frames` (the camera frames it).
  Eigen::AlignedBox3d bounds(const std::vector<int>& frames, Progress* progress) const {
    Eigen::AlignedBox3d box;
    int done = 0;
    for (const int f : frames) {
      const io::FrameSurface s = io::read_frame_surface(frames_.at(f));
      for (Index v = 0; v < s.mesh.num_vertices(); ++v) box.extend(Eigen::Vector3d(s.mesh.vertices.row(v).transpose()));
      if (progress) progress->update(++done);
    }
    if (box.isEmpty()) box = Eigen::AlignedBox3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    return box;
  }

  render::Camera camera(const Eigen::AlignedBox3d& box, double azimuth, double elevation, double aspect) const {
    if (scene_.camera) {
      render::Camera c;
      c.eye = scene_.camera->position;
      c.target = scene_.camera->target;
      c.up = scene_.camera->up;
      c.fov_degrees = scene_.camera->fov_degrees;
      const double distance = (c.eye - c.target).norm();
      const double radius = 0.5 * box.diagonal().norm() + (box.center() - c.target).norm();
      c.near = std::max(1e-3 * distance, distance - 4.0 * radius);
      c.far = distance + 40.0 * std::max(radius, 1e-3 * distance);
      return c;
    }
    return render::frame_box(box, azimuth, elevation, aspect);
  }

  render::Image draw(render::Renderer& renderer, int frame, const render::Camera& camera,
                     const Eigen::AlignedBox3d& box) const {
    const io::FrameSurface s = io::read_frame_surface(frames_.at(frame));
    const double time = frame / scene_.output.fps;
    // One mesh per body, sharing the frame's vertices.
    std::map<std::int32_t, std::vector<Index>> by_body;
    for (Index t = 0; t < s.mesh.num_triangles(); ++t) by_body[s.face_body[static_cast<std::size_t>(t)]].push_back(t);
    std::vector<TriangleMesh> bodies;
    std::vector<std::int32_t> ids;
    for (const auto& [id, triangles] : by_body) {
      TriangleMesh m;
      m.vertices = s.mesh.vertices;
      m.triangles.resize(static_cast<Index>(triangles.size()), 3);
      for (std::size_t k = 0; k < triangles.size(); ++k) m.triangles.row(static_cast<Index>(k)) = s.mesh.triangles.row(triangles[k]);
      bodies.push_back(std::move(m));
      ids.push_back(id);
    }
    render::Picture picture;
    picture.bounds = box;
    for (std::size_t k = 0; k < bodies.size(); ++k) picture.meshes.push_back({&bodies[k], render::body_colour(ids[k]), 1.0f});
    std::vector<TriangleMesh> placed(obstacle_meshes_.size());
    for (std::size_t k = 0; k < obstacle_meshes_.size(); ++k) {
      if (obstacle_meshes_[k].num_triangles() == 0) continue;
      const Eigen::Isometry3d to_world = scene_.obstacles[k].motion.transform(time);
      placed[k] = obstacle_meshes_[k];
      for (Index v = 0; v < placed[k].num_vertices(); ++v)
        placed[k].vertices.row(v) = (to_world * Eigen::Vector3d(placed[k].vertices.row(v).transpose())).transpose();
      picture.meshes.push_back({&placed[k], {0.45f, 0.50f, 0.58f}, 0.35f});
      picture.bounds.extend(placed[k].vertices.colwise().minCoeff().transpose());
      picture.bounds.extend(placed[k].vertices.colwise().maxCoeff().transpose());
    }
    if (scene_.ground) {
      render::Floor floor;
      floor.height = scene_.ground->offset;
      floor.centre = box.center().head<2>();
      const double size = std::max(box.sizes().head<2>().maxCoeff(), box.sizes().z());
      floor.half_size = 3.0 * std::max(size, 1e-3);
      floor.tile = tile_for(size);
      picture.floor = floor;
      picture.bounds.extend(Eigen::Vector3d(box.min().x(), box.min().y(), floor.height));
    }
    if (wireframe_) {
      const fs::path tets = run_ / "frames" / fmt::format("tets_{:05d}.vtk", frame);
      std::error_code error;
      if (!fs::is_regular_file(tets, error))
        throw Error(fmt::format("{}: --wireframe needs the tet mesh of every frame drawn (the scene's output.tet_mesh: "
                                "true); this frame has none",
                                tets.string()));
      const TetMesh mesh = io::read_tet_mesh_vtk(tets);
      std::set<std::pair<Index, Index>> edges;
      for (Index e = 0; e < mesh.num_elements(); ++e)
        for (int a = 0; a < 4; ++a)
          for (int b = a + 1; b < 4; ++b)
            edges.insert(std::minmax(mesh.tets(e, a), mesh.tets(e, b)));
      render::LineItem lines;
      lines.colour = {0.05f, 0.05f, 0.08f};
      for (const auto& [a, b] : edges) {
        lines.segments.push_back(mesh.positions.row(a).transpose());
        lines.segments.push_back(mesh.positions.row(b).transpose());
      }
      picture.lines.push_back(std::move(lines));
    }
    render::Image image = renderer.draw(picture, camera);
    const int scale = std::max(1, image.height / 180);
    render::draw_text(image, fmt::format("frame {}  t = {:.3f} s", frame, time), 6 * scale, image.height - 10 * scale,
                      scale, kInk);
    return image;
  }

  [[nodiscard]] const Scene& scene() const { return scene_; }

 private:
  fs::path run_;
  std::map<int, fs::path> frames_;
  const Scene& scene_;
  bool wireframe_;
  std::vector<TriangleMesh> obstacle_meshes_;
};

/// N frames spread evenly over `frames`, the first and the last included.
std::vector<int> spread(const std::vector<int>& frames, int n) {
  if (static_cast<int>(frames.size()) <= n) return frames;
  std::vector<int> out;
  for (int k = 0; k < n; ++k) {
    const std::size_t i = n == 1 ? 0
                                 : static_cast<std::size_t>(std::lround(static_cast<double>(k) *
                                                                        static_cast<double>(frames.size() - 1) / (n - 1)));
    if (out.empty() || out.back() != frames[i]) out.push_back(frames[i]);
  }
  return out;
}

fs::path write_sheet(const RunPictures& pictures, const std::vector<int>& frames, int width, int height,
                     const fs::path& out, double azimuth, double elevation, bool quiet) {
  Progress bounds_progress(quiet, static_cast<int>(frames.size()), "(framing)");
  const Eigen::AlignedBox3d box = pictures.bounds(frames, &bounds_progress);
  render::Renderer renderer(width, height);
  const render::Camera camera = pictures.camera(box, azimuth, elevation, static_cast<double>(width) / height);
  const int n = static_cast<int>(frames.size());
  const int columns = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n)))));
  const int rows = (n + columns - 1) / columns;
  constexpr int kGap = 4, kTitle = 28;
  render::Image sheet(columns * width + (columns + 1) * kGap, rows * height + (rows + 1) * kGap + kTitle, 250);
  const Scene& scene = pictures.scene();
  render::draw_text(sheet, fmt::format("{}  ({} frames at {} fps)",
                                      scene.source == "<built-in demo>" ? std::string("the built-in demo")
                                                                        : fs::path(scene.source).filename().string(),
                                      n,
                                       scene.output.fps),
                    kGap + 4, 8, 2, kInk);
  Progress progress(quiet, n, "contact sheet");
  for (int k = 0; k < n; ++k) {
    const render::Image tile = pictures.draw(renderer, frames[static_cast<std::size_t>(k)], camera, box);
    render::paste(sheet, tile, kGap + (k % columns) * (width + kGap), kTitle + kGap + (k / columns) * (height + kGap));
    progress.update(k + 1);
  }
  const fs::path path = out / "sheet.png";
  write_picture(path, sheet);
  return path;
}

void encode_mp4(const fs::path& folder, const std::string& pattern, int start, double fps, const fs::path& video,
                bool quiet) {
  const auto ffmpeg = on_path("ffmpeg");
  if (!ffmpeg) {
    to_stderr(fmt::format(
        "goo render: ffmpeg is not installed (Debian package 'ffmpeg'), so no MP4 was written; the PNG pictures "
        "are in {}\n",
        folder.string()));
    return;
  }
  const int code = run_program({ffmpeg->string(), "-y", "-loglevel", "error", "-framerate", fmt::format("{}", fps),
                                "-start_number", std::to_string(start), "-i", (folder / pattern).string(), "-vf",
                                "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", "-c:v", "libx264",
                                video.string()});
  if (code != 0)
    throw Error(fmt::format("{}: ffmpeg failed (exit code {}) to encode the pictures", video.string(), code));
  if (!quiet) to_stderr(fmt::format("goo render: {}\n", video.string()));
}

}  // namespace

int render_run(const RenderOptions& options) {
  const fs::path run = options.run;
  std::error_code error;
  if (!fs::is_directory(run, error)) throw Error(fmt::format("{}: not a run folder (no such folder)", run.string()));
  const std::map<int, fs::path> all = list_frames(run);
  if (all.empty())
    throw Error(fmt::format("{}: holds no frames to render (frames/frame_NNNNN.ply or .obj)", run.string()));
  const int modes = (options.each ? 1 : 0) + (options.turntable ? 1 : 0);
  if (modes > 1) throw Error("--each and --turntable are different pictures: choose one");
  if (options.sheet < 1 || options.sheet > 400) throw Error(fmt::format("--sheet must be 1 to 400 frames, got {}", options.sheet));
  if (options.views < 2 || options.views > 3600) throw Error(fmt::format("--views must be 2 to 3600, got {}", options.views));
  if (!std::isfinite(options.azimuth) || !std::isfinite(options.elevation) || std::abs(options.elevation) >= 90.0)
    throw Error("--elevation must be strictly between -90 and 90 degrees, --azimuth finite");
  std::vector<int> frames;
  for (const auto& [f, path] : all)
    if ((!options.first || f >= *options.first) && (!options.last || f <= *options.last)) frames.push_back(f);
  if (frames.empty())
    throw Error(fmt::format("{}: no frame between {} and {} (it holds frames {} to {})", run.string(),
                            options.first.value_or(all.begin()->first), options.last.value_or(all.rbegin()->first),
                            all.begin()->first, all.rbegin()->first));
  if (options.turntable && !all.contains(*options.turntable))
    throw Error(fmt::format("{}: --turntable {}: no such frame (it holds frames {} to {})", run.string(),
                            *options.turntable, all.begin()->first, all.rbegin()->first));
  const bool each = options.each || (options.mp4 && !options.turntable);
  const auto [width, height] = parse_size(options.size, each || options.turntable ? 960 : 480, each || options.turntable ? 720 : 360);
  const Scene scene = find_scene(run, options.scene);
  const fs::path out = options.out ? fs::path(*options.out) : run / "render";
  if (fs::exists(out, error) && !fs::is_directory(out, error))
    throw Error(fmt::format("{}: --out must be a folder for the pictures, and this is a file", out.string()));
  fs::create_directories(out, error);
  if (error || !fs::is_directory(out, error))
    throw WriteError(fmt::format("{}: cannot create the folder for the pictures: {}", out.string(), error.message()));
  RunPictures pictures(run, all, scene, options.wireframe);

  if (options.turntable) {
    const int frame = *options.turntable;
    const fs::path folder = out / fmt::format("turntable_{:05d}", frame);
    fs::create_directories(folder, error);
    const Eigen::AlignedBox3d box = pictures.bounds({frame}, nullptr);
    render::Renderer renderer(width, height);
    const render::Camera camera = pictures.camera(box, options.azimuth, options.elevation, static_cast<double>(width) / height);
    Progress progress(options.quiet, options.views, fmt::format("turntable of frame {}", frame));
    for (int k = 0; k < options.views; ++k) {
      const render::Camera view = render::orbit(camera, 360.0 * k / options.views);
      write_picture(folder / fmt::format("view_{:03d}.png", k), pictures.draw(renderer, frame, view, box));
      progress.update(k + 1);
    }
    if (!options.quiet) to_stderr(fmt::format("goo render: {} views in {}\n", options.views, folder.string()));
    if (options.mp4) encode_mp4(folder, "view_%03d.png", 0, 24.0, out / fmt::format("turntable_{:05d}.mp4", frame), options.quiet);
    return 0;
  }
  if (each) {
    Progress bounds_progress(options.quiet, static_cast<int>(frames.size()), "(framing)");
    const Eigen::AlignedBox3d box = pictures.bounds(frames, &bounds_progress);
    render::Renderer renderer(width, height);
    const render::Camera camera = pictures.camera(box, options.azimuth, options.elevation, static_cast<double>(width) / height);
    Progress progress(options.quiet, static_cast<int>(frames.size()), "frames");
    int done = 0;
    for (const int f : frames) {
      write_picture(out / fmt::format("frame_{:05d}.png", f), pictures.draw(renderer, f, camera, box));
      progress.update(++done);
    }
    if (!options.quiet) to_stderr(fmt::format("goo render: {} pictures in {}\n", frames.size(), out.string()));
    if (options.mp4) {
      // ffmpeg reads a numbered sequence without gaps.
      for (std::size_t k = 1; k < frames.size(); ++k)
        if (frames[k] != frames[k - 1] + 1)
          throw Error(fmt::format("{}: frame {} is missing, so the frames cannot make a video", run.string(), frames[k - 1] + 1));
      encode_mp4(out, "frame_%05d.png", frames.front(), scene.output.fps, out / "frames.mp4", options.quiet);
    }
    return 0;
  }
  const fs::path sheet = write_sheet(pictures, spread(frames, options.sheet), width, height, out, options.azimuth,
                                     options.elevation, options.quiet);
  std::fprintf(stdout, "%s\n", sheet.string().c_str());
  return 0;
}

fs::path render_contact_sheet(const fs::path& folder, const Scene& scene, int sheet, bool quiet) {
  const std::map<int, fs::path> all = list_frames(folder);
  if (all.empty()) throw Error(fmt::format("{}: holds no frames to render", folder.string()));
  std::vector<int> frames;
  for (const auto& [f, path] : all) frames.push_back(f);
  const fs::path out = folder / "render";
  std::error_code error;
  fs::create_directories(out, error);
  RunPictures pictures(folder, all, scene, false);
  return write_sheet(pictures, spread(frames, sheet), 480, 360, out, -30.0, 25.0, quiet);
}

}  // namespace goo::app
