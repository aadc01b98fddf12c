// Self-collisions of the embedded surface over one step: no crossing at any
// time of the step, momentum kept, nothing changed when nothing approaches,
// the same bits on one and two threads.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>

#include <fmt/format.h>

#include "core/contact/calm_stars.h"
#include "core/contact/ccd.h"
#include "core/elastic_forces.h"
#include "core/parallel.h"
#include "core/contact/self_collisions.h"
#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "meshing/surface_intersections.h"
#include "io/scene_io.h"
#include "solvers/remesh.h"
#include "solvers/simulation.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Material gel() {
  Material m;
  m.density = 1000.0;
  m.youngs_modulus = 2e4;
  m.poisson_ratio = 0.3;
  m.min_mass_fraction = 0.1;
  return m;
}

/// Two boxes of 0.1 m (the lower one `lower_width` wide), one above the
/// other with a gap, in one body on a 0.04 m lattice (a gap over two lattice
/// spacings: no element holds both); each face split into `subdivisions`²
/// squares.
MeshedBody stacked_boxes_meshed(double gap, double lower_width = 0.1, int subdivisions = 4) {
  TriangleMesh a = make_box({lower_width, lower_width, 0.1}, subdivisions),
               b = make_box({0.1, 0.1, 0.1}, subdivisions);
  b.vertices.col(2).array() += 0.1 + gap;
  return mesh_body(test::joined(a, b), gel(), 0.04);
}

Body stacked_boxes(double gap, double lower_width = 0.1, int subdivisions = 4) {
  return stacked_boxes_meshed(gap, lower_width, subdivisions).body;
}

/// Crossing triangle pairs of the surface at time t of the step x0 → x0 + d.
std::size_t crossings_at(const Body& body, const Points& x0, const Points& d, double t) {
  const Points x = x0 + t * d;
  return self_intersecting_pairs({body.embedding.surface_positions(body.tets, x), body.surface_triangles}).size();
}

Eigen::Vector3d momentum_change(const Body& body, const Points& before, const Points& after) {
  return ((after - before).array().colwise() * body.masses.array()).colwise().sum().transpose();
}

double momentum_scale(const Body& body, const Points& d) {
  return (d.rowwise().norm().array() * body.masses.array()).sum();
}

TEST(SelfCollisions, BoxThrownThroughAnotherWithinOneStepStopsOnIt) {
  const double gap = 0.1;
  const Body body = stacked_boxes(gap);
  const Points x0 = body.positions;
  // The upper box's nodes move 0.4 m down in one step: through the lower box.
  Points d = Points::Zero(body.num_nodes(), 3);
  const double split = 0.05 + 0.5 * gap;
  for (Index n = 0; n < body.num_nodes(); ++n)
    if (x0(n, 2) > split) d(n, 2) = -0.4;
  const Points before = d;
  ASSERT_EQ(crossings_at(body, x0, d, 0.0), 0u);
  ASSERT_GT(crossings_at(body, x0, d, 0.5), 0u);  // without the stage they cross
  SelfCollisions stage;
  const SelfCollisionStats stats = stage.resolve(body, x0, d, {}, {1e-4, 0.0, 8});
  EXPECT_GT(stats.impacts + stats.zone_nodes, 0);
  for (const double t : {0.05, 0.1, 0.25, 0.5, 0.75, 1.0}) EXPECT_EQ(crossings_at(body, x0, d, t), 0u) << "t = " << t;
  // The upper box ends on the lower one, not below its top.
  const Points xs = body.embedding.surface_positions(body.tets, x0 + d);
  const Index half = static_cast<Index>(xs.rows() / 2);
  EXPECT_GE(xs.bottomRows(xs.rows() - half).col(2).minCoeff(), xs.topRows(half).col(2).maxCoeff() - 1e-12);
  // Impulses are equal and opposite: momentum moves between the boxes only.
  EXPECT_LT(momentum_change(body, before, d).norm(), 1e-12 * momentum_scale(body, before));
}

TEST(SelfCollisions, NothingChangesWhenNothingApproaches) {
  const Body body = stacked_boxes(0.1);
  const Points x0 = body.positions;
  SelfCollisions stage;
  // A common translation, and the boxes drawing apart: not a bit changes.
  for (const double lift : {0.0, 0.02}) {
    Points d = Points::Constant(body.num_nodes(), 3, -0.013);
    for (Index n = 0; n < body.num_nodes(); ++n)
      if (x0(n, 2) > 0.1) d(n, 2) += lift;
    const Points before = d;
    const SelfCollisionStats stats = stage.resolve(body, x0, d, {}, {1e-4, 0.0, 8});
    EXPECT_EQ(stats.impacts + stats.repulsions + stats.zone_nodes, 0);
    EXPECT_TRUE(d == before);
  }
}

TEST(SelfCollisions, PartsOfOneSurfaceClosingInOnEachOtherRigidlyAreCaughtFromAfar) {
  // The upper box comes down on the lower one rigidly, 4 mm a step, from
  // 0.1 m away: every vertex moves exactly with the cluster it lies in, so
  // only the clusters' parting tells the list that pairs between the boxes
  // draw near (without that check the list built with the boxes apart
  // holds, and the boxes pass through each other).
  const double gap = 0.1, step = 0.004;
  const Body body = stacked_boxes(gap);
  Points x = body.positions;
  const double split = 0.05 + 0.5 * gap;
  SelfCollisions stage;
  Index builds_apart = 0, impacts = 0;
  const int steps_apart = 11, steps = 32;  // touching from step 25 on
  for (int k = 0; k < steps; ++k) {
    Points d = Points::Zero(body.num_nodes(), 3);
    for (Index n = 0; n < body.num_nodes(); ++n)
      if (body.positions(n, 2) > split) d(n, 2) = -step;
    const SelfCollisionStats stats = stage.resolve(body, x, d, {}, {1e-4, 0.0, 8});
    if (k < steps_apart) builds_apart += stats.list_builds;
    impacts += stats.impacts + stats.zone_nodes;
    for (const double t : {0.5, 1.0}) ASSERT_EQ(crossings_at(body, x, d, t), 0u) << "step " << k << ", t = " << t;
    x += d;
  }
  EXPECT_GT(impacts, 0);
  const Points xs = body.embedding.surface_positions(body.tets, x);
  const Index half = static_cast<Index>(xs.rows() / 2);
  EXPECT_GE(xs.bottomRows(xs.rows() - half).col(2).minCoeff(), xs.topRows(half).col(2).maxCoeff() - 1e-12);
  // While the boxes are apart the list built at the first step holds as
  // long as their hulls' distance allows: (0.1 m − 2δ)/√3 less four slacks
  // and two margins (a twentieth and a tenth of the mean edge, 2.85 cm)
  // is 46 mm, so through step 10 (44 mm closer). One frame for the whole
  // surface moving with its mean would have rebuilt it at steps 4 and 8
  // (each box drifts 2 mm a step from the mean; its margin is 4× that).
  EXPECT_EQ(builds_apart, 1);
}

