#pragma once
// Scene files: JSON, read strictly (docs/scene-format.md). An unknown key, a
// wrong type, an impossible value, a missing or invalid mesh file: each is
// refused with goo::Error naming the file and the JSON path
// ("drop.json: /objects/0/material/poisson_ratio must be in [0, 0.5), got 0.5").
#include <filesystem>
#include <string>
#include <string_view>

#include "core/scene.h"

namespace goo::io {

/// The current scene format version (the "version" key; 1 if absent).
inline constexpr int kSceneFormatVersion = 1;

/// Reads a scene file; relative paths in it resolve from its folder.
Scene read_scene(const std::filesystem::path& path);

/// Where a scene's geometry comes from when it is not read from its files.
struct SceneInputs {
  /// The objects' geometry is not read (their bodies come from a
  /// checkpoint): mesh and tet_mesh files are not opened, and the checks
  /// made with their geometry when the run began are not made again.
  bool objects_from_checkpoint = false;
  /// Mesh obstacles by the JSON path of their `path` field (as
  /// Scene::obstacle_meshes); any other is read from its file.
  const std::map<std::string, TriangleMesh>* obstacle_meshes = nullptr;
};

/// Parses scene text; `source` names it in errors, relative paths resolve
/// from `base_folder`.
Scene parse_scene(std::string_view text, const std::string& source, const std::filesystem::path& base_folder,
                  const SceneInputs& inputs = {});

/// The built-in demo's scene text: the Stanford bunny of gooey jelly, a
/// 75k-triangle surface on a coarse lattice, dropped onto a ball; a second
/// and a half at 24 frames per second. Its mesh, "bunny00.off", resolves
/// from demo_assets_folder().
std::string_view default_scene_text();

/// The folder the built-in demo reads bunny00.off from: $GOO_ASSETS_DIR,
/// else the assets/ folder of the source tree goo was built from
/// (scripts/fetch-assets fills it), else ./assets. Throws an Error naming
/// every place it looked when none holds it.
std::filesystem::path demo_assets_folder();

/// The built-in demo's scene, read.
Scene demo_scene();

}  // namespace goo::io
