#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/collisions.h"
#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "solvers/newmark.h"
#include "solvers/remesh.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

constexpr double kPi = 3.14159265358979323846;

Material gel(double viscosity = 0.0) {
  Material m;
  m.density = 1000.0;
  m.youngs_modulus = 2e4;
  m.poisson_ratio = 0.3;
  m.viscosity = viscosity;
  m.min_mass_fraction = 0.1;
  return m;
}

Obstacle floor_at(double height, double friction = 0.0) {
  return {"floor", make_half_space(Eigen::Vector3d::UnitZ(), height), {}, friction};
}

double lowest(const Body& body) { return body.surface().vertices.col(2).minCoeff(); }

/// One element, one embedded vertex with generic barycentric coordinates.
Body single_element(const Eigen::Vector4d& b) {
  Body body = make_body(test::corner_tetrahedron(), gel());
  body.embedding.parent = {0};
  body.embedding.bary = b.transpose();
  return body;
}

// W&T eq. 4: moving the nodes by w_i Δx moves the vertex by exactly Δx, so
// the resolved vertex lands on the obstacle's surface.
TEST(Collisions, ResolvedVertexLandsExactlyOnTheObstacle) {
  const Eigen::Vector4d b(0.1, 0.2, 0.3, 0.4);
  for (const Obstacle& obstacle :
       {floor_at(0.5), Obstacle{"ball", make_sphere_shape(0.6), {}, 0.0},
        Obstacle{"tilted", make_half_space(Eigen::Vector3d(0.3, -0.2, 1.0), 0.5), {}, 0.0}}) {
    SCOPED_TRACE(obstacle.name);
    Body body = single_element(b);
    const Eigen::Vector3d before = body.surface().vertices.row(0).transpose();
    ASSERT_LT(obstacle.query(before, 0.0).distance, 0.0);
    SurfaceCollisions collisions;
    const CollisionStats stats = collisions.resolve_positions(body, {obstacle}, 0.0, {}, 1);
    EXPECT_EQ(stats.resolved, 1);
    const Eigen::Vector3d after = body.surface().vertices.row(0).transpose();
    EXPECT_NEAR(obstacle.query(after, 0.0).distance, 0.0, 1e-15);
    // It moved along the obstacle's normal, by the penetration depth.
    EXPECT_NEAR((after - before).norm(), -obstacle.query(before, 0.0).distance, 1e-15);
  }
}

// A fine surface puts hundreds of vertices in one element: the deepest of
// them is the one resolved, whatever obstacles far away there are.
TEST(Collisions, TheDeepestOfHundredsOfVerticesInOneElementIsResolved) {
  Body body = single_element(Eigen::Vector4d(0.25, 0.25, 0.25, 0.25));
  const int n = 500;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  body.embedding.parent.assign(n, 0);
  body.embedding.bary.resize(n, 4);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector4d b(u(rng), u(rng), u(rng), u(rng));
    body.embedding.bary.row(i) = (b / b.sum()).transpose();
  }
  // A ball moved far away by its motion, then the floor through the element.
  RigidMotion far({RigidMotion::Key{0.0, Eigen::Vector3d(5, 5, 5), Eigen::Quaterniond::Identity()}});
  const std::vector<Obstacle> obstacles{Obstacle{"far ball", make_sphere_shape(0.1), far, 0.0}, floor_at(0.3)};
  const Points before = body.surface().vertices;
  Index deepest = 0;
  for (Index i = 1; i < n; ++i)
    if (before(i, 2) < before(deepest, 2)) deepest = i;
  ASSERT_LT(before(deepest, 2), 0.3);
  SurfaceCollisions collisions;
  const CollisionStats stats = collisions.resolve_positions(body, obstacles, 0.0, {}, 1);
  EXPECT_EQ(stats.resolved, 1);  // one element
  EXPECT_NEAR(stats.deepest, before(deepest, 2) - 0.3, 1e-15);
  EXPECT_NEAR(body.surface().vertices(deepest, 2), 0.3, 1e-15);  // the deepest landed on the floor
}

