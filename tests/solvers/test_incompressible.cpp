// Incompressible materials (core/volume_projection.h) in the integrators:
// no locking in bending, volume kept under stretching and squeezing,
// momentum kept, results independent of the thread count.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstdio>

#include "core/body.h"
#include "core/surface_geometry.h"
#include "core/volume_projection.h"
#include "io/scene_io.h"
#include "solvers/backward_euler.h"
#include "solvers/newmark.h"
#include "solvers/simulation.h"
#include "tests/common/test_common.h"
#include "tests/core/cantilever.h"

namespace goo {
namespace {

// A 0.5 m × 0.1 m × 0.1 m cantilever on 5n × n × n cells (30 n³ tets),
// clamped at x = 0, under its own weight.
constexpr double kLength = 0.5, kDepth = 0.1, kShear = 2e6, kDensity = 1000.0, kGravity = 9.81;

Body beam(double youngs_modulus, double poisson_ratio, bool incompressible, double viscosity = 0.0, int n = 2) {
  Material m;
  m.model = ElasticModel::fixed_corotated;
  m.youngs_modulus = youngs_modulus;
  m.poisson_ratio = poisson_ratio;
  m.density = kDensity;
  m.incompressible = incompressible;
  m.viscosity = viscosity;
  return make_body(make_box_tets({kLength, kDepth, kDepth}, {5 * n, n, n}), m);
}

std::vector<Index> clamped_nodes(const Body& body) {
  std::vector<Index> out;
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (body.rest_positions(n, 0) == 0.0) out.push_back(n);
  return out;
}

double tip_deflection(const Body& body) {
  double tip = 0.0;
  int count = 0;
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (body.rest_positions(n, 0) == kLength) {
      tip += body.rest_positions(n, 2) - body.positions(n, 2);
      ++count;
    }
  return tip / count;
}

/// Static equilibrium: the compressible models by Newton, the
/// incompressible one by Newton on the saddle-point system of the same
/// nodal constraints as the projection (tests/core/cantilever.h).
double static_tip(Body body) {
  std::vector<bool> clamped(static_cast<std::size_t>(body.num_nodes()), false);
  for (const Index n : clamped_nodes(body)) clamped[static_cast<std::size_t>(n)] = true;
  if (body.material.incompressible) {
    EXPECT_LT(test::solve_static_incompressible(body, clamped, kGravity), 60);
    EXPECT_LE(max_nodal_volume_error(body, body.positions), 1e-9);
  } else {
    test::solve_static(body, clamped, kGravity, 8);
  }
  return tip_deflection(body);
}

TEST(Incompressible, NodalVolumesDoNotLockACantileverWhereNuOf049Does) {
  // All three models share the shear modulus μ. An incompressible solid of
  // shear modulus μ has Young's modulus 3μ, so the reference is the same
  // mesh with the same nonlinear elasticity, ν = 0 and E = 3μ: beam bending
  // depends on E alone, and ν = 0 has no volumetric stiffness to lock. The
  // plain model with ν = 0.49 has E = 2μ(1 + ν) = 2.98μ, nearly the same
  // bending stiffness, but λ = 50μ locks the linear tetrahedra. The
  // incompressible model: elasticity with ν = 0 (E = 2μ) and every node
  // keeping its volume. Measured tip deflections (reference, nodal volumes,
  // ν = 0.49), mm: 2 cells through the depth 8.81, 5.53, 2.14; 4 cells
  // 13.07, 10.87, 4.78; 6 cells 14.44, 13.32, 7.20 (Timoshenko beam theory:
  // 16.1). Nodal volumes converge to the reference (63%, 83%, 92%); ν = 0.49
  // stays near half of it.
  double previous_ratio = 0.0;
  for (const int n : {2, 4, 6}) {
    const double reference = static_tip(beam(3.0 * kShear, 0.0, false, 0.0, n));
    const double locked = static_tip(beam(2.0 * kShear * 1.49, 0.49, false, 0.0, n));
    const double nodal = static_tip(beam(2.0 * kShear, 0.0, true, 0.0, n));
    std::printf("%d cells through the depth: tip %.5g m (ν = 0, E = 3μ), %.5g m (incompressible), %.5g m (ν = 0.49)\n",
                n, reference, nodal, locked);
    EXPECT_GT(nodal / reference, previous_ratio) << n << " cells: the gap must close under refinement";
    previous_ratio = nodal / reference;
    EXPECT_LT(locked, 0.6 * reference) << n << " cells: ν = 0.49 on linear tetrahedra should lock";
    if (n == 6) {
      EXPECT_NEAR(nodal, reference, 0.1 * reference);
    }
  }
}

TEST(Incompressible, NewmarkWithTheProjectionComesToRestAtTheStaticEquilibrium) {
  // The same beam (2 cells through the depth) under Newmark with strong
  // viscosity (damping ratio ~0.35 in the first bending mode). The pressure
  // carried as a force makes the rest state the mixed equilibrium
  // f + Mg − Gᵀπ = 0 whatever the viscosity (without it the viscous force on
  // the projected-away velocity would shift it: 0.0103 m measured).
  const double equilibrium = static_tip(beam(2.0 * kShear, 0.0, true));
  Body body = beam(2.0 * kShear, 0.0, true, 4e4);
  Constraints constraints;
  constraints.pinned = clamped_nodes(body);
  NewmarkSettings settings;
  // Each step's volumes are met to the tolerance, and what is left moves the
  // nodes by about tolerance × h each step: 10⁻⁶ keeps it below the match.
  settings.volume_tolerance = 1e-6;
  NewmarkIntegrator integrator(settings, constraints, Eigen::Vector3d(0.0, 0.0, -kGravity));
  double last_tip = 0.0, change = 0.0;
  for (int frame = 1; frame <= 100; ++frame) {
    integrator.advance_to(body, 0.01 * frame);
    change = std::abs(tip_deflection(body) - last_tip);
    last_tip = tip_deflection(body);
  }
  std::printf("tip at rest %.6g m, static equilibrium %.6g m\n", last_tip, equilibrium);
  // At rest: the tip moved less than 2e-3 of its deflection over the last 0.01 s.
  EXPECT_LT(change, 2e-3 * equilibrium);
  EXPECT_LE(max_nodal_volume_error(body, body.positions), settings.volume_tolerance);
  EXPECT_NEAR(last_tip, equilibrium, 5e-3 * equilibrium);
}

TEST(Incompressible, ACubeStretchedByItsFacesKeepsEveryNodalVolume) {
  // A unit cube (4³ cells) whose x = 0 and x = 1 faces are pulled apart to
  // 1.3 m over 0.3 s (their nodes prescribed, y and z held): it must neck.
  // Backward Euler, whose projection follows each converged step.
  Material m;
  m.youngs_modulus = 1e4;
  m.poisson_ratio = 0.3;
  m.viscosity = 5.0;
  m.incompressible = true;
  Body body = make_body(make_box_tets(Eigen::Vector3d::Ones(), Eigen::Vector3i::Constant(4)), m);
  Constraints constraints;
  PrescribedMotion pull;
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (body.rest_positions(n, 0) == 0.0 || body.rest_positions(n, 0) == 1.0) pull.nodes.push_back(n);
  pull.position = [](Index, const Eigen::Vector3d& rest, double t) {
    Eigen::Vector3d x = rest;
    x.x() *= 1.0 + std::min(t, 0.3);
    return x;
  };
  constraints.prescribed.push_back(pull);
  BackwardEulerSettings settings;
  settings.time_step = 0.01;
  BackwardEulerIntegrator integrator(settings, constraints, Eigen::Vector3d::Zero());
  const Points start = body.positions;
  for (int frame = 1; frame <= 100; ++frame) {
    integrator.advance_to(body, 0.01 * frame);
    // J = 1 node by node, to the projection's tolerance, at every step.
    EXPECT_LE(max_nodal_volume_error(body, body.positions), VolumeProjectionSettings{}.tolerance) << "frame " << frame;
  }
  double length = 0.0, middle_width = 1e9, total = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    length = std::max(length, body.positions(n, 0));
    if (body.rest_positions(n, 0) == 0.5 && body.rest_positions(n, 2) == 0.5)
      middle_width = std::min(middle_width, body.positions(n, 1));
  }
  for (Index e = 0; e < body.num_elements(); ++e) {
    const auto x = [&](int k) { return Eigen::Vector3d(body.positions.row(body.tets(e, k))); };
    total += (x(1) - x(0)).dot((x(2) - x(0)).cross(x(3) - x(0))) / 6.0;
  }
  EXPECT_DOUBLE_EQ(length, 1.3);
  // Σ_i V_i is the total volume: each node within the tolerance, so the sum too.
  EXPECT_NEAR(total, 1.0, VolumeProjectionSettings{}.tolerance);
  // The middle section narrows (the side at y = 0 moves inward).
  EXPECT_GT(middle_width, 0.02);
  (void)start;
}

/// A gooey ball (5 cm radius, lattice 2 cm) squeezed to half its height by
/// a press, as in the bunny press, shortened.
std::string pressed_ball(const std::string& integrator) {
  return R"({
    "integrator": )" + integrator + R"(,
    "ground": {"height": 0.0, "friction": 0.6},
    "obstacles": [{"name": "press", "shape": {"type": "box", "size": [0.4, 0.4, 0.1]}, "friction": 0.3,
                   "motion": [{"time": 0.0, "translate": [0, 0, 0.151]}, {"time": 0.3, "translate": [0, 0, 0.1]}]}],
    "objects": [{"name": "ball", "primitive": {"type": "sphere", "radius": 0.05, "segments": 24},
                 "transform": {"translate": [0, 0, 0.0505]},
                 "material": {"preset": "gooey_jelly"}, "lattice_spacing": 0.02}]
  })";
}

