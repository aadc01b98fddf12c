#pragma once
// The step pipeline of architecture.md ("One time step"), assembled per scene
// from only the stages it needs, behind a thin owner of the state: bodies,
// their integrators and constraints, the clock and the counters.
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/body.h"
#include "core/contact/self_collisions.h"
#include "core/scene.h"
#include "core/state_record.h"
#include "core/volume_projection.h"
#include "solvers/integrator.h"
#include "solvers/remesh.h"
#include "solvers/stepping.h"

namespace goo {

/// A run that went numerically wrong (a non-finite value, a node faster than
/// the scene's limits.max_speed). Not bad input: the message is a diagnosis
/// naming the step, the time, the body, the node and an element holding it.
class NumericalFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Wall time spent per stage, seconds.
struct StageTimes {
  double integrate = 0.0;     ///< forces, integration, plastic flow, smoothing, collisions (one integrator step)
  double remesh_check = 0.0;  ///< the re-mesh trigger
  double remesh = 0.0;        ///< surface upkeep, new lattice mesh, transfer, exact masses
  double safety = 0.0;        ///< the finite-value and speed checks
  StepTimes step;             ///< `integrate`, by stage
  RemeshTimes remesh_stages;  ///< `remesh`, by stage (the re-meshes that happened)
};

/// Totals over every body.
struct SimulationTotals {
  double mass = 0.0;                                   ///< Σ m, kg
  double volume = 0.0;                                 ///< enclosed by the surfaces, m³
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();  ///< Σ m v, kg m/s
  double max_speed = 0.0;                              ///< max |v| over nodes, m/s
  Index nodes = 0;
  Index elements = 0;
  Index surface_vertices = 0;
  Index surface_triangles = 0;
  SeparationReport separation;  ///< of the bodies' current meshes (remesh.separate_parts)
};

struct SimulationBody {
  std::string name;
  Body body;
  bool lattice = false;  ///< meshed on the lattice around its surface, re-meshed when degraded
  double h = 0.0;        ///< lattice spacing, m
  std::vector<PinnedRegion> regions;
  std::vector<Index> pinned;  ///< node ids held still
  SeparationReport separation;  ///< how its current mesh was copied per part of the material
  SelfCollisionSettings self_collisions;
};

class Simulation {
 public:
  /// Builds every body at t = 0: surface objects meshed on the lattice,
  /// tetrahedral objects as they are with their boundary as the embedded
  /// surface; initial velocity v + ω × (x − c), c the centroid of the object.
  explicit Simulation(const Scene& scene);
  /// The bodies as `state` holds them (a checkpoint's, load()'s layout):
  /// nothing is meshed, and the scene's objects need no geometry. Throws
  /// goo::Error naming the field for a state that does not fit the scene.
  Simulation(const Scene& scene, const StateRecord& state);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Steps every body until t_end (each body on its own time steps, landing
  /// exactly on t_end; bodies that collide with each other on common
  /// steps, the smallest any of them needs), re-meshing a lattice body after a step that trips
  /// the trigger. `stop` is asked after each step; true abandons the advance
  /// (returns false; the state is then between steps). Throws
  /// NumericalFailure when a step produces a non-finite or runaway state.
  bool advance_to(double t_end, const std::function<bool()>& stop = {});

  /// Drops what the integrators carry from step to step (cached forces, a
  /// lagged factor), so that what follows depends on the state alone. The
  /// run calls it at every frame, so that a checkpoint resumes bitwise.
  void make_restart_point();

  /// The complete state (every array of every body, clock, counters).
  [[nodiscard]] StateRecord save() const;
  /// The same, array by array into `sink` (a checkpoint writes each as it comes).
  void save(StateSink& sink) const;
  /// Replaces the state with a saved one of the same scene (goo::Error if
  /// it does not fit: missing arrays, wrong shapes, another body count).
  void load(const StateRecord& record);

  [[nodiscard]] double time() const { return time_; }
  [[nodiscard]] std::int64_t steps() const { return steps_; }
  [[nodiscard]] std::int64_t remeshes() const { return remeshes_; }
  [[nodiscard]] const StageTimes& stage_times() const { return times_; }
  /// What the self-collision stages did, all bodies and steps together.
  [[nodiscard]] const SelfCollisionStats& self_collision_totals() const { return self_collisions_; }
  /// The incompressibility projections of the whole run, and those since the
  /// last call of take_frame_volume_stats (which resets them).
  [[nodiscard]] const VolumeProjectionStats& volume_totals() const { return volume_total_; }
  VolumeProjectionStats take_frame_volume_stats() { return std::exchange(volume_frame_, VolumeProjectionStats{}); }
  /// Newmark's damping solves: the whole run's, and those since the last
  /// take_frame_damping_stats.
  [[nodiscard]] const DampingSolveStats& damping_totals() const { return damping_total_; }
  DampingSolveStats take_frame_damping_stats() { return std::exchange(damping_frame_, DampingSolveStats{}); }
  [[nodiscard]] const std::vector<SimulationBody>& bodies() const { return bodies_; }
  [[nodiscard]] SimulationTotals totals() const;
  /// Every body's surface at the current positions, in one mesh (body order).
  [[nodiscard]] TriangleMesh surface() const;
  /// Each triangle of surface()'s body (its index in bodies()).
  [[nodiscard]] std::vector<std::int32_t> surface_bodies() const;
  /// The Δt the last step of each body took (0 before any step), s.
  [[nodiscard]] double last_time_step() const { return last_dt_; }

 private:
  /// The surfaces of every body but `skipped` in one mesh (body order).
  [[nodiscard]] TriangleMesh surfaces_except(std::size_t skipped) const;
  void attach(std::size_t i, double time);  ///< (re)builds body i's constraints and integrator, its clock at `time`
  /// One step of body i alone (its own Δt, at most max_dt), then checks and a re-mesh if due.
  void step_body(std::size_t i, double max_dt);
  /// One step of every body together (collisions between bodies): the
  /// smallest Δt any body needs, then checks and re-meshes.
  void step_together(double max_dt);
  /// Collisions between bodies (and within each) over the common step from
  /// x_start to the bodies' positions (Bridson et al. 2002, as one surface).
  /// joint_: every body's elements, masses and surface side by side (ids
  /// offset, node_offset_ per body), their collision groups and thickness.
  void build_joint_body();
  void collide_bodies(const std::vector<Points>& x_start, double dt);
  void check_state(std::size_t i) const;
  void remesh_if_due(std::size_t i);
  /// Counts the integrator steps a report covers.
  void record(const StepReport& report);
  /// call() (an integrator's step of body i); a goo::Error it throws, a
  /// solve that found no answer, becomes a NumericalFailure naming the body
  /// (unless the integrator has no advice for it).
  template <class Call>
  auto guarded(std::size_t i, Call&& call);
  /// Body i's self-collision parameters (thickness resolved).
  [[nodiscard]] SelfCollisionParameters self_collision_parameters(std::size_t i) const;

  Scene scene_;  // settings, obstacles and ground (meshes of objects dropped)
  std::vector<SimulationBody> bodies_;
  std::vector<std::unique_ptr<Integrator>> integrators_;
  bool together_ = false;  ///< bodies collide with each other: common steps, one collision stage
  SelfCollisions joint_collisions_;  // the stage over all bodies' surfaces
  Body joint_;  // every body's elements, masses and surface, concatenated (positions unused)
  std::vector<Index> node_offset_;  // per body, its first node in joint_
  double joint_thickness_ = 0.0;  // the stage's thickness, m (set with joint_)
  bool joint_stale_ = true;  // a body was re-meshed or loaded: joint_ and the groups rebuilt
  double time_ = 0.0;
  double last_dt_ = 0.0;
  std::int64_t steps_ = 0;
  std::int64_t remeshes_ = 0;
  SelfCollisionStats self_collisions_;
  VolumeProjectionStats volume_total_, volume_frame_;
  DampingSolveStats damping_total_, damping_frame_;
  StageTimes times_;
};

}  // namespace goo