// Curved obstacles are measured at a vertex only where the ball about its
// element's vertices cannot rule it out (sd(p) ≥ sd(c) − |p − c|): every
// penetration is still found. A fine surface (hundreds of vertices an
// element), its nodes shaken so that elements are skewed, against a ball,
// a tilted cylinder and a rotated box placed at random across it: the
// deepest penetration met is the least signed distance over every vertex
// and obstacle, measured one by one, and every element with a vertex
// inside an obstacle has its hit.
TEST(Collisions, EveryPenetrationOfCurvedObstaclesIsFoundWhereverTheyStand) {
  TriangleMesh cube = make_box({0.3, 0.3, 0.3}, 16);
  cube.vertices.rowwise() += Eigen::RowVector3d(0.013, -0.007, 0.25);
  const MeshedBody meshed = mesh_body(cube, gel(), 0.1);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int penetrating = 0;
  for (int trial = 0; trial < 60; ++trial) {
    SCOPED_TRACE(::testing::Message() << "trial " << trial);
    auto placed = [&](double spread) {
      const Eigen::Quaterniond q = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
      const Eigen::Vector3d at = Eigen::Vector3d(0.013, -0.007, 0.25) + spread * Eigen::Vector3d(u(rng), u(rng), u(rng));
      return RigidMotion({RigidMotion::Key{0.0, at, q}});
    };
    const std::vector<Obstacle> obstacles{
        Obstacle{"ball", make_sphere_shape(0.05 + 0.04 * u(rng)), placed(0.2), 0.0},
        Obstacle{"bar", make_cylinder_shape(0.03 + 0.02 * u(rng), 0.3), placed(0.2), 0.0},
        Obstacle{"brick", make_box_shape(Eigen::Vector3d(0.05, 0.02, 0.3)), placed(0.2), 0.0}};
    Body body = meshed.body;
    for (Index n = 0; n < body.num_nodes(); ++n)
      body.positions.row(n) += 0.02 * Eigen::RowVector3d(u(rng), u(rng), u(rng));
    const Points vertices = body.surface().vertices;
    double deepest = 0.0;
    std::vector<std::uint8_t> hit(static_cast<std::size_t>(body.num_elements()), 0);
    for (Index i = 0; i < vertices.rows(); ++i)
      for (const Obstacle& o : obstacles) {
        const double d = o.query(vertices.row(i).transpose(), 0.0).distance;
        deepest = std::min(deepest, d);
        if (d < 0.0) hit[static_cast<std::size_t>(body.embedding.parent[static_cast<std::size_t>(i)])] = 1;
      }
    penetrating += deepest < 0.0;
    SurfaceCollisions collisions;
    const CollisionStats stats = collisions.resolve_positions(body, obstacles, 0.0, {}, 1);
    EXPECT_NEAR(stats.deepest, deepest, 1e-15);
    EXPECT_EQ(stats.resolved, std::count(hit.begin(), hit.end(), 1));
  }
  EXPECT_GT(penetrating, 40);  // most placements cut the body
}

// Velocities: the normal relative velocity of the resolved vertex becomes
// zero, exactly; with friction the tangential speed drops by μ × that change.
TEST(Collisions, VelocityResponseRemovesApproachAndAppliesCoulombFriction) {
  const Eigen::Vector4d b(0.1, 0.2, 0.3, 0.4);
  Body body = single_element(b);
  Points v(4, 3);
  v.rowwise() = Eigen::RowVector3d(3.0, 0.0, -2.0);
  SurfaceCollisions collisions;
  const Obstacle floor = floor_at(0.3, 0.5);
  const CollisionStats stats = collisions.resolve_velocities(body, v, {floor}, 0.0, 0.1, {});
  EXPECT_EQ(stats.resolved, 1);
  Eigen::Vector3d vs = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) vs += b[k] * v.row(k).transpose();
  EXPECT_NEAR(vs.z(), 0.0, 1e-15);
  EXPECT_NEAR(vs.x(), 3.0 - 0.5 * 2.0, 1e-15);
  EXPECT_NEAR(vs.y(), 0.0, 1e-15);
  // Receding vertices are left alone.
  v.rowwise() = Eigen::RowVector3d(0.0, 0.0, 1.0);
  EXPECT_EQ(collisions.resolve_velocities(body, v, {floor_at(0.4)}, 0.0, 0.1, {}).resolved, 0);
}