TEST(SelfCollisions, AListAfterClustersPartedLetsThemPartFurther) {
  // The upper box rises 0.35 mm a step from 1 cm above the lower one. The
  // first list allows the boxes' clusters to part by their slacks' floor
  // (a twentieth of the mean edge each); once they have, the next list's
  // slacks cover eight times the step's parting (up to a tenth of the mean
  // edge), so it lasts about twice as long. What is reported never depends
  // on the list: each step's displacements are a fresh stage's, bit for bit.
  const double gap = 0.01, step = 0.00035;
  const Body body = stacked_boxes(gap);
  const double split = 0.05 + 0.5 * gap;
  Points x = body.positions;
  SelfCollisions kept;
  std::vector<int> built;
  for (int k = 0; k < 40; ++k) {
    SCOPED_TRACE(k);
    Points d = Points::Zero(body.num_nodes(), 3);
    for (Index n = 0; n < body.num_nodes(); ++n)
      if (body.positions(n, 2) > split) d(n, 2) = step;
    Points fresh_d = d;
    const SelfCollisionStats stats = kept.resolve(body, x, d, {}, {1e-4, 0.0, 8});
    SelfCollisions fresh;
    fresh.resolve(body, x, fresh_d, {}, {1e-4, 0.0, 8});
    ASSERT_TRUE(d == fresh_d);
    if (stats.list_builds > 0) built.push_back(k);
    x += d;
  }
  ASSERT_GE(built.size(), 3u);  // here at steps 0, 8, 23 and 38
  EXPECT_GE(built[2] - built[1], 2 * (built[1] - built[0]) - 1);
}

/// The lowest node of stacked_boxes(gap)'s upper box lattice near its
/// bottom face's centre (outside the box, no element below it); −1 if none.
Index sinking_node(const Body& body, double gap) {
  Index sinking = -1;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::RowVector3d p = body.positions.row(n);
    if (p.z() > 0.05 + 0.5 * gap && std::abs(p.x()) < 0.03 && std::abs(p.y()) < 0.03 &&
        (sinking < 0 || p.z() < body.positions(sinking, 2)))
      sinking = n;
  }
  return sinking;
}

TEST(SelfCollisions, AListOutrunByAFewVerticesIsExtendedAndListsWhatAFreshOneWould) {
  // The lowest node of the upper box's lattice near its bottom face's
  // centre (outside the box, no element below it) sinks 6 mm a step: the
  // face bulges down onto the lower box (0.1 m below, reached after about
  // 66 steps) while the rest stands. The bulge's vertices outrun their
  // margins every few steps and the list is extended for them; the pairs
  // it adds must be those a fresh build would list, so a stage that keeps
  // its list gives the same displacements, bit for bit, as one built anew
  // at every step (what is reported does not depend on the list), and
  // catches the bulge on the lower box. (The other rebuilds here are the
  // bulge's cluster parting from its neighbours.) Fails if an extension
  // lists a pair twice (its impulse is then given twice: the bits part),
  // leaves out a pair it should add (at 6 mm a step the bulge meets the
  // lower box through pairs an extension listed: the kept stage then
  // misses impacts the fresh one finds, at step 66), lists a pair a fresh
  // build would not report, lets the bulge cross, differs on one thread,
  // or never happens.
  const double step = 0.006;
  const Body body = stacked_boxes(0.1, 0.1, 8);
  const Index sinking = sinking_node(body, 0.1);
  ASSERT_GE(sinking, 0);
  Points x = body.positions;
  SelfCollisions kept, kept_on_one_thread;  // the extension's sweep is parallel: the same bits on one
  SelfCollisionStats total;
  for (int k = 0; k < 76; ++k) {
    SCOPED_TRACE(k);
    Points d = Points::Zero(body.num_nodes(), 3);
    d(sinking, 2) = -step;
    Points fresh_d = d, one_thread_d = d;
    const SelfCollisionStats stats = kept.resolve(body, x, d, {}, {1e-4, 0.0, 8});
    total += stats;
    SelfCollisions fresh;
    fresh.resolve(body, x, fresh_d, {}, {1e-4, 0.0, 8});
    ASSERT_TRUE(d == fresh_d);
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      kept_on_one_thread.resolve(body, x, one_thread_d, {}, {1e-4, 0.0, 8});
    }
    ASSERT_TRUE(d == one_thread_d);
    EXPECT_EQ(stats.waited, 0);
    for (const double t : {0.5, 1.0}) ASSERT_EQ(crossings_at(body, x, d, t), 0u) << "t = " << t;
    x += d;
  }
  EXPECT_GT(total.list_extensions, 0);
  EXPECT_GT(total.impacts + total.zone_nodes, 0);  // the bulge reached the lower box and was stopped
}

/// Two lumpy spheres of radius 0.1 m, 0.35 m apart in one body, each spun
/// about its centre by 40° (about a random axis) and thrown 0.13 m at the
/// other in one step: they end 0.09 m apart, deep in each other. Rigid
/// motions of each: no element inverts.
struct Throw {
  Body body;
  Points x0, d;
};
Throw spun_spheres(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lump(-0.004, 0.004);
  TriangleMesh a = make_sphere(0.1, 24);
  for (Index v = 0; v < a.num_vertices(); ++v) a.vertices.row(v) *= 1.0 + lump(rng) / 0.1;
  TriangleMesh both = test::joined(a, a);
  both.vertices.bottomRows(a.num_vertices()).col(0).array() += 0.35;
  Throw c{mesh_body(both, gel(), 0.04).body, {}, {}};
  c.x0 = c.body.positions;
  c.d = Points::Zero(c.body.num_nodes(), 3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    const Eigen::Matrix3d R = Eigen::AngleAxisd(40.0 * 3.14159265358979 / 180.0, axis).toRotationMatrix();
    const Eigen::Vector3d centre(side == 0 ? 0.0 : 0.35, 0.0, 0.0), push(side == 0 ? 0.13 : -0.13, 0.0, 0.0);
    for (Index n = 0; n < c.body.num_nodes(); ++n) {
      if ((c.x0(n, 0) > 0.175) != (side == 1)) continue;
      const Eigen::Vector3d r = c.x0.row(n).transpose() - centre;
      c.d.row(n) = (R * r - r + push).transpose();
    }
  }
  return c;
}

TEST(SelfCollisions, SpunSpheresThrownTogetherNeverCross) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    Throw c = spun_spheres(seed);
    const Points before = c.d;
    ASSERT_EQ(crossings_at(c.body, c.x0, c.d, 0.0), 0u);
    ASSERT_GT(crossings_at(c.body, c.x0, c.d, 1.0), 0u);  // without the stage they pass into each other
    SelfCollisions stage;
    const SelfCollisionStats stats = stage.resolve(c.body, c.x0, c.d, {}, {1e-4, 0.3, 8});
    EXPECT_GT(stats.impacts, 0);
    for (const double t : {0.25, 0.5, 0.75, 1.0})
      EXPECT_EQ(crossings_at(c.body, c.x0, c.d, t), 0u) << "seed " << seed << ", t = " << t;
    EXPECT_LT(momentum_change(c.body, before, c.d).norm(), 1e-12 * momentum_scale(c.body, before));
  }
}

TEST(SelfCollisions, RigidZonesAloneKeepTheSurfaceApart) {
  // No impulse rounds at all: the fail-safe does everything.
  for (unsigned seed = 1; seed <= 2; ++seed) {
    Throw c = spun_spheres(seed);
    const Points before = c.d;
    SelfCollisions stage;
    const SelfCollisionStats stats = stage.resolve(c.body, c.x0, c.d, {}, {1e-4, 0.0, 0});
    EXPECT_GT(stats.zone_nodes, 0);
    for (const double t : {0.25, 0.5, 0.75, 1.0}) EXPECT_EQ(crossings_at(c.body, c.x0, c.d, t), 0u);
    // A rigid zone keeps the linear momentum of its displacements.
    EXPECT_LT(momentum_change(c.body, before, c.d).norm(), 1e-12 * momentum_scale(c.body, before));
  }
}

