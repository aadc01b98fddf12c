#include "solvers/simulation.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include "core/error.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/surface_geometry.h"
#include "meshing/remesh_trigger.h"
#include "solvers/backward_euler.h"
#include "solvers/checkpoint_schema.h"
#include "solvers/newmark.h"
#include "solvers/remesh.h"
#include "solvers/stepping.h"

namespace goo {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::vector<Index> nodes_in(const Points& x, const std::vector<PinnedRegion>& regions) {
  std::vector<Index> out;
  for (Index n = 0; n < static_cast<Index>(x.rows()); ++n)
    for (const auto& r : regions)
      if (r.box.contains(x.row(n).transpose())) {
        out.push_back(n);
        break;
      }
  return out;
}

/// Coordinates a state may hold, m: far beyond any scene (a body at
/// limits.max_speed for a day), far below what breaks the lattice and grids.
constexpr double kFarthest = 1e9;

/// Refuses a loaded body whose values no run can produce (a checkpoint's
/// checksums hold, its numbers were written by something else): the first
/// bad value, by array and index.
void check_values(const Body& body, const std::string& prefix, const std::string& name) {
  auto fail = [&](const std::string& array, Eigen::Index at, const std::string& what) {
    throw Error(fmt::format("{}{} (body '{}'): entry {} {}", prefix, array, name, at, what));
  };
  auto points = [&](const Points& x, const std::string& array) {
    for (Eigen::Index n = 0; n < x.rows(); ++n)
      if (!x.row(n).allFinite() || x.row(n).cwiseAbs().maxCoeff() > kFarthest)
        fail(array, n, fmt::format("is ({}, {}, {}): not finite, or beyond {:g} m", x(n, 0), x(n, 1), x(n, 2), kFarthest));
  };
  points(body.rest_positions, "rest_positions");
  points(body.positions, "positions");
  for (Eigen::Index n = 0; n < body.velocities.rows(); ++n)
    if (!body.velocities.row(n).allFinite()) fail("velocities", n, "is not finite");
  for (Eigen::Index n = 0; n < body.masses.size(); ++n)
    if (!(std::isfinite(body.masses[n]) && body.masses[n] > 0.0))
      fail("masses", n, fmt::format("is {}: a mass is positive and finite", body.masses[n]));
  for (Eigen::Index e = 0; e < body.rest_volumes.size(); ++e) {
    const auto k = static_cast<std::size_t>(e);
    if (!(std::isfinite(body.rest_volumes[e]) && body.rest_volumes[e] > 0.0))
      fail("rest_volumes", e, fmt::format("is {}: a volume is positive and finite", body.rest_volumes[e]));
    if (!body.Dm_inv[k].allFinite()) fail("Dm_inv", e, "is not finite");
    if (!(body.Fp[k].allFinite() && body.Fp[k].determinant() > 0.0))
      fail("Fp", e, "is not finite or has no positive determinant");
    if (!std::isfinite(body.alpha[e])) fail("alpha", e, "is not finite");
    if (body.solid_fractions.size() > 0 &&
        !(body.solid_fractions[e] >= 0.0 && body.solid_fractions[e] <= 1.0 + 1e-9))
      fail("solid_fractions", e, fmt::format("is {}: a fraction is in [0, 1]", body.solid_fractions[e]));
  }
  // Barycentric coordinates sum to 1 (up to round-off); they may be
  // negative (smoothing re-embeds a vertex the mesh no longer holds in the
  // nearest element).
  for (Eigen::Index v = 0; v < body.embedding.bary.rows(); ++v) {
    const auto w = body.embedding.bary.row(v);
    if (!w.allFinite() || std::abs(w.sum() - 1.0) > 1e-9 * std::max(1.0, w.cwiseAbs().maxCoeff()))
      fail("embedding_bary", v, "is not a point's barycentric coordinates (finite, summing to 1)");
  }
  if (body.surface_triangles.rows() < 4)
    throw Error(fmt::format("{}surface_triangles (body '{}'): {} triangles cannot close a surface", prefix, name,
                            body.surface_triangles.rows()));
  if (!(std::isfinite(body.rest_material_volume) && body.rest_material_volume > 0.0))
    throw Error(fmt::format("{}rest_material_volume (body '{}'): {} is not a volume", prefix, name,
                            body.rest_material_volume));
}

}  // namespace