// Friction acts per node (Coulomb): every node the normal response moved
// loses of its tangential velocity relative to the floor exactly
// min(its tangential speed, μ × the normal change it received), along that
// velocity; so with μ large every such node stops along the floor, and the
// elements in contact move alike (none is held at one node and dragged at
// the next, which folded a puddle's bottom). Friction applied at each
// element's deepest vertex stopped that vertex, its nodes by differing
// amounts.
TEST(Collisions, FrictionActsPerNodeWithinCoulombsBound) {
  TriangleMesh cube = make_box({0.3, 0.3, 0.3}, 8);
  cube.vertices.rowwise() += Eigen::RowVector3d(0.013, -0.007, 0.25);
  const MeshedBody meshed = mesh_body(cube, gel(), 0.1);
  const Body& body = meshed.body;
  const double dt = 0.01;
  for (const double mu : {0.2, 10.0}) {
    SCOPED_TRACE(::testing::Message() << "mu " << mu);
    const Obstacle floor = floor_at(lowest(body) - 0.002, mu);
    Points v(body.num_nodes(), 3);
    v.rowwise() = Eigen::RowVector3d(1.0, 0.5, -1.0);
    const Points before = v;
    SurfaceCollisions collisions;
    ASSERT_GT(collisions.resolve_velocities(body, v, {floor}, 0.0, dt, {}).resolved, 0);
    int moved = 0, stopped = 0;
    for (Index n = 0; n < body.num_nodes(); ++n) {
      const Eigen::Vector3d change = (v.row(n) - before.row(n)).transpose();
      if (change.isZero(0.0)) continue;
      ++moved;
      const double normal = std::abs(change.z());
      const double speed_before = before.row(n).head<2>().norm(), speed_after = v.row(n).head<2>().norm();
      EXPECT_NEAR(speed_before - speed_after, std::min(speed_before, mu * normal), 1e-14);
      // Along the velocity: the direction along the floor is kept.
      if (speed_after > 1e-14) {
        EXPECT_NEAR(v(n, 0) * before(n, 1) - v(n, 1) * before(n, 0), 0.0, 1e-14);
      } else {
        ++stopped;
      }
    }
    EXPECT_GE(moved, 9);
    EXPECT_LT(moved, body.num_nodes());  // the top is not touched
    if (mu > 1.0) {
      EXPECT_EQ(stopped, moved);
    }
  }
}

struct Drop {
  MeshedBody body;
  NewmarkSettings settings;
  double h;
};

Drop block(double h = 0.1) {
  TriangleMesh cube = make_box({0.3, 0.3, 0.3}, 3);
  cube.vertices.rowwise() += Eigen::RowVector3d(0.013, -0.007, 0.25);
  Drop d{mesh_body(cube, gel(300.0), h), {}, h};
  d.settings.max_time_step = 1e-3;
  return d;
}

// Passes after the first look again only where the earlier one moved
// nodes; they must find what full detections find: four passes in one call
// equal four calls of one pass each, bit for bit. (Two walls: a correction
// against one pushes vertices into the other or the floor, so the later
// passes meet real penetrations, not rounding, which they leave alone.)
TEST(Collisions, LaterPassesFindWhatAFullDetectionFinds) {
  Drop d = block();
  Body& body = d.body.body;
  body.positions.col(2).array() -= 0.3;  // its bottom 0.2 m under the floor, into two sloped walls
  const std::vector<Obstacle> obstacles{
      floor_at(0.0), Obstacle{"wall", make_half_space(Eigen::Vector3d(1.0, 0.2, 0.3), 0.1), {}, 0.0},
      Obstacle{"other wall", make_half_space(Eigen::Vector3d(-0.3, 1.0, 0.2), 0.05), {}, 0.0}};
  Body one_call = body, four_calls = body;
  SurfaceCollisions a, b;
  const CollisionStats together = a.resolve_positions(one_call, obstacles, 0.0, {}, 4);
  CollisionStats apart;
  for (int pass = 0; pass < 4; ++pass) {
    const CollisionStats s = b.resolve_positions(four_calls, obstacles, 0.0, {}, 1);
    apart.passes += s.passes;
    apart.resolved += s.resolved;
  }
  EXPECT_GE(together.passes, 3);  // two passes at least looked again where the first moved nodes
  EXPECT_EQ(together.passes, apart.passes);
  EXPECT_EQ(together.resolved, apart.resolved);
  EXPECT_TRUE(one_call.positions == four_calls.positions);
}

