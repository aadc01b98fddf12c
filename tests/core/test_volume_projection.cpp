#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <random>

#include "core/body.h"
#include "core/volume_projection.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

/// A 0.2 m box of 4³ cells (384 tets) whose nodes were moved at random by
/// up to `amplitude` × the cell size, and given a spin and a random velocity:
/// a step's end whose nodal volumes are off by up to ~`amplitude`.
struct Perturbed {
  Body body;
  Points start;
};

Perturbed perturbed_box(double amplitude, unsigned seed) {
  Material m;
  m.incompressible = true;
  Perturbed out{make_body(make_box_tets(Eigen::Vector3d::Constant(0.2), Eigen::Vector3i::Constant(4)), m), {}};
  Body& body = out.body;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double cell = 0.05;
  const Eigen::Vector3d omega(2.0, -1.0, 3.0);
  for (Index n = 0; n < body.num_nodes(); ++n)
    body.velocities.row(n) =
        (omega.cross(Eigen::Vector3d(body.positions.row(n))) + 0.3 * Eigen::Vector3d(u(rng), u(rng), u(rng)))
            .transpose();
  out.start = body.positions;
  const double dt = 1e-3;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d d(u(rng), u(rng), u(rng));
    body.velocities.row(n) += (amplitude * cell / dt) * d.transpose();
  }
  body.positions = out.start + dt * body.velocities;
  return out;
}

TEST(VolumeProjection, RestoresEveryNodalVolumeToTheTolerance) {
  for (const double amplitude : {0.01, 0.05, 0.15}) {
    Perturbed p = perturbed_box(amplitude, 3);
    const double before = max_nodal_volume_error(p.body, p.body.positions);
    EXPECT_GT(before, 0.5 * amplitude) << "the test must start far from the constraint";
    VolumeProjection projection;
    const VolumeProjectionStats stats = projection.project(p.body, p.start, {}, 1e-3, 1e-3);
    EXPECT_DOUBLE_EQ(stats.error_before, before);
    const double after = max_nodal_volume_error(p.body, p.body.positions);
    EXPECT_LE(after, VolumeProjectionSettings{}.tolerance) << "amplitude " << amplitude;
    EXPECT_DOUBLE_EQ(stats.error, after);
    EXPECT_GE(stats.newton_iterations, 1);
  }
}

TEST(VolumeProjection, ConservesLinearAndAngularMomentumAndMovesPositionsWithVelocities) {
  Perturbed p = perturbed_box(0.05, 5);
  const double dt = 1e-3;
  // L = Σ m xⁿ⁺¹ × v = Σ m xⁿ × v when xⁿ⁺¹ = xⁿ + Δt v: measured about xⁿ.
  auto angular = [&](const Body& b) {
    Eigen::Vector3d L = Eigen::Vector3d::Zero();
    for (Index n = 0; n < b.num_nodes(); ++n)
      L += b.masses[n] * Eigen::Vector3d(p.start.row(n)).cross(Eigen::Vector3d(b.velocities.row(n)));
    return L;
  };
  const Eigen::Vector3d P0 = linear_momentum(p.body), L0 = angular(p.body);
  VolumeProjection projection;
  projection.project(p.body, p.start, {}, dt, dt);
  const double mass = p.body.masses.sum(), speed = p.body.velocities.rowwise().norm().maxCoeff();
  // Each element's impulses sum to zero and have no moment about xⁿ; the
  // sums' round-off is a few ulps of the largest term (m |v|, m |x||v|).
  EXPECT_TRUE(test::matrices_near(linear_momentum(p.body), P0, 1e-12 * mass * speed));
  EXPECT_TRUE(test::matrices_near(angular(p.body), L0, 1e-12 * mass * 0.4 * speed));
  // The step stays consistent: xⁿ⁺¹ = xⁿ + Δt vⁿ⁺¹.
  EXPECT_TRUE(test::matrices_near(p.body.positions, p.start + dt * p.body.velocities, 1e-14));
}