/// Two triangles (corners 0–2 and 3–5) embedded in one element: the corner
/// tetrahedron of 0.1 m, with its apex node light (at the mass floor).
Body sheets_in_one_element(const Points& corners) {
  Body body = make_body(test::corner_tetrahedron(0.1), gel());
  body.masses[3] *= 0.05;
  body.embedding.parent.assign(6, 0);
  body.embedding.bary.resize(6, 4);
  for (Index v = 0; v < 6; ++v) {
    const Eigen::RowVector3d p = corners.row(v);
    body.embedding.bary.row(v) << 1.0 - p.sum() / 0.1, p(0) / 0.1, p(1) / 0.1, p(2) / 0.1;
  }
  body.surface_triangles.resize(2, 3);
  body.surface_triangles << 0, 1, 2, 3, 4, 5;
  return body;
}

TEST(SelfCollisions, SheetsInOneElementMoveWithItAndAreLeftAlone) {
  // Two parallel triangles 5e-5 m apart, closer than the thickness, in one
  // element squashed to half its height over the step. Both move by the
  // element's one affine map x ↦ A(t) x + b(t), invertible at every time of
  // the step (det D(t) > 0), which passes nothing through anything: the
  // pairs are not measured and no node is pushed. (Impulses between points
  // of one element would stretch it instead: both sides hang on its nodes.)
  const double thickness = 1e-4, gap = 5e-5, z = 0.01;
  Points corners(6, 3);
  corners << 0.01, 0.01, z, 0.05, 0.01, z, 0.01, 0.05, z,  //
      0.01, 0.01, z + gap, 0.01, 0.05, z + gap, 0.05, 0.01, z + gap;
  const Body body = sheets_in_one_element(corners);
  const Points x0 = body.positions;
  Points d = Points::Zero(body.num_nodes(), 3);
  d(3, 2) = -0.05;
  const Points before = d;
  SelfCollisions stage;
  const SelfCollisionStats stats = stage.resolve(body, x0, d, {}, {thickness, 0.0, 8});
  EXPECT_EQ(stats.candidates, 0);
  EXPECT_EQ(stats.repulsions + stats.impacts + stats.zone_rounds, 0);
  EXPECT_TRUE(d == before);
  for (const double t : {0.0, 0.5, 1.0}) EXPECT_EQ(crossings_at(body, x0, d, t), 0u);
}

/// Two parallel triangles `gap` apart in planes x = const, in one element
/// whose nodes 1 and 2 move by −0.22 m along x and y: x and y scale by
/// 1 − 2.2t, so det D(t) = 0.1 (0.1 − 0.22t)² vanishes at t = 1/2.2 though
/// it is positive at both ends. There the element is flat, both triangles
/// lie on the z axis and meet, and after it their order along x is
/// reversed: the step passes one through the other.
struct FlattenedSheets {
  Body body;
  Points x0, d;
  static constexpr double flat = 1.0 / 2.2;
  explicit FlattenedSheets(double gap) {
    const double x = 0.01;
    Points corners(6, 3);
    corners << x, 0.01, 0.01, x, 0.05, 0.01, x, 0.01, 0.05,  //
        x + gap, 0.01, 0.01, x + gap, 0.01, 0.05, x + gap, 0.05, 0.01;
    body = sheets_in_one_element(corners);
    x0 = body.positions;
    d = Points::Zero(body.num_nodes(), 3);
    d(1, 0) = -0.22;
    d(2, 1) = -0.22;
  }
  /// The least distance between the two triangles at time t (their 6
  /// vertex–triangle and 9 edge–edge pairs) for displacements dd.
  [[nodiscard]] double gap_at(const Points& dd, double t) const {
    const Points xs = body.embedding.surface_positions(body.tets, x0 + t * dd);
    auto p = [&](Index v) { return Eigen::Vector3d(xs.row(v).transpose()); };
    double least = std::numeric_limits<double>::infinity();
    for (int side = 0; side < 2; ++side)
      for (int k = 0; k < 3; ++k) {
        const Index v = 3 * side + k, o = 3 * (1 - side);
        least = std::min(least, ccd::closest(ccd::PairKind::vertex_triangle, {p(v), p(o), p(o + 1), p(o + 2)}).distance);
      }
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        least = std::min(least, ccd::closest(ccd::PairKind::edge_edge,
                                             {p(a), p((a + 1) % 3), p(3 + b), p(3 + (b + 1) % 3)}).distance);
    return least;
  }
  /// The least gap over the step (at the flat time and 1001 times).
  [[nodiscard]] double least_gap(const Points& dd) const {
    double least = gap_at(dd, flat);
    for (int k = 0; k <= 1000; ++k) least = std::min(least, gap_at(dd, k / 1000.0));
    return least;
  }
};

/// The sheets meet as given; the stage keeps every pair at least the
/// thickness apart all step (none left reported, ccd.h) and the momentum.
SelfCollisionStats resolve_flattened(FlattenedSheets& c, double thickness) {
  EXPECT_LT(c.gap_at(c.d, FlattenedSheets::flat), 1e-12);
  const Points given = c.d;
  SelfCollisions stage;
  const SelfCollisionStats stats = stage.resolve(c.body, c.x0, c.d, {}, {thickness, 0.0, 8});
  EXPECT_GE(c.least_gap(c.d), thickness);
  EXPECT_LT(momentum_change(c.body, given, c.d).norm(), 1e-12 * momentum_scale(c.body, given));
  return stats;
}

TEST(SelfCollisions, SheetsInAnElementFlattenedMidStepAreKeptApart) {
  // 1 mm apart: such an element's own pairs are measured, and the step is
  // made safe. The impulses, all on the element's four nodes, are cut
  // (kMaxNodeMove) but together give each pair a good share of what it
  // lacks each round: the rounds resolve them without the fail-safe.
  FlattenedSheets c(1e-3);
  const SelfCollisionStats stats = resolve_flattened(c, 1e-4);
  EXPECT_GT(stats.candidates, 0);
  EXPECT_GT(stats.impacts, 0);
  EXPECT_EQ(stats.zone_rounds, 0);
}

TEST(SelfCollisions, RoundsThatCannotResolveTheirPairsHandThemToTheFailSafeAtOnce) {
  // The same sheets 0.1 mm apart (thickness 10 µm): their points' weights
  // on the nodes differ ten times less, so the cut impulses give each pair
  // a few percent of what it lacks a round, and eight rounds would leave
  // most of it. The rounds stop as soon as every pair left is such a pair,
  // and the rigid zones keep the sheets apart.
  FlattenedSheets c(1e-4);
  const SelfCollisionStats stats = resolve_flattened(c, 1e-5);
  EXPECT_GT(stats.impacts, 0);
  EXPECT_LE(stats.rounds, 2);
  EXPECT_GT(stats.zone_rounds, 0);
}