TEST(Incompressible, ABallSqueezedByThePressKeepsItsVolumeToHalfAPercent) {
  Simulation sim(io::parse_scene(pressed_ball(R"({"type": "newmark"})"), "press.json", "."));
  const double v0 = surface_integrals(sim.bodies()[0].body.surface()).volume;
  double lowest = 1.0, highest = 1.0, bottom = 0.0, top = 0.0;
  for (int frame = 1; frame <= 9; ++frame) {
    sim.advance_to(frame / 30.0);
    const TriangleMesh s = sim.bodies()[0].body.surface();
    const double ratio = surface_integrals(s).volume / v0;
    std::printf("frame %d: volume ratio %.5f\n", frame, ratio);
    lowest = std::min(lowest, ratio);
    highest = std::max(highest, ratio);
    bottom = s.vertices.col(2).minCoeff();
    top = s.vertices.col(2).maxCoeff();
  }
  std::printf("volume ratio in [%.5f, %.5f]; height %.4f m\n", lowest, highest, top - bottom);
  EXPECT_LT(top - bottom, 0.055) << "the press must have squeezed the ball to about half its height";
  EXPECT_GE(lowest, 0.995);
  EXPECT_LE(highest, 1.005);
}

TEST(Incompressible, TheContactsGiveBackTheVolumeTheyTakeInTheSameStep) {
  // The squeezed ball with Newmark and with backward Euler, frame by frame
  // as it is written: the position corrections at the press and the floor
  // take volume, which the same step gives back with the nodes they moved
  // held against the obstacles wherever a node is off by more than ten
  // tolerances (10⁻⁴ each). Every node's share of the material is then
  // within ten tolerances after every step, so the material's volume too,
  // and the surface's volume follows the material's up to their
  // difference, measured again every few steps: within ten tolerances
  // (measured: 0.99993 lowest with Newmark, 0.99930 with backward Euler;
  // without giving the volume back, 0.99821 and 0.93537 at frame 9). No
  // surface vertex is left inside the press or the floor.
  const double tolerance = VolumeProjectionSettings{}.tolerance;
  for (const std::string integrator : {R"({"type": "newmark"})", R"({"type": "backward_euler", "time_step": 0.002})"}) {
    Simulation sim(io::parse_scene(pressed_ball(integrator), "press.json", "."));
    const double v0 = surface_integrals(sim.bodies()[0].body.surface()).volume;
    for (int frame = 1; frame <= 9; ++frame) {
      const double t = frame / 30.0;
      sim.advance_to(t);
      const TriangleMesh s = sim.bodies()[0].body.surface();
      EXPECT_NEAR(surface_integrals(s).volume / v0, 1.0, 10.0 * tolerance) << integrator << ", frame " << frame;
      const double press_bottom = 0.151 - (0.151 - 0.1) * std::min(t, 0.3) / 0.3 - 0.05;
      EXPECT_LE(s.vertices.col(2).maxCoeff(), press_bottom + 1e-12) << integrator << ", frame " << frame;
      EXPECT_GE(s.vertices.col(2).minCoeff(), -1e-12) << integrator << ", frame " << frame;
    }
  }
}