TEST(VolumeProjection, FixedNodesDoNotMoveAndAFullyFixedNeighbourhoodHasNoConstraint) {
  Perturbed p = perturbed_box(0.05, 7);
  std::vector<std::uint8_t> fixed(static_cast<std::size_t>(p.body.num_nodes()), 0);
  // Every node on the x = 0 face and the layer behind it.
  for (Index n = 0; n < p.body.num_nodes(); ++n)
    if (p.body.rest_positions(n, 0) < 0.06) fixed[static_cast<std::size_t>(n)] = 1;
  const Points before = p.body.positions;
  VolumeProjection projection;
  const VolumeProjectionStats stats = projection.project(p.body, p.start, fixed, 1e-3, 1e-3);
  for (Index n = 0; n < p.body.num_nodes(); ++n)
    if (fixed[static_cast<std::size_t>(n)]) {
      EXPECT_TRUE(p.body.positions.row(n) == before.row(n)) << "node " << n;
    }
  // The x = 0 face's nodes touch only fixed nodes: they keep their error;
  // every other node meets the tolerance.
  EXPECT_LE(stats.error, VolumeProjectionSettings{}.tolerance);
  EXPECT_GT(max_nodal_volume_error(p.body, p.body.positions), VolumeProjectionSettings{}.tolerance);
}

TEST(VolumeProjection, ThePressureForceItCarriesIsTheImpulseItAppliedReadAsAForce) {
  // The force −Gᵀλ / (Δt span) over `span` is the impulse M Δv the
  // projection gave. Newmark's kick is Δt/2, backward Euler's Δt.
  for (const double span : {0.5e-3, 1e-3}) {
    Perturbed p = perturbed_box(0.05, 11);
    const Points v0 = p.body.velocities;
    VolumeProjection projection;
    projection.project(p.body, p.start, {}, 1e-3, span);
    Points force = Points::Zero(p.body.num_nodes(), 3);
    projection.add_pressure_forces(p.body, p.start, force);
    Points impulse = p.body.velocities - v0;
    for (Index n = 0; n < p.body.num_nodes(); ++n) impulse.row(n) *= p.body.masses[n];
    EXPECT_TRUE(test::matrices_near(impulse, span * force, 1e-12 * impulse.cwiseAbs().maxCoeff()));
    projection.reset();
    Points none = Points::Zero(p.body.num_nodes(), 3);
    projection.add_pressure_forces(p.body, p.start, none);
    EXPECT_EQ(none.cwiseAbs().maxCoeff(), 0.0);
  }
}

/// The pressures one projection carries from the perturbed box whose
/// elements at node `corner` hold `fraction` of their volume in material
/// (the others full); the projection must meet its tolerance there.
Eigen::VectorXd carried_pressures(Perturbed& p, Index corner, double fraction) {
  Body& body = p.body;
  const double dt = 1e-3;
  body.solid_fractions = Eigen::VectorXd::Ones(body.num_elements());
  int at_corner = 0;
  for (Index e = 0; e < body.num_elements(); ++e)
    for (int k = 0; k < 4; ++k)
      if (body.tets(e, k) == corner) body.solid_fractions[e] = fraction, ++at_corner;
  EXPECT_GT(at_corner, 0);
  VolumeProjection projection;
  const VolumeProjectionStats stats = projection.project(body, p.start, {}, dt, 0.5 * dt);
  EXPECT_GE(stats.newton_iterations, 1);
  EXPECT_LE(stats.error, VolumeProjectionSettings{}.tolerance);
  const Eigen::VectorXd pressure = projection.pressures();
  EXPECT_EQ(pressure.size(), body.num_nodes());
  EXPECT_TRUE(pressure.allFinite());
  return pressure;
}

TEST(VolumeProjection, ANodeBesideASliverOfMaterialCarriesNoPressure) {
  // A corner node whose elements hold 10⁻⁹ of their volume in material (a
  // lattice node beside a sliver): its row of G M⁻¹ Gᵀ is of order 10⁻⁹ of
  // its neighbours', its multiplier of order 10⁹ of theirs. It still holds
  // its constraint (the projection meets the tolerance), but carries no
  // pressure, and the others carry those of the box filled everywhere to
  // within the share's bound (kMinMaterialShare = 1%: 100×).
  const Index corner = 0;
  Perturbed full = perturbed_box(0.05, 37), sliver = perturbed_box(0.05, 37);
  const Eigen::VectorXd filled = carried_pressures(full, corner, 1.0);
  const Eigen::VectorXd pressure = carried_pressures(sliver, corner, 1e-9);
  ASSERT_EQ(pressure.size(), filled.size());
  EXPECT_NE(filled[corner], 0.0);
  EXPECT_EQ(pressure[corner], 0.0);
  EXPECT_LE(pressure.cwiseAbs().maxCoeff(), 100.0 * filled.cwiseAbs().maxCoeff());
}