TEST(StarSpread, NoneForAnAffineMotionAndTheClosedFormOtherwise) {
  // One gradient throughout: g = 0, the star moves affinely.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Eigen::Matrix3d F = R * Eigen::Vector3d(1.2, 0.9, 0.8).asDiagonal();
  EXPECT_LE(star_spread(std::vector<Eigen::Matrix3d>(24, F), std::vector<Eigen::Matrix3d>(24, 1.1 * F)), 1e-14);
  // Two tets, I and diag(2, 1, 1): Ā = diag(1.5, 1, 1), ‖F − Ā‖ = 0.5, σ_min(Ā) = 1.
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d S = Eigen::Vector3d(2.0, 1.0, 1.0).asDiagonal();
  EXPECT_NEAR(star_spread({I, S}, {I, S}), 0.5, 1e-15);
  // Ā(t) = (1 − 2t) I passes through 0 at t = 1/2: no bound.
  EXPECT_TRUE(std::isinf(star_spread({I}, {-I})));
  // The star grown by 1.2 over the step: L = 0.6 at the end; σ_min 1 → 1.2
  // with Δ = 0.2 ‖diag(1.5, 1, 1)‖ = 0.2 √4.25, so s = (2.2 − 0.2 √4.25) / 2.
  const double s = 0.5 * (2.2 - 0.2 * std::sqrt(4.25));
  EXPECT_NEAR(star_spread({I, S}, {1.2 * I, 1.2 * S}), 0.6 / s, 1e-12);
}

TEST(CalmStars, ASpreadFromSingularValueBoundsAnswersEveryTestAsTheSvdsDoes) {
  // Stars of 14 gradients R U (I + noise) over a step, from calm to
  // stirred, stretched up to 2:1 and turned: the κ that skips the SVD
  // (Gershgorin bounds of σ_min) is at least the SVD's, and answers the
  // tests the self-collision list puts it to (κ × 4 < ¾ to group a star,
  // κ × ratio < 1 − 10⁻⁹ to leave its pairs off) as the SVD's does. It
  // must also skip the SVD for calm stars, or it saves nothing.
  std::mt19937 rng(37);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int skipped = 0, tests = 0;
  for (int star = 0; star < 2000; ++star) {
    const double noise = 0.2 * std::pow(10.0, -3.0 * (star % 10) / 9.0);  // 0.2 down to 2e-4
    const double stretch = 1.0 + (star % 7) / 6.0;                        // 1 to 2
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    const Eigen::Matrix3d U = Eigen::Vector3d(stretch, 1.0, 1.0 / std::sqrt(stretch)).asDiagonal();
    const Eigen::Matrix3d Q =
        Eigen::AngleAxisd(3.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    std::vector<Eigen::Matrix3d> F0, F1;
    for (int k = 0; k < 14; ++k) {
      Eigen::Matrix3d E0, E1;
      for (int i = 0; i < 9; ++i) {
        E0.data()[i] = noise * u(rng);
        E1.data()[i] = noise * u(rng);
      }
      F0.push_back(R * Q * U * Q.transpose() * (Eigen::Matrix3d::Identity() + E0));
      F1.push_back(1.01 * F0.back() * (Eigen::Matrix3d::Identity() + E1));
    }
    const double exact = star_spread(F0, F1);
    for (const auto& [multiplier, threshold] :
         {std::pair{CalmStars::kRatio, 0.75}, std::pair{CalmStars::kRatio, 1.0 - 1e-9}, std::pair{9.0, 1.0 - 1e-9}}) {
      const double tested = star_spread(F0, F1, multiplier, threshold);
      ++tests;
      if (tested != exact) ++skipped;
      EXPECT_GE(tested, exact);
      EXPECT_EQ(tested * multiplier < threshold, exact * multiplier < threshold)
          << "star " << star << ": κ " << exact << " and " << tested;
    }
  }
  EXPECT_GT(skipped, tests / 4);
}

/// A ball of 0.1 m radius and 4,512 triangles on a 0.04 m lattice (the
/// nodes inside it have whole stars) and the displacements of a step that
/// shrinks it by `by` (2 %) about its centre.
struct ShrunkBall {
  Body body;
  Points x0, d;
};
ShrunkBall shrunk_ball(double by = 0.02) {
  ShrunkBall b{mesh_body(make_sphere(0.1, 48), gel(), 0.04).body, {}, {}};
  b.x0 = b.body.positions;
  const Eigen::RowVector3d centre = b.x0.colwise().mean();
  b.d = -by * (b.x0.rowwise() - centre);
  return b;
}

TEST(SelfCollisions, PairsInACalmStarStayOffTheListUntilItStopsBeingCalm) {
  // Moved affinely (shrunk by 10 %), every star is calm (κ = 0): its
  // group's pairs are off the list. The next step keeps the list (every
  // vertex within its margin of its cluster's motion: four times the
  // shrink's 1 mm or so across a cluster) but moves every node by up to
  // 3 mm more, so the gradients across a star differ by up to ~15 % and κρ
  // passes 1: those groups' pairs are listed (fewer without).
  ShrunkBall b = shrunk_ball(0.1);
  SelfCollisions stage;
  Points d = b.d;
  const SelfCollisionStats calm = stage.resolve(b.body, b.x0, d, {}, {1e-4, 0.0, 8});
  EXPECT_EQ(calm.list_builds, 1);
  EXPECT_TRUE(d == b.d);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Points stirred = b.d;
  for (Index n = 0; n < b.body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) stirred(n, k) += 0.003 * unit(random);
  d = stirred;
  const SelfCollisionStats stirred_stats = stage.resolve(b.body, b.x0, d, {}, {1e-4, 0.0, 8});
  EXPECT_EQ(stirred_stats.list_builds, 0);  // the same list, with the stirred stars' pairs added
  EXPECT_GT(stirred_stats.listed, calm.listed);
  // A fresh stage builds its list with the stirred stars left out of groups.
  SelfCollisions fresh;
  d = stirred;
  const SelfCollisionStats built = fresh.resolve(b.body, b.x0, d, {}, {1e-4, 0.0, 8});
  EXPECT_GT(built.listed, calm.listed);
  for (const double t : {0.0, 0.5, 1.0}) EXPECT_EQ(crossings_at(b.body, b.x0, d, t), 0u);
}

TEST(SelfCollisions, CalmGroupsListTheSamePairsOnOneAndTwoThreads) {
  // The calm ball's step and then its stirred one, on one and on two
  // threads: the groups (assigned, measured and listed in parallel loops)
  // and so the pairs walked, and the displacements, are the same.
  struct Run {
    SelfCollisionStats calm, stirred;
    Points d;
  };
  auto run = [](int threads) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    ShrunkBall b = shrunk_ball();
    SelfCollisions stage;
    Run r;
    Points d = b.d;
    r.calm = stage.resolve(b.body, b.x0, d, {}, {1e-4, 0.0, 8});
    std::mt19937 random(5);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (Index n = 0; n < b.body.num_nodes(); ++n)
      for (int k = 0; k < 3; ++k) b.d(n, k) += 0.003 * unit(random);
    r.d = b.d;
    r.stirred = stage.resolve(b.body, b.x0, r.d, {}, {1e-4, 0.0, 8});
    return r;
  };
  const Run one = run(1), two = run(2);
  EXPECT_EQ(one.calm.listed, two.calm.listed);
  EXPECT_EQ(one.stirred.listed, two.stirred.listed);
  EXPECT_GT(one.stirred.listed, one.calm.listed);  // the groups did form, and some dissolved
  EXPECT_EQ(one.stirred.candidates, two.stirred.candidates);
  EXPECT_TRUE(one.d == two.d);
}

/// The largest κ (star_spread) over the stars of all nodes, every star
/// taken whole, for the step x0 → x1: a bound of the calm stars' own.
double largest_spread(const Body& body, const Points& x0, const Points& x1) {
  double most = 0.0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    std::vector<Eigen::Matrix3d> F0, F1;
    for (Index c = body.incidence.offsets[at(n)]; c < body.incidence.offsets[at(n) + 1]; ++c) {
      const Index e = body.incidence.corners[at(c)] / 4;
      F0.push_back(deformation_gradient(body, x0, e));
      F1.push_back(deformation_gradient(body, x1, e));
    }
    most = std::max(most, star_spread(F0, F1));
  }
  return most;
}