// A corrected vertex lands on the obstacle only to within the rounding of
// its signed distance; a penetration that shallow is none. One ulp below a
// floor at height ~0.4 (5.6e-17 m) is left alone, 1e-12 m is resolved.
TEST(Collisions, APenetrationWithinTheRoundingOfItsDistanceIsNone) {
  const Eigen::Vector4d b(0.1, 0.2, 0.3, 0.4);
  for (const bool rounding : {true, false}) {
    SCOPED_TRACE(rounding ? "one ulp deep" : "1e-12 m deep");
    Body body = single_element(b);
    const double z = body.surface().vertices(0, 2);
    const double floor = rounding ? std::nextafter(z, 1.0) : z + 1e-12;
    const Points before = body.positions;
    SurfaceCollisions collisions;
    const CollisionStats stats = collisions.resolve_positions(body, {floor_at(floor)}, 0.0, {}, 4);
    EXPECT_EQ(stats.resolved, rounding ? 0 : 1);
    if (rounding)
      EXPECT_TRUE(body.positions == before);
    else
      EXPECT_NEAR(body.surface().vertices(0, 2), floor, 1e-15);
  }
}

// The passes end by themselves once only rounding is left. A block moved
// 0.3 m down (its bottom 0.2 m under the floor) into a sloped wall, one
// pass a call: each call that corrects anything meets a real penetration
// (the first two 0.3 and 0.047 m deep), and a call soon finds nothing. (Before, from the third call
// on, each moved a few vertices by 10⁻¹⁷ m and found as many again.)
TEST(Collisions, PassesEndWhenOnlyRoundingIsLeft) {
  Drop d = block();
  Body& body = d.body.body;
  body.positions.col(2).array() -= 0.3;
  const std::vector<Obstacle> obstacles{
      floor_at(0.0), Obstacle{"wall", make_half_space(Eigen::Vector3d(1.0, 0.2, 0.3), 0.1), {}, 0.0}};
  SurfaceCollisions collisions;
  int calls = 0;
  for (; calls < 8; ++calls) {
    const CollisionStats stats = collisions.resolve_positions(body, obstacles, 0.0, {}, 1);
    if (stats.resolved == 0) break;
    EXPECT_LT(stats.deepest, -1e-9) << "call " << calls;  // micrometres and more, not rounding
  }
  EXPECT_GE(calls, 2);
  EXPECT_LT(calls, 8);
}

// A half-space is bounded per element from its nodes' distances and the
// ranges of its vertices' barycentric coordinates, and per vertex from the
// nodes' distances, before any vertex is measured: the bounds must never
// pass over a vertex inside. With vertices drifted far out of their
// parents (coordinates below −0.3), tilted and moving planes swept
// through the block, one pass resolves exactly the elements a test of
// every vertex finds inside, its deepest depth the same; the velocity
// stage finds the deepest vertex at x + Δt v. (As embedded, the
// coordinates' ranges are what the bound needs; drifted, the per-vertex one.)
class HalfSpaceBounds : public ::testing::TestWithParam<double> {};