Simulation::Simulation(const Scene& scene, const StateRecord& state) : scene_(scene) {
  for (auto& object : scene_.objects) {
    object.surface.reset();
    object.tet_mesh.reset();
  }
  if (scene.objects.empty()) throw Error(fmt::format("{}: objects: the scene has no object to simulate", scene.source));
  for (const SceneObject& object : scene.objects) {
    SimulationBody b;  // what the state does not hold
    b.name = object.name;
    b.regions = object.pinned;
    b.self_collisions = object.self_collisions;
    b.body.material = object.material;
    bodies_.push_back(std::move(b));
  }
  together_ = bodies_.size() > 1 && scene_.body_collisions.enabled;
  integrators_.resize(bodies_.size());
  load(state);
}

Simulation::Simulation(const Scene& scene) : scene_(scene) {
  for (auto& object : scene_.objects) {  // the meshes are needed once, below
    object.surface.reset();
    object.tet_mesh.reset();
  }
  if (scene.objects.empty()) throw Error(fmt::format("{}: objects: the scene has no object to simulate", scene.source));
  for (const SceneObject& object : scene.objects) {
    SimulationBody b;
    b.name = object.name;
    b.regions = object.pinned;
    b.self_collisions = object.self_collisions;
    Eigen::Vector3d centre;
    if (object.surface) {
      b.lattice = true;
      b.h = object.lattice_spacing;
      centre = surface_integrals(*object.surface).centroid;
      b.body = mesh_body(*object.surface, object.material, b.h, scene_.remesh.separate_parts, &b.separation).body;
    } else {
      b.body = make_body(*object.tet_mesh, object.material, object.name);
      embed_boundary(b.body);
      double volume = 0.0;
      centre.setZero();
      for (Index e = 0; e < b.body.num_elements(); ++e) {
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (int k = 0; k < 4; ++k) c += b.body.positions.row(b.body.tets(e, k)).transpose() / 4.0;
        centre += b.body.rest_volumes[e] * c;
        volume += b.body.rest_volumes[e];
      }
      centre /= volume;
    }
    Body& body = b.body;
    for (Index n = 0; n < body.num_nodes(); ++n) {
      const Eigen::Vector3d r = body.positions.row(n).transpose() - centre;
      body.velocities.row(n) = (object.velocity + object.angular_velocity.cross(r)).transpose();
    }
    b.pinned = nodes_in(body.positions, b.regions);
    for (const Index n : b.pinned) body.velocities.row(n).setZero();
    bodies_.push_back(std::move(b));
  }
  together_ = bodies_.size() > 1 && scene_.body_collisions.enabled;
  integrators_.resize(bodies_.size());
  for (std::size_t i = 0; i < bodies_.size(); ++i) attach(i, time_);
}

Simulation::~Simulation() = default;

SelfCollisionParameters Simulation::self_collision_parameters(std::size_t i) const {
  const SimulationBody& b = bodies_[i];
  SelfCollisionParameters self;
  self.friction = b.self_collisions.friction;
  self.thickness = b.self_collisions.thickness;
  if (!(self.thickness > 0.0)) {
    double size = b.h;
    if (!b.lattice) {  // a tetrahedral mesh: its mean rest edge length, from the mean volume of a regular tet
      const double mean_volume = b.body.rest_volumes.sum() / std::max<Index>(1, b.body.num_elements());
      size = std::cbrt(6.0 * std::sqrt(2.0) * mean_volume);
    }
    self.thickness = kSelfCollisionThicknessFraction * size;
  }
  return self;
}

