#pragma once
// Every key of a goo checkpoint, in one place (docs/running.md,
// "Checkpoints"): the simulation's clock and bodies (Simulation::save and
// load), what a run adds (run/*, scene/*: goo run and its resume), and what
// goo info shows. Each group has a writer and a reader; the readers throw
// goo::Error naming the key when it is missing or has the wrong shape.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/body.h"
#include "core/scene.h"
#include "core/state_record.h"

namespace goo::checkpoint {

/// time, steps, remeshes, last_time_step.
struct Clock {
  double time = 0.0;  ///< s
  std::int64_t steps = 0;
  std::int64_t remeshes = 0;
  double last_time_step = 0.0;  ///< s
};
void put_clock(StateSink& sink, const Clock& clock);
[[nodiscard]] Clock get_clock(const StateRecord& record);

/// bodies/count.
void put_body_count(StateSink& sink, std::size_t count);
[[nodiscard]] std::int64_t get_body_count(const StateRecord& record);

/// The prefix of body i's keys, "bodies/i/" (error messages name the field with it).
[[nodiscard]] std::string body_prefix(std::size_t i);

/// What a checkpoint holds of body i: bodies/i/{name, lattice,
/// lattice_spacing, the Body's arrays, pinned, rest_material_volume}.
struct StoredBody {
  std::string name;
  bool lattice = false;
  double lattice_spacing = 0.0;  ///< m
  Body body;                     ///< arrays only: no material, no incidence
  std::vector<Index> pinned;
};
/// Writes body i's arrays as they are, each streamed from `body`.
void put_body(StateSink& sink, std::size_t i, const std::string& name, bool lattice, double lattice_spacing,
              const Body& body, const std::vector<Index>& pinned);
[[nodiscard]] StoredBody get_body(const StateRecord& record, std::size_t i);

/// run/*: the frame written and the totals of the run's first frame.
struct RunFields {
  std::int64_t frame = 0;
  double initial_mass = 0.0;    ///< kg
  double initial_volume = 0.0;  ///< m³
  Eigen::Vector3d initial_momentum = Eigen::Vector3d::Zero();  ///< kg m/s
};
void put_run(StateSink& sink, const RunFields& run);
[[nodiscard]] RunFields get_run(const StateRecord& record);

/// scene/*: the scene's text, where it was read, and its mesh obstacles'
/// meshes (so a run resumes without the files it began from).
void put_scene(StateSink& sink, const Scene& scene);
[[nodiscard]] const std::string& get_scene_text(const StateRecord& record);
[[nodiscard]] const std::string& get_scene_source(const StateRecord& record);
[[nodiscard]] const std::string& get_scene_base_folder(const StateRecord& record);
/// The meshes by the obstacle field they belong to (none in a checkpoint
/// written before goo kept them), checked as a mesh file is.
[[nodiscard]] std::map<std::string, TriangleMesh> get_obstacle_meshes(const StateRecord& record);

}  // namespace goo::checkpoint