TEST_P(HalfSpaceBounds, NeverPassOverAVertexInside) {
  TriangleMesh cube = make_box({0.3, 0.3, 0.3}, 8);  // several vertices in most elements
  cube.vertices.rowwise() += Eigen::RowVector3d(0.013, -0.007, 0.25);
  MeshedBody meshed = mesh_body(cube, gel(), 0.1);
  Body& body = meshed.body;
  std::mt19937 rng(5);
  const double spread = GetParam();
  std::uniform_real_distribution<double> u(-0.3, 0.3), drift(-spread, spread);
  for (Index s = 0; s < body.embedding.num_vertices(); ++s) {
    Eigen::Vector4d b = body.embedding.bary.row(s).transpose() +
                        Eigen::Vector4d(drift(rng), drift(rng), drift(rng), drift(rng));
    body.embedding.bary.row(s) = (b.array() - (b.sum() - 1.0) / 4.0).matrix().transpose();
  }
  if (spread > 0.0) {
    ASSERT_LT(body.embedding.bary.minCoeff(), -0.3);
  }
  Points v(body.num_nodes(), 3);
  for (Index n = 0; n < body.num_nodes(); ++n) v.row(n) = Eigen::RowVector3d(u(rng), u(rng), u(rng) - 1.0);
  const double dt = 0.02;
  const Eigen::Vector3d normal = Eigen::Vector3d(0.2, -0.3, 1.0).normalized();
  RigidMotion turning({RigidMotion::Key{0.0, Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity()},
                       RigidMotion::Key{1.0, Eigen::Vector3d(0.0, 0.0, 0.1),
                                        Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()))}});
  // Each vertex's position at x + t v, as the collision stage computes it.
  const auto at = [&](double t) {
    Points out(body.embedding.num_vertices(), 3);
    for (Index s = 0; s < out.rows(); ++s) {
      const Index e = body.embedding.parent[static_cast<std::size_t>(s)];
      Eigen::Vector3d p = Eigen::Vector3d::Zero(), q = Eigen::Vector3d::Zero();
      for (int k = 0; k < 4; ++k) {
        p += body.embedding.bary(s, k) * body.positions.row(body.tets(e, k)).transpose();
        q += body.embedding.bary(s, k) * v.row(body.tets(e, k)).transpose();
      }
      out.row(s) = (t == 0.0 ? p : p + t * q).transpose();
    }
    return out;
  };
  int planes = 0, ahead_only = 0;
  for (double offset = -0.1; offset < 0.45; offset += 0.02)
    for (const RigidMotion& motion : {RigidMotion{}, turning}) {
      SCOPED_TRACE(::testing::Message() << "offset " << offset << (motion.is_static() ? "" : ", moving"));
      const Obstacle plane{"plane", make_half_space(normal, offset), motion, 0.0};
      const double t = 0.5;
      // Positions: per element, is any vertex inside; the deepest depth.
      std::vector<char> inside(static_cast<std::size_t>(body.num_elements()), 0);
      double deepest = 0.0;
      const Points xs = at(0.0);
      for (Index s = 0; s < xs.rows(); ++s) {
        const double dist = plane.query(xs.row(s).transpose(), t).distance;
        if (dist < 0.0) inside[static_cast<std::size_t>(body.embedding.parent[static_cast<std::size_t>(s)])] = 1;
        deepest = std::min(deepest, dist);
      }
      const Index expected = static_cast<Index>(std::count(inside.begin(), inside.end(), 1));
      SurfaceCollisions collisions;
      if (expected > 0 && expected < body.num_elements()) {
        ++planes;
        Body moved = body;
        const CollisionStats stats = collisions.resolve_positions(moved, {plane}, t, {}, 1);
        EXPECT_EQ(stats.resolved, expected);
        EXPECT_NEAR(stats.deepest, deepest, 1e-15);
      }
      // Velocities: the deepest vertex at x + Δt v (some planes reach
      // none at x, some at x + Δt v).
      const Points ys = at(dt);
      double deepest_ahead = 0.0;
      for (Index s = 0; s < ys.rows(); ++s)
        deepest_ahead = std::min(deepest_ahead, plane.query(ys.row(s).transpose(), t).distance);
      if (deepest_ahead < 0.0 && deepest == 0.0) ++ahead_only;
      Points w = v;
      EXPECT_NEAR(collisions.resolve_velocities(body, w, {plane}, t, dt, {}).deepest, deepest_ahead, 1e-15);
    }
  EXPECT_GE(planes, 20);
  EXPECT_GE(ahead_only, 1);
}