void Simulation::attach(std::size_t i, double time) {
  joint_stale_ = true;
  Constraints constraints;
  constraints.pinned = bodies_[i].pinned;
  constraints.obstacles = scene_.obstacles;
  if (scene_.ground) {
    // The floor meets the embedded surface, like every obstacle (a node-level
    // ground would hold the lattice's outer nodes, up to h outside the surface).
    constraints.obstacles.push_back(Obstacle{"ground", make_half_space(scene_.ground->normal, scene_.ground->offset),
                                             RigidMotion{}, scene_.ground->friction});
  }
  // Bodies stepped together meet their own surface in the joint stage.
  if (bodies_[i].self_collisions.enabled && !together_) constraints.self_collisions = self_collision_parameters(i);
  std::unique_ptr<Integrator> integrator;
  if (scene_.integrator == IntegratorKind::newmark) {
    integrator = std::make_unique<NewmarkIntegrator>(scene_.newmark, std::move(constraints), scene_.gravity,
                                                     scene_.surface_tension);
  } else {
    // scene_.backward_euler.statics is set for the static integrator.
    integrator = std::make_unique<BackwardEulerIntegrator>(scene_.backward_euler, std::move(constraints), scene_.gravity,
                                                           scene_.surface_tension);
  }
  integrator->set_time(time);
  integrators_[i] = std::move(integrator);
}

void Simulation::make_restart_point() {
  for (auto& integrator : integrators_) integrator->invalidate();
}

void Simulation::check_state(std::size_t i) const {
  // Architecture.md, "Nothing lost": a numerical failure stops the run with
  // a diagnosis. The worst node is the first non-finite one, else the fastest.
  const Body& body = bodies_[i].body;
  Index worst = -1;
  double worst_speed = -1.0;
  bool finite = true;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const bool ok = body.positions.row(n).allFinite() && body.velocities.row(n).allFinite();
    if (!ok) {
      worst = n;
      finite = false;
      break;
    }
    double speed = body.velocities.row(n).norm();
    if (!std::isfinite(speed)) speed = body.velocities.row(n).stableNorm();  // |v|² overflowed
    if (speed > worst_speed) {
      worst_speed = speed;
      worst = n;
    }
  }
  if (finite && worst_speed <= scene_.limits.max_speed) return;
  const Index corner = body.incidence.corners[at(body.incidence.offsets[at(worst)])];
  const double t = integrators_[i]->time();
  const std::string what = finite ? fmt::format("moves at {:.4g} m/s, above limits.max_speed = {:.4g} m/s (an energy "
                                                "blow-up)",
                                                worst_speed, scene_.limits.max_speed)
                                  : std::string("has a non-finite position or velocity");
  throw NumericalFailure(fmt::format(
      "numerical failure at step {} (t = {:.6g} s, Δt = {:.3g} s): body '{}', node {} of element {} {}; lower the time "
      "step (newmark.cfl, newmark.max_time_step or backward_euler.time_step) or check the material",
      steps_, t, last_dt_, bodies_[i].name, worst, corner / 4, what));
}

void Simulation::record(const StepReport& report) {
  last_dt_ = report.dt;
  times_.step += report.times;
  self_collisions_ += report.self_collisions;
  volume_total_ += report.volume;
  volume_frame_ += report.volume;
  damping_total_ += report.damping;
  damping_frame_ += report.damping;
  steps_ += report.steps;
}

template <class Call>
auto Simulation::guarded(std::size_t i, Call&& call) {
  try {
    return call();
  } catch (const Error& e) {
    // A solve that found no answer even at its smallest step: not bad input.
    const std::string_view advice = integrators_[i]->failure_advice();
    if (advice.empty()) throw;
    throw NumericalFailure(fmt::format("numerical failure at step {} (t = {:.6g} s): body '{}': {}; try {}", steps_ + 1,
                                       integrators_[i]->time(), bodies_[i].name, e.what(), advice));
  }
}

void Simulation::step_body(std::size_t i, double max_dt) {
  SimulationBody& b = bodies_[i];
  auto start = Clock::now();
  record(guarded(i, [&] { return integrators_[i]->step(b.body, max_dt); }));
  times_.integrate += seconds_since(start);

  start = Clock::now();
  check_state(i);
  times_.safety += seconds_since(start);
  remesh_if_due(i);
}

