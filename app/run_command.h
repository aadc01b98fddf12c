#pragma once
// goo run: a scene in, frames, checkpoints and a summary out
// (docs/running.md).
#include <optional>
#include <string>

namespace goo::app {

struct RunOptions {
  std::optional<std::string> scene;   ///< scene file; none: the built-in demo (or the checkpoint's scene)
  std::optional<std::string> out;     ///< output folder; default the scene's output.folder
  std::optional<int> frames;          ///< last frame; default the scene's output.frames
  int threads = 0;                    ///< 0: all cores
  std::optional<std::string> resume;  ///< checkpoint to continue from
  bool quiet = false;
  bool overwrite = false;  ///< replace the frames of an earlier run in the output folder
  bool preview = false;    ///< a contact sheet of the frames when the run ends (goo render)
};

/// Exit codes of goo run (beside 2 for bad input, thrown as goo::Error).
inline constexpr int kExitNumericalFailure = 3;
inline constexpr int kExitWriteFailure = 4;
inline constexpr int kExitInterrupted = 130;

/// Runs the scene. Returns 0 when every frame was written, 3 after a
/// numerical failure (diagnosed, last good checkpoint kept), 4 when an
/// output file could not be written (a full disk: the files written before
/// are kept), 130 when interrupted by SIGINT or SIGTERM (a checkpoint of the
/// last whole frame written). Bad input throws goo::Error before anything is
/// written; an output that cannot be written before the first frame,
/// goo::WriteError.
int run_scene(const RunOptions& options);

}  // namespace goo::app
