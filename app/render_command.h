#pragma once
// goo render: pictures of a run's frames (docs/rendering.md).
#include <filesystem>
#include <optional>
#include <string>

#include "core/scene.h"

namespace goo::app {

struct RenderOptions {
  std::string run;                     ///< the run's output folder
  std::optional<std::string> out;      ///< where the pictures go; default RUN/render
  std::optional<std::string> scene;    ///< the scene (floor, obstacles, camera); default the one summary.json names
  int sheet = 12;                      ///< frames on the contact sheet (the default output)
  bool each = false;                   ///< one picture per frame
  std::optional<int> turntable;        ///< views of this frame all around it
  int views = 36;                      ///< views of a turntable
  std::optional<int> first, last;      ///< the frames considered (default all)
  std::string size;                    ///< "WxH" of each picture (default 960x720; 480x360 on a sheet)
  bool wireframe = false;              ///< the tet mesh's edges too (needs tet_mesh output)
  bool mp4 = false;                    ///< the pictures as a video through ffmpeg, when it is installed
  double azimuth = -30.0, elevation = 25.0;  ///< degrees: where the automatic camera looks from
  bool quiet = false;
};

/// Renders what `options` asks for. Returns 0. Bad options, a folder
/// without frames, unreadable frames or scene throw goo::Error (exit 2).
int render_run(const RenderOptions& options);

/// The contact sheet of a run just written (goo run --preview): `sheet`
/// frames of `folder` into folder/render/sheet.png. Returns its path.
std::filesystem::path render_contact_sheet(const std::filesystem::path& folder, const Scene& scene, int sheet = 12,
                                           bool quiet = false);

}  // namespace goo::app