TEST(SelfCollisions, ACalmGroupListsOnlyItsNearPairsThatItsSpreadReaches) {
  // Two boxes 4 mm apart in one body on a 0.04 m lattice: the facing
  // sheets share stars, and their triangle pairs are near pairs (rest
  // distance d ≥ 4 mm, largest vertex distance D ≈ 3 cm: ratio up to ~9).
  // A calm step groups them; the next keeps the list and stirs the nodes
  // by up to a, every star's κ staying below 1/4 (so no group lists all its
  // pairs): the pairs listed are the near pairs with κρ ≥ 1, more of them
  // the more the star is stirred. A fresh build, whose groups need 4κ < ¾,
  // lists the stirred stars' pairs whole: more again. Fails if the near
  // pairs are not listed (the list stays the calm one).
  std::vector<std::int64_t> listed;
  for (const double a : {0.0, 0.0008, 0.0016}) {
    SCOPED_TRACE(a);
    const MeshedBody meshed = stacked_boxes_meshed(0.004);
    const Body& body = meshed.body;
    const Points x0 = body.positions;
    const Points d0 = -0.02 * (x0.rowwise() - x0.colwise().mean());
    SelfCollisions stage;
    Points d = d0;
    const SelfCollisionStats calm = stage.resolve(body, x0, d, {}, {1e-4, 0.0, 8});
    std::mt19937 random(5);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    Points stirred = d0;
    // Drawn node by node in lattice key order (corners, then centres): each
    // lattice node gets the same stir whatever the mesh's node numbering.
    std::vector<Index> by_key(at(body.num_nodes()));
    std::iota(by_key.begin(), by_key.end(), Index{0});
    std::sort(by_key.begin(), by_key.end(), [&](Index p, Index q) {
      return meshed.lattice_mesh.node_keys[at(p)] < meshed.lattice_mesh.node_keys[at(q)];
    });
    for (const Index n : by_key)
      for (int k = 0; k < 3; ++k) stirred(n, k) += a * unit(random);
    ASSERT_LT(4.0 * largest_spread(body, x0, x0 + stirred), 1.0);
    d = stirred;
    const SelfCollisionStats s = stage.resolve(body, x0, d, {}, {1e-4, 0.0, 8});
    EXPECT_EQ(s.list_builds, 0);
    if (a == 0.0) {
      EXPECT_EQ(s.listed, calm.listed);
    }
    listed.push_back(s.listed);
    for (const double t : {0.0, 0.5, 1.0}) EXPECT_EQ(crossings_at(body, x0, d, t), 0u);
    if (a == 0.0016) {
      SelfCollisions fresh;
      d = stirred;
      EXPECT_GT(fresh.resolve(body, x0, d, {}, {1e-4, 0.0, 8}).listed, s.listed);
    }
  }
  EXPECT_LT(listed[0], listed[1]);
  EXPECT_LT(listed[1], listed[2]);
}

/// D / d of a triangle pair as the calm stars define it, measured for
/// every primitive pair (no bound): the largest over the pairs that share
/// no vertex and do not lie in one element; 0 if there are none.
double exact_pair_ratio(const Body& body, const Points& rest, Index a, Index b) {
  const Triangles& tris = body.surface_triangles;
  const auto& parent = body.embedding.parent;
  double ratio = 0.0;
  auto consider = [&](ccd::PairKind kind, const std::array<Index, 4>& v, std::size_t first) {
    const Index e = parent[at(v[0])];
    if (parent[at(v[1])] == e && parent[at(v[2])] == e && parent[at(v[3])] == e) return;
    for (std::size_t i = 0; i < 4; ++i)
      for (std::size_t j = i + 1; j < 4; ++j)
        if (v[i] == v[j]) return;
    ccd::Points4 x;
    for (std::size_t k = 0; k < 4; ++k) x[k] = rest.row(v[k]).transpose();
    double D = 0.0;
    for (std::size_t i = 0; i < first; ++i)
      for (std::size_t j = first; j < 4; ++j) D = std::max(D, (x[i] - x[j]).norm());
    const double d = ccd::closest(kind, x).distance;
    ratio = std::max(ratio, d > 0.0 ? D / d : std::numeric_limits<double>::infinity());
  };
  for (const auto& [p, q] : {std::pair{a, b}, std::pair{b, a}})
    for (int k = 0; k < 3; ++k) consider(ccd::PairKind::vertex_triangle, {tris(p, k), tris(q, 0), tris(q, 1), tris(q, 2)}, 1);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      consider(ccd::PairKind::edge_edge, {tris(a, i), tris(a, (i + 1) % 3), tris(b, j), tris(b, (j + 1) % 3)}, 2);
  return ratio;
}

/// Per surface triangle, the element holding all three corners (−1: none),
/// as the self-collision stage gives CalmStars::update_surface.
std::vector<Index> elements_of_triangles(const Body& body) {
  const auto nt = static_cast<Index>(body.surface_triangles.rows());
  std::vector<Index> element_of(at(nt));
  for (Index t = 0; t < nt; ++t) {
    const Index e = body.embedding.parent[at(body.surface_triangles(t, 0))];
    element_of[at(t)] = body.embedding.parent[at(body.surface_triangles(t, 1))] == e &&
                                body.embedding.parent[at(body.surface_triangles(t, 2))] == e
                            ? e
                            : -1;
  }
  return element_of;
}

TEST(CalmStars, StarsFoundFromTheMovedElementsListWhatThePassOverAllStarsLists) {
  // Two boxes 4 mm apart (facing sheets with near pairs in shared stars),
  // grouped on a calm step; then rounds that stir a few nodes each, more
  // every round, as impulses do. newly_unsafe given the moved elements
  // looks only at their stars: each round must return the pairs, in the
  // order, that the pass over every grouped star returns (and leave the
  // same state for the next round). Fails if a moved element's star is
  // missed, a full group is taken again, or its pairs are not taken.
  const Body body = stacked_boxes(0.004);
  const Index nt = static_cast<Index>(body.surface_triangles.rows()), nn = body.num_nodes();
  const std::vector<Index> element_of = elements_of_triangles(body);
  const Points x0 = body.positions;
  Points d = -0.02 * (x0.rowwise() - x0.colwise().mean());
  CalmStars all;
  all.update_mesh(body);
  all.update_surface(body, element_of);
  all.assign_groups(body, x0, d);
  CalmStars moved_only = all;
  const Points xs = body.embedding.surface_positions(body.tets, x0);
  std::vector<Box3> boxes(at(nt));
  for (Index t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k) boxes[at(t)].extend(Eigen::Vector3d(xs.row(body.surface_triangles(t, k)).transpose()));
  std::mt19937 random(11);
  std::uniform_int_distribution<Index> node(0, nn - 1);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::size_t returned = 0;
  for (int round = 0; round < 200; ++round) {
    SCOPED_TRACE(round);
    std::vector<std::uint8_t> moved(at(nn), 0);
    for (int k = 0; k < 3; ++k) {
      const Index n = node(random);
      moved[at(n)] = 1;
      for (int i = 0; i < 3; ++i) d(n, i) += 0.0002 * (1 + round / 20) * unit(random);
    }
    std::vector<Index> elements;
    for (Index e = 0; e < body.num_elements(); ++e)
      if (moved[at(body.tets(e, 0))] || moved[at(body.tets(e, 1))] || moved[at(body.tets(e, 2))] ||
          moved[at(body.tets(e, 3))])
        elements.push_back(e);
    std::reverse(elements.begin(), elements.end());  // any order
    const auto expected = all.newly_unsafe(body, x0, d, &moved, boxes);
    ASSERT_EQ(moved_only.newly_unsafe(body, x0, d, &moved, boxes, &elements), expected);
    returned += expected.size();
  }
  EXPECT_GT(returned, 0u);
}