TEST(VolumeProjection, ANodeWithFewElementsCarriesOnlyWhatAFullNodeWould) {
  // The share that carries is of a full node's elements: a node with few
  // elements (a corner of the box here; a node copy of a separated re-mesh,
  // or a node whose empty elements were left out, has few too) whose
  // elements are mostly empty holds a sliver of material however large its
  // share of its own few elements. Its share s of its own elements is at
  // least 1%, but s × (its elements' volume / a full node's) is below: it
  // carries no pressure. (A fluid sliding off a ball, separated, blew up at
  // 0.21 s while such a node carried.)
  Perturbed p = perturbed_box(0.05, 37);
  const Index corner = 0;
  Eigen::VectorXd whole = Eigen::VectorXd::Zero(p.body.num_nodes());
  for (Index e = 0; e < p.body.num_elements(); ++e)
    for (int k = 0; k < 4; ++k) whole[p.body.tets(e, k)] += 0.25 * p.body.rest_volumes[e];
  const double ratio = whole[corner] / whole.maxCoeff();
  ASSERT_LT(ratio, 0.5) << "the node must have fewer elements than a full one";
  // ≥ 1% of its own elements; × ratio, < 1% of a full node's.
  const Eigen::VectorXd pressure = carried_pressures(p, corner, 0.01 / std::sqrt(ratio));
  ASSERT_EQ(pressure.size(), p.body.num_nodes());
  EXPECT_EQ(pressure[corner], 0.0);
  EXPECT_NE(pressure.cwiseAbs().maxCoeff(), 0.0);
}

TEST(VolumeProjection, VelocitiesLoseEveryVolumeChangingComponent) {
  Perturbed p = perturbed_box(0.0, 13);  // at rest shape, moving
  for (Index n = 0; n < p.body.num_nodes(); ++n) p.body.velocities.row(n) *= 1.0 + 0.5 * p.body.rest_positions(n, 0);
  p.body.positions = p.start;
  Points forces = Points::Zero(p.body.num_nodes(), 3);
  VolumeProjection projection;
  const double dt = 1e-3;
  const VolumeProjectionStats stats = projection.project_velocities(p.body, {}, dt, 0.5 * dt, forces);
  EXPECT_GT(stats.error_before, 100.0 * VolumeProjectionSettings{}.tolerance);
  // A step along the projected velocities changes no nodal volume to first
  // order: Δt G v below the tolerance (the second order is (Δt |∇v|)²).
  const double rate = p.body.velocities.rowwise().norm().maxCoeff() / 0.05;
  EXPECT_LE(max_nodal_volume_error(p.body, p.start + dt * p.body.velocities),
            VolumeProjectionSettings{}.tolerance + 10.0 * (dt * rate) * (dt * rate));
  EXPECT_LE(stats.error, 0.25 * VolumeProjectionSettings{}.tolerance);
  // The forces of the next kick carry the same impulse.
  EXPECT_GT(forces.cwiseAbs().maxCoeff(), 0.0);
}