TEST(Incompressible, ThePressRunIsBitwiseIdenticalOnOneAndTwoThreads) {
  StateRecord states[2];
  for (int threads = 1; threads <= 2; ++threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Simulation sim(io::parse_scene(pressed_ball(R"({"type": "newmark"})"), "press.json", "."));
    sim.advance_to(0.1);
    states[threads - 1] = sim.save();
  }
  for (const auto& [name, array] : states[0].arrays()) EXPECT_TRUE(array == states[1].arrays().at(name)) << name;
}

TEST(Incompressible, AFreeFlyingBodyKeepsItsMomentumAndMass) {
  // A spinning, deforming incompressible cube in free flight: the
  // projection's impulses cancel element by element and have no moment
  // about the step's start (the velocity projection's none about its end),
  // and Newmark's other forces are internal too.
  Material m;
  m.youngs_modulus = 1e4;
  m.incompressible = true;
  Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.3), Eigen::Vector3i::Constant(3)), m);
  // Spinning, drifting and deforming: x-stretching velocities change
  // every nodal volume from the first step on.
  const Eigen::Vector3d omega(1.0, -2.0, 0.5);
  for (Index n = 0; n < body.num_nodes(); ++n)
    body.velocities.row(n) = (omega.cross(Eigen::Vector3d(body.positions.row(n))) + Eigen::Vector3d(0.2, 0.1, -0.3) +
                              Eigen::Vector3d(2.0 * body.positions(n, 0), 0.0, 0.0))
                                 .transpose();
  const Eigen::Vector3d P0 = linear_momentum(body), L0 = angular_momentum(body);
  const double mass = body.masses.sum();
  NewmarkIntegrator integrator({}, {}, Eigen::Vector3d::Zero());
  for (int i = 0; i < 200; ++i) integrator.step(body, 1.0);
  EXPECT_LE(max_nodal_volume_error(body, body.positions), VolumeProjectionSettings{}.tolerance);
  EXPECT_EQ(body.masses.sum(), mass);
  EXPECT_TRUE(test::matrices_near(linear_momentum(body), P0, 1e-12 * mass));
  EXPECT_TRUE(test::matrices_near(angular_momentum(body), L0, 1e-10 * L0.norm()))
      << (angular_momentum(body) - L0).transpose() << " of " << L0.norm();
}

}  // namespace
}  // namespace goo