TEST(CalmStars, TheNearPairsAreExactlyThoseWithAPrimitivePairAboveTheRatio) {
  // Every pair of triangles that can join one group (a candidate star in
  // common, not both within one element), measured in full: the near
  // pairs are those whose ratio exceeds kRatio, with that ratio to the bit.
  // update_surface measures only the pairs its grown boxes find, and of
  // those only the primitive pairs a bound cannot clear: this fails if the
  // boxes miss a near pair or the bound clears one.
  std::size_t ties = 0;  // equal ratios, in either case
  for (const double gap : {0.004, 0.02}) {
    SCOPED_TRACE(gap);
    Body body = stacked_boxes(gap, 0.1, 12);
    const Index nt = static_cast<Index>(body.surface_triangles.rows());
    const std::vector<Index> element_of = elements_of_triangles(body);
    CalmStars stars;
    stars.update_mesh(body);
    stars.update_surface(body, element_of);
    std::map<std::array<Index, 2>, double> found;
    for (std::size_t i = 0; i < stars.near_pairs().size(); ++i) found[stars.near_pairs()[i]] = stars.near_ratios()[i];
    const Points rest = body.embedding.surface_positions(body.tets, body.rest_positions);
    std::map<Index, std::vector<Index>> by_star;
    for (Index t = 0; t < nt; ++t)
      for (const Index n : stars.candidate_stars()[at(t)])
        if (n >= 0) by_star[n].push_back(t);
    std::set<std::array<Index, 2>> pairs;
    for (const auto& [n, members] : by_star)
      for (std::size_t i = 0; i < members.size(); ++i)
        for (std::size_t j = i + 1; j < members.size(); ++j) {
          const Index a = members[i], b = members[j];
          if (element_of[at(a)] >= 0 && element_of[at(a)] == element_of[at(b)]) continue;
          pairs.insert({std::min(a, b), std::max(a, b)});
        }
    std::size_t near = 0, missed = 0, wrong = 0;
    for (const auto& pair : pairs) {
      const double ratio = exact_pair_ratio(body, rest, pair[0], pair[1]);
      const auto it = found.find(pair);
      if (!(ratio <= CalmStars::kRatio)) {
        ++near;
        if (it == found.end()) {
          ++missed;
        } else if (!(it->second == ratio || (std::isinf(ratio) && std::isinf(it->second)))) {
          ++wrong;
        }
      } else if (it != found.end()) {
        ++wrong;
      }
    }
    EXPECT_GT(pairs.size(), 10000u);
    EXPECT_EQ(missed, 0u);
    EXPECT_EQ(wrong, 0u);
    // Ordered by ratio, largest first, then by index: a permutation of the
    // near pairs in which no ratio is above the one before it.
    const std::vector<Index>& order = stars.near_order();
    ASSERT_EQ(order.size(), stars.near_pairs().size());
    std::vector<Index> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], static_cast<Index>(i));
    for (std::size_t i = 1; i < order.size(); ++i) {
      const double before = stars.near_ratios()[at(order[i - 1])], now = stars.near_ratios()[at(order[i])];
      EXPECT_FALSE(now > before) << "place " << i;
      if (now == before) {
        ++ties;
        EXPECT_LT(order[i - 1], order[i]) << "place " << i;
      }
    }
    EXPECT_EQ(found.size(), near);
    if (gap == 0.004) {
      EXPECT_GT(near, 100u);  // the facing sheets' pairs
    }
  }
  EXPECT_GT(ties, 0u);
}

TEST(SelfCollisions, ABodyWithAnInvertedElementIsLeftToTurnBack) {
  // The same throw with the elements of one sphere turned inside out at
  // the step's end (its nodes mirrored through its centre plane): an
  // inverted element turns back only by passing through itself.
  Throw c = spun_spheres(1);
  for (Index n = 0; n < c.body.num_nodes(); ++n)
    if (c.x0(n, 0) > 0.175) c.d(n, 0) = 2.0 * (0.35 - c.x0(n, 0)) - 0.13;
  const Points before = c.d;
  SelfCollisions stage;
  const SelfCollisionStats stats = stage.resolve(c.body, c.x0, c.d, {}, {1e-4, 0.0, 8});
  EXPECT_EQ(stats.waited, 1);
  EXPECT_EQ(stats.impacts + stats.repulsions + stats.zone_nodes, 0);
  EXPECT_TRUE(c.d == before);
}

TEST(SelfCollisions, AShortStepSetsNoFasterVelocitiesThanAFullOne) {
  // Two boxes 0.1 m apart at rest with a thickness of 0.2 m: the repulsion
  // pushes them apart by a tenth of the missing 0.1 m over a full step.
  // Velocity = displacement / Δt, so a step 1000× shorter would set them
  // apart 1000× faster (a run's steps shrink under fast motion, and the
  // response would then feed the motion that shrinks them). With the
  // reference step, the targets scale by Δt / reference: the velocities
  // set are those of a full step, whatever the step.
  const double reference = 1e-3;
  auto fastest = [&](double dt, double reference_step) {
    Body body = stacked_boxes(0.1);
    body.velocities.setZero();
    const Points x0 = body.positions;
    SelfCollisionParameters parameters{0.2, 0.0, 8};
    parameters.reference_step = reference_step;
    SelfCollisions stage;
    const SelfCollisionStats stats = stage.resolve_step(body, x0, dt, {}, parameters);
    EXPECT_GT(stats.repulsions, 0);
    return body.velocities.rowwise().norm().maxCoeff();
  };
  const double full = fastest(reference, reference);
  EXPECT_GT(full, 0.0);
  for (const double dt : {1e-4, 1e-6, 1e-9}) EXPECT_NEAR(fastest(dt, reference), full, 1e-6 * full) << "Δt = " << dt;
  EXPECT_NEAR(fastest(1e-6, 0.0), 1000.0 * full, 1e-6 * full * 1000.0);  // unscaled: 1000× faster
}

/// Both stages' stats, field by field.
void expect_same_stats(const SelfCollisionStats& a, const SelfCollisionStats& b) {
  EXPECT_EQ(a.candidates, b.candidates);
  EXPECT_EQ(a.repulsions, b.repulsions);
  EXPECT_EQ(a.impacts, b.impacts);
  EXPECT_EQ(a.rounds, b.rounds);
  EXPECT_EQ(a.zone_rounds, b.zone_rounds);
  EXPECT_EQ(a.zone_nodes, b.zone_nodes);
  EXPECT_EQ(a.list_builds, b.list_builds);
  EXPECT_EQ(a.list_extensions, b.list_extensions);
  EXPECT_EQ(a.listed, b.listed);
}