void Simulation::step_together(double max_dt) {
  const auto start = Clock::now();
  const std::size_t count = bodies_.size();
  // One Δt for all: the smallest any body needs (Newmark's CFL and strain
  // bounds; backward Euler's fixed step, the same for every body).
  double dt = max_dt;
  for (std::size_t i = 0; i < count; ++i) dt = std::min(dt, integrators_[i]->next_time_step(bodies_[i].body, max_dt));
  const double t0 = integrators_[0]->time();
  std::vector<Points> x_start(count);
  for (std::size_t i = 0; i < count; ++i) {
    x_start[i] = bodies_[i].body.positions;
    guarded(i, [&] { integrators_[i]->begin_step(bodies_[i].body, dt); });
  }
  const auto joint = Clock::now();
  collide_bodies(x_start, dt);
  times_.step.self_collisions += seconds_since(joint);
  for (std::size_t i = 0; i < count; ++i) {
    record(integrators_[i]->finish_step(bodies_[i].body));
    integrators_[i]->set_time(t0 + dt);  // every clock alike, to the bit
  }
  last_dt_ = dt;
  times_.integrate += seconds_since(start);
  const auto checks = Clock::now();
  for (std::size_t i = 0; i < count; ++i) check_state(i);
  times_.safety += seconds_since(checks);
  for (std::size_t i = 0; i < count; ++i) remesh_if_due(i);
}

void Simulation::build_joint_body() {
  // The bodies' elements and surfaces side by side, ids offset.
  const std::size_t count = bodies_.size();
  Index nodes = 0, elements = 0, vertices = 0, triangles = 0;
  for (const SimulationBody& b : bodies_) {
    nodes += b.body.num_nodes(), elements += b.body.num_elements();
    vertices += b.body.embedding.num_vertices(), triangles += static_cast<Index>(b.body.surface_triangles.rows());
  }
  joint_ = Body{};
  joint_.positions.resize(nodes, 3);
  joint_.masses.resize(nodes);
  joint_.tets.resize(elements, 4);
  joint_.surface_triangles.resize(triangles, 3);
  joint_.embedding.parent.resize(at(vertices));
  joint_.embedding.bary.resize(vertices, 4);
  CollisionGroups groups;
  groups.vertex_group.resize(at(vertices));
  groups.element_group.resize(at(elements));
  groups.between_friction = scene_.body_collisions.friction;
  node_offset_.assign(count, 0);
  Index n0 = 0, e0 = 0, v0 = 0, t0 = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Body& body = bodies_[i].body;
    const auto group = static_cast<std::int32_t>(i);
    node_offset_[i] = n0;
    joint_.tets.middleRows(e0, body.num_elements()) = body.tets.array() + n0;
    const auto nt = static_cast<Index>(body.surface_triangles.rows());
    joint_.surface_triangles.middleRows(t0, nt) = body.surface_triangles.array() + v0;
    const Index nv = body.embedding.num_vertices();
    for (Index v = 0; v < nv; ++v) joint_.embedding.parent[at(v0 + v)] = body.embedding.parent[at(v)] + e0;
    joint_.embedding.bary.middleRows(v0, nv) = body.embedding.bary;
    std::fill_n(groups.vertex_group.begin() + v0, nv, group);
    std::fill_n(groups.element_group.begin() + e0, body.num_elements(), group);
    groups.self_pairs.push_back(bodies_[i].self_collisions.enabled ? 1 : 0);
    groups.self_friction.push_back(bodies_[i].self_collisions.friction);
    n0 += body.num_nodes(), e0 += body.num_elements(), v0 += nv, t0 += nt;
  }
  for (std::size_t i = 0; i < count; ++i)  // masses change only where joint_ is rebuilt (a re-mesh, a load)
    joint_.masses.segment(node_offset_[i], bodies_[i].body.num_nodes()) = bodies_[i].body.masses;
  joint_collisions_.set_groups(std::move(groups));
  // One thickness for the stage: the smallest any pair asks for (the
  // key's, else the smallest body's own; a body's own pairs their own).
  double smallest = std::numeric_limits<double>::infinity(), smallest_self = smallest;
  for (std::size_t i = 0; i < count; ++i) {
    const double own = self_collision_parameters(i).thickness;
    smallest = std::min(smallest, own);
    if (bodies_[i].self_collisions.enabled) smallest_self = std::min(smallest_self, own);
  }
  const double between = scene_.body_collisions.thickness;
  joint_thickness_ = std::min(between > 0.0 ? between : smallest, smallest_self);
  joint_stale_ = false;
}

