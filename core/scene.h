#pragma once
// A scene: what to simulate and how, as plain values (docs/scene-format.md).
// io reads it from JSON (meshes loaded, every value checked); solvers build
// a Simulation from it; app runs it.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/constraints.h"
#include "core/material.h"
#include "core/obstacles.h"
#include "core/settings.h"
#include "core/tet_mesh.h"
#include "core/triangle_mesh.h"

namespace goo {

/// `static` solves for equilibrium with backward Euler's machinery
/// (BackwardEulerSettings::statics), its settings in Scene::backward_euler.
enum class IntegratorKind { newmark, backward_euler, statics };

/// Nodes inside an axis-aligned world box are held still (re-evaluated at
/// every re-mesh: pinned nodes do not move, so the region stays theirs).
struct PinnedRegion {
  Eigen::AlignedBox3d box;
};

struct SceneObject {
  std::string name;
  /// Exactly one of the two: a closed surface meshed on the lattice (and
  /// re-meshed), or a tetrahedral mesh simulated as it is (no re-meshing).
  std::optional<TriangleMesh> surface;
  std::optional<TetMesh> tet_mesh;
  Material material;
  double lattice_spacing = 0.0;  ///< h, m (surface objects)
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();          ///< m/s
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< rad/s, about the centroid of the geometry
  std::vector<PinnedRegion> pinned;
  SelfCollisionSettings self_collisions;
};

struct RemeshSettings {
  bool enabled = true;
  RemeshThresholds thresholds;
  bool upkeep = true;  ///< split and collapse surface edges at each re-mesh
  UpkeepSettings upkeep_settings;
  /// Copy elements and nodes per part of the material, so that parts of a
  /// body closer than the spacing share no element (docs/lattice.md).
  bool separate_parts = true;
};

struct OutputSettings {
  std::string folder = "goo-out";
  double fps = 24.0;
  int frames = 72;          ///< frames after frame 0 (the initial state)
  bool ply = true;          ///< frames/frame_NNNNN.ply (binary)
  bool obj = false;         ///< frames/frame_NNNNN.obj
  bool tet_mesh = false;    ///< frames/tets_NNNNN.vtu (the finite-element mesh)
  bool hdf5 = true;         ///< run.h5 with the run.xdmf sidecar
};

/// When a run is declared numerically failed.
struct SafetyLimits {
  double max_speed = 1000.0;  ///< m/s: any node faster is an energy blow-up
};

/// Where `goo render` looks from (without one it frames the whole run).
struct SceneCamera {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< the eye, m
  Eigen::Vector3d target = Eigen::Vector3d::Zero();    ///< the point at the picture's centre, m
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();       ///< the picture's up direction
  double fov_degrees = 35.0;                           ///< vertical field of view
};

struct Scene {
  std::string source;       ///< the file it came from ("<built-in demo>" for the default)
  std::string text;         ///< the scene's JSON text, as read (stored in checkpoints)
  std::string base_folder;  ///< where relative paths in the scene resolve
  Eigen::Vector3d gravity = standard_gravity();  ///< m/s², on every body (the integrators' only source of it)
  IntegratorKind integrator = IntegratorKind::newmark;
  NewmarkSettings newmark;
  BackwardEulerSettings backward_euler;
  SurfaceTensionSettings surface_tension;  ///< every body's, whatever the integrator
  std::optional<HalfSpace> ground;       ///< a floor under every object
  std::vector<Obstacle> obstacles;
  std::vector<SceneObject> objects;
  BodyCollisionSettings body_collisions;  ///< between objects (two or more)
  RemeshSettings remesh;
  OutputSettings output;
  int checkpoint_every_frames = 24;  ///< 0: only when the run ends or is interrupted
  SafetyLimits limits;
  std::optional<SceneCamera> camera;  ///< for pictures only
  /// Each mesh obstacle's mesh as read from its file (before its scale), by
  /// the JSON path of its `path` field: checkpoints keep them, so a run
  /// resumes without the files.
  std::map<std::string, TriangleMesh> obstacle_meshes;
};

std::string_view to_string(IntegratorKind kind);

}  // namespace goo