/// Two stages, one looking again at only what a round's impulses moved
/// (whatever their number), the other at everything, resolving the same
/// steps one after another.
struct Rechecks {
  SelfCollisions what_moved, everything;
  SelfCollisionStats total;
  Rechecks() {
    what_moved.set_recheck(SelfCollisions::Recheck::what_moved);
    everything.set_recheck(SelfCollisions::Recheck::everything);
  }
  /// Resolves d (from x0) with both: the same displacements and counts.
  void step(const Body& body, const Points& x0, Points& d, const SelfCollisionParameters& parameters) {
    Points other = d;
    const SelfCollisionStats stats = what_moved.resolve(body, x0, d, {}, parameters);
    expect_same_stats(stats, everything.resolve(body, x0, other, {}, parameters));
    ASSERT_TRUE(d == other);
    total += stats;
  }
};

TEST(SelfCollisions, ChecksAfterImpulsesLookOnlyAtWhatMovedWithTheSameResults) {
  // After a round's impulses only what they moved is looked at again: the
  // list's clusters holding a moved vertex (their mean motions, their pairs
  // with every other cluster, their vertices' drifts), and the surface
  // vertices, elements and calm stars of the moved nodes (found through the
  // incidence and an index of each element's vertices). The displacements
  // and every count must be those of a stage that looks at everything.
  // Fails if the changed clusters' means, pairs or drifts are not measured
  // again (a list kept past its margins: pairs missed, other impulses), if
  // an impact's vertices are not flagged, or if a moved node's elements'
  // orientations or stars are not measured again.
  {
    SCOPED_TRACE("a bulge meeting a box: one list over many steps, extended and rebuilt");
    const double step = 0.006;
    const Body body = stacked_boxes(0.1, 0.1, 8);
    const Index sinking = sinking_node(body, 0.1);
    ASSERT_GE(sinking, 0);
    Points x = body.positions;
    Rechecks both;
    for (int k = 0; k < 76; ++k) {
      SCOPED_TRACE(k);
      Points d = Points::Zero(body.num_nodes(), 3);
      d(sinking, 2) = -step;
      both.step(body, x, d, {1e-4, 0.0, 8});
      x += d;
    }
    EXPECT_GT(both.total.rounds, 0);
    EXPECT_GT(both.total.list_extensions, 0);
  }
  for (const auto& [gap, thickness] : {std::pair{1e-3, 1e-4}, std::pair{1e-4, 1e-5}}) {
    SCOPED_TRACE(fmt::format("sheets in an element flattened mid-step, {} m apart", gap));
    FlattenedSheets c(gap);
    Rechecks both;
    both.step(c.body, c.x0, c.d, {thickness, 0.0, 8});
    EXPECT_GT(both.total.impacts, 0);
  }
  {
    SCOPED_TRACE("a calm ball, then stirred: stars stop being calm");
    ShrunkBall b = shrunk_ball(0.1);
    Rechecks both;
    Points d = b.d;
    both.step(b.body, b.x0, d, {1e-4, 0.0, 8});
    std::mt19937 random(5);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (int k = 0; k < 3; ++k) {
      Points x = b.x0 + d;
      d = b.d;
      for (Index n = 0; n < b.body.num_nodes(); ++n)
        for (int i = 0; i < 3; ++i) d(n, i) += 0.003 * unit(random);
      both.step(b.body, x, d, {2e-3, 0.0, 8});
    }
  }
}

TEST(SelfCollisions, SpunSpheresRecheckOnlyWhatMovedWithTheSameResults) {
  // As the test above, on the spun spheres thrown into each other (many
  // rounds with friction, rigid zones): about bits, and minutes under the
  // sanitizers (scripts/test leaves it to the release build; the test above
  // runs the same code there).
  for (unsigned seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(fmt::format("seed {}", seed));
    Throw c = spun_spheres(seed);
    Rechecks both;
    both.step(c.body, c.x0, c.d, {1e-4, 0.3, 8});
    EXPECT_GT(both.total.rounds, 1);
  }
}