// As embedded (every coordinate in [0, 1]), and drifted far out.
INSTANTIATE_TEST_SUITE_P(Collisions, HalfSpaceBounds, ::testing::Values(0.0, 0.5));

TEST(Collisions, BodyDroppedOnTheFloorComesToRestAboveIt) {
  Drop d = block();
  d.settings.max_time_step = 2.5e-3;
  Constraints c;
  c.obstacles = {floor_at(0.0)};
  NewmarkIntegrator integrator(d.settings, c);
  double worst = 1e9;
  const Body& body = d.body.body;
  while (integrator.time() < 1.5) {
    integrator.step(d.body.body, 1.5 - integrator.time());
    worst = std::min(worst, lowest(body));
  }
  // Never below the floor by more than 1e-6 h; resting on it, not hovering.
  EXPECT_GE(worst, -1e-6 * d.h);
  EXPECT_LT(lowest(body), 0.01 * d.h);
  // At rest: contacts are resolved at each half step, so a resting body
  // keeps at most the gravity of a step, g Δt, as mass-weighted speed
  // (0.025 m/s here, against the 1.3 m/s of the impact).
  EXPECT_LT(std::sqrt(2.0 * kinetic_energy(body) / body.masses.sum()), 9.81 * d.settings.max_time_step);
}

/// A block resting on a plane tilted by θ about y.
void slide(double theta, double friction, double seconds, Eigen::Vector3d* displacement) {
  const Eigen::Vector3d n(-std::sin(theta), 0.0, std::cos(theta));
  TriangleMesh cube = make_box({0.3, 0.3, 0.2}, 3);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(-theta, Eigen::Vector3d::UnitY()).toRotationMatrix();
  cube.vertices = cube.vertices * R.transpose();
  // Lowest point exactly on the plane n·x = 0.
  const Eigen::VectorXd heights = cube.vertices * n;
  cube.vertices.rowwise() -= heights.minCoeff() * n.transpose();
  Drop d{mesh_body(cube, gel(500.0), 0.1), {}, 0.1};
  d.settings.max_time_step = 1e-3;
  Constraints c;
  c.obstacles = {Obstacle{"slope", make_half_space(n, 0.0), {}, friction}};
  NewmarkIntegrator integrator(d.settings, c);
  const Body& body = d.body.body;
  const Eigen::Vector3d start = body.positions.transpose() * body.masses / body.masses.sum();
  integrator.advance_to(d.body.body, seconds);
  *displacement = body.positions.transpose() * body.masses / body.masses.sum() - start;
}

// Frictionless: every contact correction is along the plane's normal and
// internal forces sum to zero, so the centre of mass slides with g sin θ
// exactly (Newmark is exact for constant acceleration).
TEST(Collisions, FrictionlessBlockSlidesWithGSinTheta) {
  const double theta = kPi / 6.0, t = 0.5, g = 9.81;
  Eigen::Vector3d d;
  slide(theta, 0.0, t, &d);
  const Eigen::Vector3d down_slope(-std::cos(theta), 0.0, -std::sin(theta));
  EXPECT_NEAR(d.dot(down_slope), 0.5 * g * std::sin(theta) * t * t, 1e-9);
}

// With μ > tan θ the contact holds: the centre of mass moves down the slope
// no more than the block's own elastic shear under the slope's pull,
// γ H / 2 with γ = ρ g sin θ H / μ_shear (1.3 cm here), against 61 cm
// frictionless.
TEST(Collisions, BlockWithFrictionAboveTanThetaStaysPut) {
  const double theta = kPi / 6.0, t = 0.5, H = 0.2;
  Eigen::Vector3d d;
  slide(theta, 1.2 * std::tan(theta), t, &d);
  const Eigen::Vector3d down_slope(-std::cos(theta), 0.0, -std::sin(theta));
  const Material m = gel();
  const double shear = m.density * 9.81 * std::sin(theta) * H / m.mu();
  EXPECT_LT(std::abs(d.dot(down_slope)), shear * H / 2.0);
}