void Simulation::collide_bodies(const std::vector<Points>& x_start, double dt) {
  const std::size_t count = bodies_.size();
  if (joint_stale_) build_joint_body();
  SelfCollisionParameters parameters;
  parameters.thickness = joint_thickness_;

  const Index nodes = joint_.num_nodes();
  Points x0(nodes, 3), d(nodes, 3);
  std::vector<std::uint8_t> fixed(at(nodes), 0);
  for (std::size_t i = 0; i < count; ++i) {
    const Body& body = bodies_[i].body;
    const Index n0 = node_offset_[i];
    x0.middleRows(n0, body.num_nodes()) = x_start[i];
    d.middleRows(n0, body.num_nodes()) = body.positions - x_start[i];
    for (const Index n : bodies_[i].pinned) fixed[at(n0 + n)] = 1;
  }
  // Responses at full size at the smallest reference step of the bodies,
  // scaled down for a shorter step (SelfCollisionParameters::target_scale).
  double reference = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < count; ++i)
    reference = std::min(reference, integrators_[i]->reference_step());
  if (reference > 0.0 && std::isfinite(reference)) parameters.target_scale = std::min(1.0, dt / reference);
  const Points before = d;
  self_collisions_ += joint_collisions_.resolve(joint_, x0, d, fixed, parameters);
  for (std::size_t i = 0; i < count; ++i) {
    Body& body = bodies_[i].body;
    const Index n0 = node_offset_[i];
    for (Index n = 0; n < body.num_nodes(); ++n) {
      if (d.row(n0 + n) == before.row(n0 + n)) continue;
      body.positions.row(n) = x0.row(n0 + n) + d.row(n0 + n);
      body.velocities.row(n) += (d.row(n0 + n) - before.row(n0 + n)) / dt;
    }
  }
}

void Simulation::remesh_if_due(std::size_t i) {
  SimulationBody& b = bodies_[i];
  if (!b.lattice || !scene_.remesh.enabled) return;
  auto start = Clock::now();
  const bool due = remesh_due(b.body, b.body.positions, b.body.embedding.bary, scene_.remesh.thresholds);
  times_.remesh_check += seconds_since(start);
  if (!due) return;
  const RemeshCheck check = check_remesh(b.body, b.body.positions, b.body.embedding.bary, scene_.remesh.thresholds);

  // W&T fig. 8, last stage: a new lattice mesh around the current surface.
  start = Clock::now();
  // The re-mesh waits while any element is inverted. An inverted element's
  // state cannot be carried across (the transfer raises its stretches to
  // min_stretch), and the material it holds overlaps its neighbours', so the
  // surface folds through itself and encloses less than the material fills:
  // a mirrored body, half way to right side out, encloses 10⁻³ of its volume,
  // and the rest-volume correction would then compress the new mesh a
  // thousandfold. The elasticity turns inverted elements back; the re-mesh
  // goes ahead once none is left.
  if (check.inverted > 0) {
    log().debug("re-mesh of '{}' postponed: {} of {} elements are inverted", b.name, check.inverted,
                b.body.num_elements());
    times_.remesh += seconds_since(start);
    return;
  }
  // A surface turned inside out bounds no solid a lattice could fill.
  const TriangleMesh surface = b.body.surface();
  if (const double volume = surface_integrals(surface).volume; !(volume > 0.0)) {
    log().debug("re-mesh of '{}' postponed: its surface is inside out (volume {:.3g} m³)", b.name, volume);
    times_.remesh += seconds_since(start);
    return;
  }
  RemeshReport report;
  const double t = integrators_[i]->time();
  // Bodies that collide: the upkeep's collapses must not pass through them.
  const TriangleMesh others = together_ ? surfaces_except(i) : TriangleMesh{};
  std::optional<MeshedBody> attempt;
  try {
    attempt = remesh(b.body, surface, b.h, &report, scene_.remesh.upkeep ? &scene_.remesh.upkeep_settings : nullptr,
                     together_ ? &others : nullptr, scene_.remesh.separate_parts);
  } catch (const Error& e) {
    // A mesh with no valid element left (every element inverted) cannot
    // carry its state across; the elasticity turns the elements back first.
    log().debug("re-mesh of '{}' postponed: {}", b.name, e.what());
    times_.remesh += seconds_since(start);
    return;
  }
  times_.remesh_stages += report.times;
  MeshedBody& meshed = *attempt;
  b.body = std::move(meshed.body);
  b.separation = report.separation;
  b.pinned = nodes_in(b.body.positions, b.regions);
  for (const Index n : b.pinned) b.body.velocities.row(n).setZero();
  attach(i, t);
  ++remeshes_;
  times_.remesh += seconds_since(start);
  log().debug(
      "re-mesh of '{}' at t = {:.6g} s: {} → {} elements (element {}, vertex {}, growth {:.3g}); rest volume missed "
      "by {:.3g}, mass by {:.3g} before correction; {} elements split, {} node copies",
      b.name, t, report.old_elements, report.new_elements, check.element, check.vertex, check.worst_growth,
      report.rest_volume_error, report.mass_error, report.separation.split_elements, report.separation.node_copies);
}