TEST(SelfCollisions, SameBitsOnOneAndTwoThreads) {
  Points one, two;
  for (const int threads : {1, 2}) {
    tbb::global_control control(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    Throw c = spun_spheres(3);
    SelfCollisions stage;
    stage.resolve(c.body, c.x0, c.d, {}, {1e-4, 0.3, 8});
    (threads == 1 ? one : two) = c.d;
  }
  EXPECT_TRUE(one == two);
}

TEST(SelfCollisions, FrictionHoldsBackSliding) {
  // The upper box comes down onto a wider lower one while sliding sideways:
  // with friction its surface slides less over the step.
  auto slide = [](double friction) {
    const Body body = stacked_boxes(0.1, 0.3);
    const Points x0 = body.positions;
    Points d = Points::Zero(body.num_nodes(), 3);
    for (Index n = 0; n < body.num_nodes(); ++n)
      if (x0(n, 2) > 0.1) d.row(n) << 0.03, 0.0, -0.15;
    SelfCollisions stage;
    const SelfCollisionStats stats = stage.resolve(body, x0, d, {}, {1e-4, friction, 8});
    EXPECT_GT(stats.impacts, 0);
    EXPECT_EQ(crossings_at(body, x0, d, 1.0), 0u);
    const Points ds = body.embedding.surface_positions(body.tets, d);
    return ds.bottomRows(ds.rows() / 2).col(0).mean();
  };
  const double free = slide(0.0), held = slide(1.0);
  EXPECT_GT(free, 0.0);
  EXPECT_LT(held, free);
}

/// Crossing triangle pairs in each of the first `frames` frames of the
/// shipped splashing-fluid drop, with self-collisions and the upkeep's
/// flips on or off; `volumes` gets each frame's enclosed volume over frame 0's.
std::vector<std::size_t> crossings_per_frame(bool self_collisions, bool flips, int frames,
                                             std::vector<double>* volumes = nullptr) {
  Scene scene = io::read_scene(std::filesystem::path(GOO_SOURCE_DIR) / "scenes" / "drop_splashing_fluid.json");
  scene.objects[0].self_collisions.enabled = self_collisions;
  scene.remesh.upkeep_settings.flips = flips;
  Simulation sim(scene);
  const double v0 = surface_integrals(sim.surface()).volume;
  std::vector<std::size_t> out;
  for (int frame = 1; frame <= frames; ++frame) {
    sim.advance_to(frame / scene.output.fps);
    out.push_back(self_intersecting_pairs(sim.surface()).size());
    if (volumes) volumes->push_back(surface_integrals(sim.surface()).volume / v0);
  }
  return out;
}

TEST(SelfCollisions, TheSplashingFluidDropNeverCrossesItself) {
  // W&T fig. 3's fluid at the shipped scene's resolution, through the
  // impact and the splash (frames 1–12, 0.5 s): without the stage (and
  // without the upkeep's flips, which alone keep these 12 frames free of
  // crossings, measured) the surface crosses itself from frame 8 on.
  std::vector<double> volumes;
  const std::vector<std::size_t> off = crossings_per_frame(false, false, 12),
                                 on = crossings_per_frame(true, true, 12, &volumes);
  EXPECT_GT(*std::max_element(off.begin(), off.end()), 0u);
  for (std::size_t f = 0; f < on.size(); ++f) EXPECT_EQ(on[f], 0u) << "frame " << f + 1;
  // The fluid is incompressible (its preset): every frame keeps the volume
  // to 1% through the impact (ν = 0.3 alone lost 44% at frame 6).
  for (std::size_t f = 0; f < volumes.size(); ++f) EXPECT_NEAR(volumes[f], 1.0, 0.01) << "frame " << f + 1;
}

TEST(SelfCollisions, TheArmadilloOozesOntoTheGrateCleanly) {
  // scenes/armadillo_grate.json (W&T fig. 6, the 52k-triangle armadillo)
  // on a twice coarser lattice, through its landing on the bars (frame 6):
  // no crossing, its volume, a surface that neither creases nor multiplies,
  // and it rests on the bars (their tops at z = 0.212 m), not through them.
  Scene scene = io::read_scene(std::filesystem::path(GOO_SOURCE_DIR) / "scenes" / "armadillo_grate.json");
  scene.objects[0].lattice_spacing = 0.024;
  Simulation sim(scene);
  const SurfaceQuality start = measure_surface_quality(sim.surface());
  for (int frame = 1; frame <= 8; ++frame) {
    sim.make_restart_point();
    ASSERT_TRUE(sim.advance_to(frame / scene.output.fps));
    const SurfaceQuality q = measure_surface_quality(sim.surface());
    EXPECT_EQ(q.self_intersecting_pairs, 0) << "frame " << frame;
    EXPECT_NEAR(q.volume, start.volume, 0.01 * start.volume) << "frame " << frame;
    EXPECT_LE(q.creased_edges, q.edges / 50) << "frame " << frame;  // the surface issue's 2%
    EXPECT_LE(q.triangles, 3 * start.triangles) << "frame " << frame;
  }
  const Points x = sim.surface().vertices;
  const double lowest = x.col(2).minCoeff();
  EXPECT_GT(lowest, 0.1);
  EXPECT_LT(lowest, 0.212);
}

/// The bottom of a surface against an obstacle: among the triangles whose
/// corners all lie within `near` of the obstacle's surface, those whose
/// outward normal points away from the obstacle (a triangle folded over its
/// neighbour turns its back on it), and the edges between two such contact
/// triangles creased past 90°.
struct Bottom {
  Index contact = 0, flipped = 0, creased = 0;
};

Bottom bottom_against(const TriangleMesh& mesh, const Obstacle& obstacle, double t, double near) {
  Bottom out;
  const Index nt = mesh.num_triangles();
  std::vector<std::uint8_t> in_contact(static_cast<std::size_t>(nt), 0);
  std::vector<Eigen::Vector3d> normal(static_cast<std::size_t>(nt));
  for (Index f = 0; f < nt; ++f) {
    const auto [a, b, c] = mesh.corners(f);
    normal[static_cast<std::size_t>(f)] = (b - a).cross(c - a).normalized();
    bool close = true;
    for (const auto& p : {a, b, c}) close = close && obstacle.query(p, t).distance <= near;
    if (!close) continue;
    in_contact[static_cast<std::size_t>(f)] = 1;
    ++out.contact;
    const Eigen::Vector3d centre = (a + b + c) / 3.0;
    if (normal[static_cast<std::size_t>(f)].dot(obstacle.query(centre, t).normal) > 0.0) ++out.flipped;
  }
  std::map<std::pair<Index, Index>, Index> first;
  for (Index f = 0; f < nt; ++f) {
    if (!in_contact[static_cast<std::size_t>(f)]) continue;
    for (int k = 0; k < 3; ++k) {
      const Index u = mesh.triangles(f, k), v = mesh.triangles(f, (k + 1) % 3);
      const auto key = std::minmax(u, v);
      const auto [it, fresh] = first.emplace(key, f);
      if (!fresh && normal[static_cast<std::size_t>(it->second)].dot(normal[static_cast<std::size_t>(f)]) < 0.0)
        ++out.creased;
    }
  }
  return out;
}

/// The smallest volume of an element holding material over its rest
/// volume (det Fp included), at the body's positions.
double smallest_volume_ratio(const Body& body) {
  double smallest = std::numeric_limits<double>::infinity();
  for (Index e = 0; e < body.num_elements(); ++e) {
    if (body.solid_fractions.size() == body.num_elements() && !(body.solid_fractions[e] > 0.0)) continue;
    const Eigen::Vector3d x0 = body.positions.row(body.tets(e, 0)).transpose();
    Eigen::Matrix3d Ds;
    for (int k = 0; k < 3; ++k) Ds.col(k) = body.positions.row(body.tets(e, k + 1)).transpose() - x0;
    smallest = std::min(smallest, Ds.determinant() / 6.0 / (body.rest_volumes[e] * body.Fp[at(e)].determinant()));
  }
  return smallest;
}

TEST(Contact, AFluidOnABallAndDownASlopeKeepsItsBottomUnfolded) {
  // The surface issue's contact item: the splashing fluid of fig. 3 (its
  // scene's resolution) lands on a ball and slides off it, and lands on a
  // slope (a box tilted by 25°, friction 0.3 < tan 25°) and slides down it;
  // shapes other than the floor's half-space, so the general contact path.
  // Run without restart points (a goo run makes one every frame), as the
  // library's users may: the carried pressures build up over the whole run
  // (the ball blew up at 0.21 s while nodes beside slivers of material
  // carried their multipliers as pressures). Every frame: no crossing, no
  // element squashed below a tenth of its rest volume (where the projection
  // calls it crushed) or inverted, the volume kept, and the bottom
  // unfolded: every triangle lying on the obstacle (all corners within
  // 0.1 mm of it; a sheet is thicker) faces into it, and no two of them are
  // creased past 90°.
  for (const char* shape : {R"({"name": "ball", "shape": {"type": "sphere", "radius": 0.5}, "friction": 0.5})",
                            R"({"name": "slope", "shape": {"type": "box", "size": [2, 2, 0.2]}, "friction": 0.3,
                                "transform": {"rotate_degrees": [0, 25, 0], "translate": [0, 0, 0.4]}})"}) {
    const Scene scene = io::parse_scene(fmt::format(R"({{"ground": {{"height": -1}}, "obstacles": [{}],
      "objects": [{{"primitive": {{"type": "box", "size": [0.2, 0.2, 0.2], "subdivisions": 12}},
        "transform": {{"translate": [0.12, 0, 0.62]}},
        "material": {{"preset": "splashing_fluid", "min_mass_fraction": 0.05}}, "lattice_spacing": 0.04}}]}})",
                                                    shape),
                                        "contact.json", ".");
    Simulation sim(scene);
    const Obstacle& obstacle = scene.obstacles[0];
    const double v0 = surface_integrals(sim.surface()).volume;
    Index touching = 0;
    for (int frame = 1; frame <= 16; ++frame) {
      ASSERT_TRUE(sim.advance_to(frame / 24.0)) << obstacle.name << " frame " << frame;
      const TriangleMesh surface = sim.surface();
      const SurfaceQuality q = measure_surface_quality(surface);
      const Bottom bottom = bottom_against(surface, obstacle, sim.time(), 1e-4);
      touching = std::max(touching, bottom.contact);
      const Body& body = sim.bodies()[0].body;
      EXPECT_EQ(q.self_intersecting_pairs, 0) << obstacle.name << " frame " << frame;
      EXPECT_EQ(bottom.flipped, 0) << obstacle.name << " frame " << frame;
      EXPECT_EQ(bottom.creased, 0) << obstacle.name << " frame " << frame;
      EXPECT_GT(smallest_volume_ratio(body), 0.1) << obstacle.name << " frame " << frame;
      EXPECT_NEAR(q.volume, v0, 0.01 * v0) << obstacle.name << " frame " << frame;
    }
    EXPECT_GT(touching, 100) << obstacle.name << ": the fluid must lie on the obstacle";
  }
}

}  // namespace
}  // namespace goo