/// A soft block on the floor under a press that comes down to half its
/// height in one second.
struct Press {
  Drop drop = block();
  Constraints constraints;
  Press() {
    TriangleMesh cube = make_box({0.3, 0.3, 0.3}, 3);
    cube.vertices.rowwise() += Eigen::RowVector3d(0.013, -0.007, 0.1505);
    drop.body = mesh_body(cube, gel(50.0), drop.h);
    RigidMotion::Key top, bottom;
    top.translation = {0.0, 0.0, 0.3 + 0.1 + 0.02};
    bottom.time = 1.0;
    bottom.translation = {0.0, 0.0, 0.15 + 0.1};
    constraints.obstacles = {floor_at(0.0, 0.3),
                             Obstacle{"press", make_box_shape({0.5, 0.5, 0.1}), RigidMotion({top, bottom}), 0.3}};
  }
};

/// The deepest penetration of the body's surface into an obstacle.
double penetration(const Body& body, const Obstacle& obstacle, double t) {
  const Points xs = body.surface().vertices;
  double worst = 0.0;
  for (Index v = 0; v < xs.rows(); ++v) worst = std::min(worst, obstacle.query(xs.row(v).transpose(), t).distance);
  return worst;
}

TEST(Collisions, KinematicPressSqueezesABlockWithoutEnteringIt) {
  Press press;
  NewmarkIntegrator integrator(press.drop.settings, press.constraints);
  Body& body = press.drop.body.body;
  const double height = bounding_box(body.surface().vertices).sizes().z();
  double worst_press = 0.0, worst_floor = 0.0;
  while (integrator.time() < 1.0) {
    integrator.step(body, 1.0 - integrator.time());
    worst_press = std::min(worst_press, penetration(body, press.constraints.obstacles[1], integrator.time()));
    worst_floor = std::min(worst_floor, penetration(body, press.constraints.obstacles[0], integrator.time()));
  }
  EXPECT_GE(worst_press, -1e-6 * press.drop.h);
  EXPECT_GE(worst_floor, -1e-6 * press.drop.h);
  // Squeezed to half its height, and bulging sideways.
  const Eigen::AlignedBox3d box = bounding_box(body.surface().vertices);
  EXPECT_LT(box.sizes().z(), 0.5 * height + 1e-3);
  EXPECT_GT(box.sizes().x(), 0.3 * 1.1);
}

TEST(Collisions, SphereObstacleDeflectsAFallingBody) {
  TriangleMesh cube = make_box({0.2, 0.2, 0.2}, 2);
  cube.vertices.rowwise() += Eigen::RowVector3d(0.08, 0.003, 0.45);
  MeshedBody mb = mesh_body(cube, gel(50.0), 0.07);
  NewmarkSettings settings;
  settings.max_time_step = 1e-3;
  Constraints c;
  c.obstacles = {Obstacle{"ball", make_sphere_shape(0.2), {}, 0.0}};
  NewmarkIntegrator integrator(settings, c);
  double worst = 0.0;
  while (integrator.time() < 0.5) {
    integrator.step(mb.body, 0.5 - integrator.time());
    worst = std::min(worst, penetration(mb.body, c.obstacles[0], integrator.time()));
  }
  EXPECT_GE(worst, -1e-6 * 0.07);
  // Pushed off to +x (the side its centre was on), slowed in its fall.
  const Eigen::Vector3d momentum = linear_momentum(mb.body);
  EXPECT_GT(momentum.x(), 0.05 * mb.body.masses.sum());
  EXPECT_GT(momentum.z(), -9.81 * 0.5 * 0.9 * mb.body.masses.sum());
}

TEST(Collisions, SameBitsForAnyThreadCount) {
  auto run = [](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Press press;
    NewmarkIntegrator integrator(press.drop.settings, press.constraints);
    integrator.advance_to(press.drop.body.body, 0.3);
    return press.drop.body.body.positions;
  };
  EXPECT_TRUE(run(1) == run(2));
}

}  // namespace
}  // namespace goo