bool Simulation::advance_to(double t_end, const std::function<bool()>& stop) {
  if (together_) {
    double t = integrators_[0]->time();
    bool stopped = false;
    step_until(
        t, t_end,
        [&](double max_dt) {
          step_together(max_dt);
          t = integrators_[0]->time();
        },
        [&] { return stopped = stop && stop(); });
    if (stopped) return false;
    for (auto& integrator : integrators_) integrator->set_time(t_end);
    time_ = t_end;
    return true;
  }
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    double t = integrators_[i]->time();
    bool stopped = false;
    step_until(
        t, t_end,
        [&](double max_dt) {
          step_body(i, max_dt);
          t = integrators_[i]->time();  // a re-mesh replaces the integrator, not its clock
        },
        [&] { return stopped = stop && stop(); });
    if (stopped) return false;  // the state stays between steps
    integrators_[i]->set_time(t_end);  // exactly, as step_until landed t
  }
  time_ = t_end;
  return true;
}

SimulationTotals Simulation::totals() const {
  SimulationTotals out;
  for (const SimulationBody& b : bodies_) {
    const Body& body = b.body;
    out.mass += body.masses.sum();
    out.momentum += linear_momentum(body);
    for (Index n = 0; n < body.num_nodes(); ++n) out.max_speed = std::max(out.max_speed, body.velocities.row(n).norm());
    out.volume += surface_integrals(body.surface()).volume;
    out.nodes += body.num_nodes();
    out.elements += body.num_elements();
    out.surface_vertices += body.embedding.num_vertices();
    out.surface_triangles += static_cast<Index>(body.surface_triangles.rows());
    out.separation.split_elements += b.separation.split_elements;
    out.separation.node_copies += b.separation.node_copies;
    out.separation.degenerate_elements += b.separation.degenerate_elements;
  }
  return out;
}

TriangleMesh Simulation::surface() const {
  return surfaces_except(bodies_.size());
}

TriangleMesh Simulation::surfaces_except(std::size_t skipped) const {
  TriangleMesh out;
  Index vertices = 0, triangles = 0;
  for (std::size_t k = 0; k < bodies_.size(); ++k) {
    if (k == skipped) continue;
    vertices += bodies_[k].body.embedding.num_vertices();
    triangles += static_cast<Index>(bodies_[k].body.surface_triangles.rows());
  }
  out.vertices.resize(vertices, 3);
  out.triangles.resize(triangles, 3);
  Index v0 = 0, t0 = 0;
  for (std::size_t k = 0; k < bodies_.size(); ++k) {
    if (k == skipped) continue;
    const TriangleMesh s = bodies_[k].body.surface();
    out.vertices.middleRows(v0, s.vertices.rows()) = s.vertices;
    out.triangles.middleRows(t0, s.triangles.rows()) = s.triangles.array() + v0;
    v0 += static_cast<Index>(s.vertices.rows());
    t0 += static_cast<Index>(s.triangles.rows());
  }
  return out;
}

std::vector<std::int32_t> Simulation::surface_bodies() const {
  std::vector<std::int32_t> out;
  for (std::size_t k = 0; k < bodies_.size(); ++k)
    out.insert(out.end(), static_cast<std::size_t>(bodies_[k].body.surface_triangles.rows()),
               static_cast<std::int32_t>(k));
  return out;
}