TEST(VolumeProjection, PartlyFilledElementsKeepTheMaterialsVolumeNotTheirWholeOne) {
  // Elements at a body's boundary are partly filled (φ_e < 1). The nodes
  // keep ¼ Σ φ_e V_e, the material's share: an element mostly empty may
  // compress while its full neighbour keeps its volume. Holding the whole
  // elements' ¼ Σ V_e instead let the material's volume go where empty
  // parts grew (a bunny under the press lost 2.3% at one frame).
  Perturbed p = perturbed_box(0.05, 7);
  Body& body = p.body;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> fraction(0.05, 1.0);
  body.solid_fractions.resize(body.num_elements());
  for (Index e = 0; e < body.num_elements(); ++e) body.solid_fractions[e] = fraction(rng);
  // The material's share of each node, at x and at rest, and the whole share.
  auto shares = [&](const Points& x) {
    Eigen::VectorXd material = Eigen::VectorXd::Zero(body.num_nodes()), whole = material;
    for (Index e = 0; e < body.num_elements(); ++e) {
      Eigen::Matrix3d Ds;
      for (int k = 1; k < 4; ++k) Ds.col(k - 1) = (x.row(body.tets(e, k)) - x.row(body.tets(e, 0))).transpose();
      const double V = Ds.determinant() / 6.0, rest = body.rest_volumes[e];
      for (int k = 0; k < 4; ++k) {
        material[body.tets(e, k)] += 0.25 * body.solid_fractions[e] * (V - rest);
        whole[body.tets(e, k)] += 0.25 * rest;
      }
    }
    return material.cwiseAbs().cwiseQuotient(whole).maxCoeff();
  };
  EXPECT_GT(shares(body.positions), 0.01) << "the test must start far from the constraint";
  VolumeProjection projection;
  projection.project(body, p.start, {}, 1e-3, 0.0);  // no surface: the targets unscaled
  EXPECT_LE(shares(body.positions), VolumeProjectionSettings{}.tolerance);
}

TEST(VolumeProjection, SlidingNodesAreFreeAlongTheirContactsOnly) {
  // Two elements of a box share nodes; one is pressed from above (the
  // obstacle's outward normal −z), the other from above and the side (+x),
  // and again from above within half a degree of −z (no new direction).
  Material m;
  const Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.2), Eigen::Vector3i::Constant(2)), m);
  const double tilt = 0.5 * M_PI / 180.0;
  const std::vector<ElementContact> contacts{{0, {0.0, 0.0, -1.0}},
                                             {1, {1.0, 0.0, 0.0}},
                                             {1, {std::sin(tilt), 0.0, -std::cos(tilt)}}};
  const SlidingNodes s = SlidingNodes::from_contacts(body, contacts);
  const Eigen::Matrix3d z_held = Eigen::Vector3d(1, 1, 0).asDiagonal(), y_only = Eigen::Vector3d(0, 1, 0).asDiagonal();
  for (Index n = 0; n < body.num_nodes(); ++n) {
    bool in0 = false, in1 = false;
    for (int k = 0; k < 4; ++k) in0 = in0 || body.tets(0, k) == n, in1 = in1 || body.tets(1, k) == n;
    const auto i = static_cast<std::size_t>(n);
    EXPECT_EQ(s.sliding[i], in0 || in1 ? 1 : 0) << n;
    const Eigen::Matrix3d expected = in1 ? y_only : in0 ? z_held : Eigen::Matrix3d::Identity();
    EXPECT_TRUE(test::matrices_near(s.free[i], expected, 1e-15)) << n << "\n" << s.free[i];
  }
}

/// The top layer of a box's nodes pushed 2 % of its height down (as a
/// press's position corrections would); the nodes of the top elements are
/// held against the press (outward normal −z).
struct Pressed {
  Body body;
  SlidingNodes sliding;
};

Pressed pressed_box() {
  Material m;
  m.incompressible = true;
  Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.2), Eigen::Vector3i::Constant(4)), m);
  const double top = body.positions.col(2).maxCoeff();
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (body.positions(n, 2) == top) body.positions(n, 2) -= 0.02 * 0.2;
  std::vector<ElementContact> contacts;
  for (Index e = 0; e < body.num_elements(); ++e)
    for (int k = 0; k < 4; ++k)
      if (body.rest_positions(body.tets(e, k), 2) == top) {
        contacts.push_back({e, {0.0, 0.0, -1.0}});
        break;
      }
  SlidingNodes sliding = SlidingNodes::from_contacts(body, contacts);
  return {std::move(body), std::move(sliding)};
}

