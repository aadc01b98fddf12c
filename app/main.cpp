// The goo command line.
#include <fmt/format.h>
#include <spdlog/cfg/env.h>

#include <CLI/CLI.hpp>

#include <csignal>
#include <iostream>

#include "app/info_command.h"
#include "app/render_command.h"
#include "app/run_command.h"
#include "core/error.h"
#include "core/log.h"
#include "core/memory_budget.h"

#ifndef GOO_VERSION
#error "GOO_VERSION must be defined by the build"
#endif

namespace {

/// Exit codes: 0 success, 1 internal failure, 2 bad input or usage, 4 an
/// output that cannot be written (goo run's own: docs/running.md).
constexpr int kExitInternal = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitWriteFailure = goo::app::kExitWriteFailure;

/// goo render's options (docs/rendering.md).
CLI::App* add_render_command(CLI::App& app, goo::app::RenderOptions& render_options) {
  CLI::App* render = app.add_subcommand(
      "render", "Pictures of a run's frames: a contact sheet (default), one per frame, or a turntable (docs/rendering.md)");
  render->add_option("RUN", render_options.run, "A run's output folder")->required();
  render->add_option("--out", render_options.out, "Folder for the pictures (default: RUN/render)");
  render->add_option("--scene", render_options.scene, "The run's scene (default: the one RUN/summary.json names)");
  render->add_option("--sheet", render_options.sheet, "Frames on the contact sheet (default 12)");
  render->add_flag("--each", render_options.each, "One picture per frame (frame_NNNNN.png)");
  render->add_option("--turntable", render_options.turntable, "Views all around this frame (turntable_NNNNN/)");
  render->add_option("--views", render_options.views, "Views of a turntable (default 36)");
  render->add_option("--first", render_options.first, "First frame considered");
  render->add_option("--last", render_options.last, "Last frame considered");
  render->add_option("--size", render_options.size, "WIDTHxHEIGHT of each picture (default 960x720; 480x360 on a sheet)");
  render->add_option("--azimuth", render_options.azimuth, "Degrees about the vertical the camera looks from (default -30)");
  render->add_option("--elevation", render_options.elevation, "Degrees above the horizon the camera looks from (default 25)");
  render->add_flag("--wireframe", render_options.wireframe, "Draw the tet mesh's edges (needs output.tet_mesh)");
  render->add_flag("--mp4", render_options.mp4, "Also encode the pictures as an MP4 (needs ffmpeg)");
  render->add_flag("--quiet", render_options.quiet, "No progress, only errors");
  return render;
}

}  // namespace

int main(int argc, char** argv) {
  // When whoever reads goo's output goes away (a harness killed, `goo run |
  // head`), writing a log line must fail quietly, not kill goo before it
  // writes its checkpoint and summary.
  std::signal(SIGPIPE, SIG_IGN);
  // A file-size limit (ulimit -f) reached is a write that fails (EFBIG),
  // reported naming the file like a full disk, not a process killed.
  std::signal(SIGXFSZ, SIG_IGN);
  // Re-meshes allocate and free the same buffers again and again: kept in
  // the process, not faulted in afresh each time (core/memory_budget.h).
  goo::keep_freed_memory();
  CLI::App app{"goo: viscoelastic and viscoplastic materials with thin features", "goo"};
  app.set_version_flag("--version", std::string("goo ") + GOO_VERSION);
  app.require_subcommand(0, 1);

  std::string mesh_path;
  bool json = false;
  CLI::App* info =
      app.add_subcommand("info", "Describe a surface mesh (OFF, OBJ, PLY, STL) and check it can be simulated, or describe a checkpoint");
  info->add_option("MESH", mesh_path, "Surface mesh file, or a goo checkpoint (.h5)")->required();
  info->add_flag("--json", json, "Print the report as JSON");

  goo::app::RunOptions run_options;
  CLI::App* run = app.add_subcommand(
      "run", "Run a scene: frames, checkpoints and summary.json into the output folder (no scene: the built-in demo)");
  run->add_option("SCENE", run_options.scene, "Scene file (JSON, docs/scene-format.md)");
  run->add_option("--out", run_options.out, "Output folder (default: the scene's output.folder)");
  run->add_option("--frames", run_options.frames, "Last frame to write (default: the scene's output.frames)");
  run->add_option("--threads", run_options.threads, "Worker threads (default: all cores)");
  run->add_option("--resume", run_options.resume, "Continue from this checkpoint (the scene is stored in it)");
  run->add_flag("--quiet", run_options.quiet, "No progress or log lines, only errors");
  run->add_flag("--overwrite", run_options.overwrite, "Replace the frames of an earlier run in the output folder");
  run->add_flag("--preview", run_options.preview, "Write a contact sheet of the frames when the run ends (render/sheet.png)");

  goo::app::RenderOptions render_options;
  CLI::App* render = add_render_command(app, render_options);
  goo::log();                      // create the logger, then let SPDLOG_LEVEL=debug (say) change its level
  spdlog::cfg::load_env_levels();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitBadInput;
  }

  try {
    if (info->parsed()) return goo::app::run_info(mesh_path, json, std::cout);
    if (render->parsed()) return goo::app::render_run(render_options);
    if (run->parsed()) {
      if (run_options.quiet && goo::log().level() < spdlog::level::warn) goo::log().set_level(spdlog::level::warn);
      return goo::app::run_scene(run_options);
    }
    std::cout << app.help();
    return 0;
  } catch (const goo::WriteError& e) {
    std::cout.flush();
    fmt::print(stderr, "goo: error: cannot write the output: {}\n", e.what());
    return kExitWriteFailure;
  } catch (const goo::Error& e) {
    std::cout.flush();
    fmt::print(stderr, "goo: error: {}\n", e.what());
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cout.flush();
    fmt::print(stderr, "goo: internal error: {}\n", e.what());
    return kExitInternal;
  }
}