StateRecord Simulation::save() const {
  StateRecord r;
  save(r);
  return r;
}

void Simulation::save(StateSink& r) const {
  checkpoint::put_clock(r, checkpoint::Clock{time_, steps_, remeshes_, last_dt_});
  checkpoint::put_body_count(r, bodies_.size());
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    const SimulationBody& b = bodies_[i];
    checkpoint::put_body(r, i, b.name, b.lattice, b.h, b.body, b.pinned);
  }
}

void Simulation::load(const StateRecord& r) {
  const auto count = checkpoint::get_body_count(r);
  if (count != static_cast<std::int64_t>(bodies_.size()))
    throw Error(fmt::format("the state holds {} bodies, the scene {}", count, bodies_.size()));
  const checkpoint::Clock clock = checkpoint::get_clock(r);
  time_ = clock.time;
  steps_ = clock.steps;
  remeshes_ = clock.remeshes;
  last_dt_ = clock.last_time_step;
  if (!(std::isfinite(time_) && time_ >= 0.0)) throw Error(fmt::format("time: {} is not a time a run reaches", time_));
  if (steps_ < 0 || remeshes_ < 0) throw Error(fmt::format("steps ({}) and remeshes ({}) cannot be negative", steps_, remeshes_));
  if (!(std::isfinite(last_dt_) && last_dt_ >= 0.0))
    throw Error(fmt::format("last_time_step: {} is not a time step", last_dt_));
  for (std::size_t i = 0; i < bodies_.size(); ++i) {
    SimulationBody& b = bodies_[i];
    const std::string p = checkpoint::body_prefix(i);
    checkpoint::StoredBody stored = checkpoint::get_body(r, i);
    if (stored.name != b.name)
      throw Error(fmt::format("state body {} is '{}', the scene's is '{}'", i, stored.name, b.name));
    b.lattice = stored.lattice;
    b.h = stored.lattice_spacing;
    b.pinned = std::move(stored.pinned);
    Body body = std::move(stored.body);
    body.material = b.body.material;
    // A tetrahedral-mesh body's checkpoint written before make_body set this
    // holds 0; its material fills its elements, so it is Σ W, as make_body
    // sets it now (a lattice body with 0 is refused below).
    if (!b.lattice && body.rest_material_volume == 0.0) body.rest_material_volume = body.rest_volumes.sum();
    // Every count must agree, and every id be in range, before anything uses them.
    const auto nn = body.positions.rows(), ne = body.tets.rows();
    const auto nv = static_cast<Eigen::Index>(body.embedding.parent.size());
    const bool sizes = body.rest_positions.rows() == nn && body.velocities.rows() == nn && body.masses.size() == nn &&
                       std::ssize(body.Dm_inv) == ne && body.rest_volumes.size() == ne && std::ssize(body.Fp) == ne &&
                       body.alpha.size() == ne && body.rest_condition.size() == ne &&
                       (body.solid_fractions.size() == 0 || body.solid_fractions.size() == ne) && body.embedding.bary.rows() == nv;
    const bool ids = (ne == 0 || (body.tets.minCoeff() >= 0 && body.tets.maxCoeff() < nn)) &&
                     (body.surface_triangles.rows() == 0 ||
                      (body.surface_triangles.minCoeff() >= 0 && body.surface_triangles.maxCoeff() < nv)) &&
                     std::all_of(body.embedding.parent.begin(), body.embedding.parent.end(),
                                 [&](Index e) { return e >= 0 && e < ne; }) &&
                     std::all_of(b.pinned.begin(), b.pinned.end(), [&](Index n) { return n >= 0 && n < nn; });
    if (!sizes || !ids) throw Error(fmt::format("state body {} ('{}'): array sizes or ids do not agree", i, b.name));
    check_values(body, p, b.name);
    body.incidence = NodeIncidence::build(body.tets, static_cast<Index>(nn));
    b.body = std::move(body);
  }
  for (std::size_t i = 0; i < bodies_.size(); ++i) attach(i, time_);
}

}  // namespace goo