TEST(VolumeProjection, RestoreGivesBackThePressedVolumeAlongThePressInThePositionsAlone) {
  // Restoring gives every node its volume back by moving the others: the
  // held ones keep their height, velocities do not change.
  Pressed pressed = pressed_box();
  Body& body = pressed.body;
  const SlidingNodes& sliding = pressed.sliding;
  const Points before = body.positions, velocities = body.velocities;
  const double error = max_nodal_volume_error(body, body.positions);
  EXPECT_GT(error, 0.02) << "the test must start far from the constraint";
  VolumeProjection projection;
  const VolumeProjectionStats stats = projection.restore(body, {}, sliding);
  EXPECT_DOUBLE_EQ(stats.error_before, error);
  EXPECT_LE(max_nodal_volume_error(body, body.positions), VolumeProjectionSettings{}.tolerance);
  EXPECT_TRUE(body.velocities == velocities);
  double moved = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    moved = std::max(moved, (body.positions.row(n) - before.row(n)).norm());
    if (sliding.sliding[static_cast<std::size_t>(n)]) {
      EXPECT_EQ(body.positions(n, 2), before(n, 2)) << n;
    }
  }
  EXPECT_GT(moved, 1e-4) << "the other nodes give the volume back";
  // Without the contacts the top nodes rise back instead.
  Body free_body = body;
  free_body.positions = before;
  projection.restore(free_body, {}, SlidingNodes{});
  EXPECT_GT((free_body.positions.col(2) - before.col(2)).maxCoeff(), 1e-4);
}

TEST(VolumeProjection, ARestoreWithinItsThresholdMovesNothingAndLeavesNoTrace) {
  // A restore whose nodes are all within `from` stops at its first
  // measurement (the constraints' half of a preparation alone): nothing
  // moves, the error it reports is the body's, and a later restore is a
  // fresh one's to the bit. Just under the error, it runs as from 0.
  const Pressed pressed = pressed_box();
  const double error = max_nodal_volume_error(pressed.body, pressed.body.positions);
  VolumeProjection projection;
  Body held = pressed.body;
  const VolumeProjectionStats kept = projection.restore(held, {}, pressed.sliding, 2.0 * error);
  EXPECT_EQ(kept.newton_iterations, 0);
  EXPECT_EQ(kept.cg_iterations, 0);
  EXPECT_DOUBLE_EQ(kept.error_before, error);  // every node of the box has a rest volume
  EXPECT_TRUE(held.positions == pressed.body.positions);
  Body moved = pressed.body, reference = pressed.body;
  const VolumeProjectionStats ran = projection.restore(moved, {}, pressed.sliding, 0.5 * error);
  VolumeProjection fresh;
  const VolumeProjectionStats from_zero = fresh.restore(reference, {}, pressed.sliding);
  EXPECT_GT(ran.newton_iterations, 0);
  EXPECT_EQ(ran.cg_iterations, from_zero.cg_iterations);
  EXPECT_DOUBLE_EQ(ran.error_before, error);
  EXPECT_TRUE(moved.positions == reference.positions);
}

TEST(VolumeProjection, ARestoreStartsFromTheLastOnesMultipliers) {
  // A press takes the same volume step after step: the second restore of
  // the same pressed state starts at the first one's answer and needs
  // fewer iterations for the same tolerance; after reset() a restore is
  // again a fresh one's, bit for bit.
  const Pressed pressed = pressed_box();
  const double tolerance = VolumeProjectionSettings{}.tolerance;
  VolumeProjection projection;
  Body first = pressed.body, second = pressed.body, third = pressed.body;
  const VolumeProjectionStats s1 = projection.restore(first, {}, pressed.sliding);
  const VolumeProjectionStats s2 = projection.restore(second, {}, pressed.sliding);
  EXPECT_LE(max_nodal_volume_error(second, second.positions), tolerance);
  EXPECT_LT(s2.cg_iterations, s1.cg_iterations);
  projection.reset();
  const VolumeProjectionStats s3 = projection.restore(third, {}, pressed.sliding);
  EXPECT_EQ(s3.cg_iterations, s1.cg_iterations);
  EXPECT_TRUE(third.positions == first.positions);
}

TEST(VolumeProjection, TheNextStepReusesThePreparationOnlyWhereNothingItReadChanged) {
  // A velocity projection at a step's end, then the next step's projection
  // from the same positions, which reuses the velocity projection's
  // preparation (G, masses, rest volumes, the preconditioner): the same
  // bits as a fresh projection given the same state, also where what the
  // preparation read changed in between.
  enum class Change { kNothing, kMass, kPlastic, kFraction, kFixed, kStart };
  const double dt = 1e-3;
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Points unchanged;
  for (const Change change : {Change::kNothing, Change::kMass, Change::kPlastic, Change::kFraction, Change::kFixed,
                              Change::kStart}) {
    Perturbed p = perturbed_box(0.0, 19);
    Body& body = p.body;
    const Index nn = body.num_nodes();
    Points forces = Points::Zero(nn, 3);
    VolumeProjection reused;
    reused.project_velocities(body, {}, dt, 0.5 * dt, forces);
    std::vector<std::uint8_t> fixed;
    switch (change) {
      case Change::kNothing: break;
      case Change::kMass: body.masses[7] *= 1.5; break;
      case Change::kPlastic: body.Fp[3] = Eigen::Vector3d(1.1, 1.0, 1.0).asDiagonal(); break;
      case Change::kFraction: body.solid_fractions = Eigen::VectorXd::Constant(body.num_elements(), 0.8); break;
      case Change::kFixed:
        fixed.assign(static_cast<std::size_t>(nn), 0);
        fixed[5] = 1;
        break;
      case Change::kStart: body.positions(9, 0) += 1e-4; break;
    }
    const Points start = body.positions;
    // A step along the velocities, then off by up to 1 % of a cell.
    body.positions = start + dt * body.velocities;
    for (Index n = 0; n < nn; ++n) body.positions.row(n) += 0.01 * 0.05 * Eigen::RowVector3d(u(rng), u(rng), u(rng));
    Body copy = body;
    VolumeProjection fresh;
    const VolumeProjectionStats a = reused.project(body, start, fixed, dt, 0.5 * dt);
    const VolumeProjectionStats b = fresh.project(copy, start, fixed, dt, 0.5 * dt);
    EXPECT_GE(a.newton_iterations, 1);
    EXPECT_EQ(a.cg_iterations, b.cg_iterations) << static_cast<int>(change);
    EXPECT_TRUE(body.positions == copy.positions) << static_cast<int>(change);
    EXPECT_TRUE(body.velocities == copy.velocities) << static_cast<int>(change);
    if (change == Change::kNothing) {
      unchanged = body.positions;
      rng.seed(23);  // the same offsets for every change
    } else {
      rng.seed(23);
      EXPECT_FALSE(body.positions == unchanged) << "the change must matter: " << static_cast<int>(change);
    }
  }
}

TEST(VolumeProjection, TheVelocityProjectionReusesTheForcesGradientOnlyWhereNothingItReadChanged) {
  // The force evaluation takes G at xⁿ⁺¹ for the carried pressures; the
  // velocity projection at the same xⁿ⁺¹ reuses it: the same bits as a
  // fresh projection given the same state, also where the positions, the
  // fractions or the mesh (an element's corners renumbered by an even
  // permutation: the same tetrahedron, its G columns in another order)
  // changed in between.
  enum class Change { kNothing, kPosition, kFraction, kMesh };
  const double dt = 1e-3;
  Points unchanged;
  for (const Change change : {Change::kNothing, Change::kPosition, Change::kFraction, Change::kMesh}) {
    Perturbed p = perturbed_box(0.02, 29);
    Body& body = p.body;
    const Index nn = body.num_nodes();
    Points forces = Points::Zero(nn, 3);
    VolumeProjection reused;
    reused.project_velocities(body, {}, dt, 0.5 * dt, forces);  // carries pressures
    reused.add_pressure_forces(body, body.positions, forces);   // G at these positions
    switch (change) {
      case Change::kNothing: break;
      case Change::kPosition: body.positions(9, 0) += 1e-4; break;
      case Change::kFraction: body.solid_fractions = Eigen::VectorXd::Constant(body.num_elements(), 0.8); break;
      case Change::kMesh: {
        const Eigen::Matrix<Index, 1, 4> corners = body.tets.row(11);
        body.tets.row(11) << corners[1], corners[2], corners[0], corners[3];
        body.incidence = NodeIncidence::build(body.tets, nn);
        break;
      }
    }
    std::mt19937 rng(31);  // the same velocities for every change, which change the volumes
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (Index n = 0; n < nn; ++n) body.velocities.row(n) += 0.1 * Eigen::RowVector3d(u(rng), u(rng), u(rng));
    Body copy = body;
    VolumeProjection fresh;
    Points forces_copy = forces;
    const VolumeProjectionStats a = reused.project_velocities(body, {}, dt, 0.5 * dt, forces);
    const VolumeProjectionStats b = fresh.project_velocities(copy, {}, dt, 0.5 * dt, forces_copy);
    EXPECT_GE(a.newton_iterations, 1) << static_cast<int>(change);
    EXPECT_EQ(a.cg_iterations, b.cg_iterations) << static_cast<int>(change);
    EXPECT_TRUE(body.velocities == copy.velocities) << static_cast<int>(change);
    if (change == Change::kNothing)
      unchanged = body.velocities;
    else
      EXPECT_FALSE(body.velocities == unchanged) << "the change must matter: " << static_cast<int>(change);
  }
}

TEST(VolumeProjection, ANodeWithMoreThanSixtyFourNeighboursIsHeldLikeAnyOther) {
  // A fan of 2 × 70 tets about the z axis: the centre node shares an element
  // with all 72 other nodes (the projection gathers a row of more than 64
  // neighbours apart from the others).
  constexpr int kSectors = 70;
  TetMesh fan;
  fan.positions.resize(kSectors + 3, 3);
  fan.positions.row(0) << 0.0, 0.0, 0.0;
  fan.positions.row(1) << 0.0, 0.0, 0.05;
  fan.positions.row(2) << 0.0, 0.0, -0.05;
  for (int k = 0; k < kSectors; ++k) {
    const double angle = 2.0 * M_PI * k / kSectors;
    fan.positions.row(3 + k) << 0.1 * std::cos(angle), 0.1 * std::sin(angle), 0.0;
  }
  fan.tets.resize(2 * kSectors, 4);
  for (int k = 0; k < kSectors; ++k) {
    const int a = 3 + k, b = 3 + (k + 1) % kSectors;
    fan.tets.row(2 * k) << 0, a, b, 1;
    fan.tets.row(2 * k + 1) << 0, b, a, 2;
  }
  Material m;
  m.incompressible = true;
  Body body = make_body(fan, m);
  ASSERT_GT(body.rest_volumes.minCoeff(), 0.0) << "the fan's tets must be positively oriented";
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Points start = body.positions;
  const double dt = 1e-3;
  for (Index n = 0; n < body.num_nodes(); ++n) body.velocities.row(n) << u(rng), u(rng), u(rng);
  body.velocities *= 0.002 / dt;  // up to 2 mm a step, the fan 50 mm high above and below its centre
  body.positions = start + dt * body.velocities;
  const double before = max_nodal_volume_error(body, body.positions);
  ASSERT_GT(before, 10.0 * VolumeProjectionSettings{}.tolerance) << "the test must start far from the constraint";
  const Eigen::Vector3d P0 = linear_momentum(body);
  VolumeProjection projection;
  const VolumeProjectionStats stats = projection.project(body, start, {}, dt, dt);
  EXPECT_LE(max_nodal_volume_error(body, body.positions), VolumeProjectionSettings{}.tolerance);
  EXPECT_GE(stats.newton_iterations, 1);
  const double mass = body.masses.sum(), speed = body.velocities.rowwise().norm().maxCoeff();
  EXPECT_TRUE(test::matrices_near(linear_momentum(body), P0, 1e-12 * mass * speed));
}

TEST(VolumeProjection, BitwiseIdenticalWithOneAndTwoThreads) {
  Points result[2];
  for (int threads = 1; threads <= 2; ++threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    // Large enough that the loops split (more than one grain of elements).
    Material m;
    m.incompressible = true;
    Body body = make_body(make_box_tets(Eigen::Vector3d::Constant(0.2), Eigen::Vector3i::Constant(8)), m);
    std::mt19937 rng(17);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Points start = body.positions;
    for (Index n = 0; n < body.num_nodes(); ++n) body.velocities.row(n) << u(rng), u(rng), u(rng);
    body.positions = start + 1e-3 * body.velocities;
    VolumeProjection projection;
    projection.project(body, start, {}, 1e-3, 1e-3);
    result[threads - 1] = body.positions;
  }
  EXPECT_TRUE(result[0] == result[1]);
}

}  // namespace
}  // namespace goo
