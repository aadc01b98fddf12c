#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>

#include "core/error.h"
#include "core/primitives.h"
#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "meshing/surface_intersections.h"
#include "meshing/surface_upkeep.h"

namespace goo {
namespace {

double longest_edge(const TriangleMesh& s) {
  double out = 0.0;
  for (Index t = 0; t < s.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k)
      out = std::max(out, (s.vertices.row(s.triangles(t, k)) - s.vertices.row(s.triangles(t, (k + 1) % 3))).norm());
  return out;
}

void expect_closed_manifold(const TriangleMesh& s) {
  const SurfaceReport r = analyze_surface(s);
  EXPECT_TRUE(r.closed());
  EXPECT_TRUE(r.manifold());
  EXPECT_TRUE(r.consistently_oriented());
  EXPECT_EQ(r.euler_characteristic(), 2);
}

// A split bisects two triangles in their own planes: the surface as a point
// set does not change, so area, volume and centroid do not either, and
// every old vertex keeps its place.
TEST(SurfaceUpkeep, SplitsLeaveEverySurfacePointWhereItWas) {
  const TriangleMesh before = make_sphere(1.0, 8);
  TriangleMesh after = before;
  const double h = 0.4;
  UpkeepSettings settings;
  settings.collapse_length = 0.0;
  settings.flips = false;  // they trade diagonals: the point set moves a little
  const UpkeepReport report = upkeep_surface(after, h, settings);
  EXPECT_GT(report.splits, 50);
  EXPECT_EQ(report.collapses, 0);
  expect_closed_manifold(after);
  EXPECT_LE(longest_edge(after), settings.split_length * h);
  ASSERT_GE(after.num_vertices(), before.num_vertices());
  EXPECT_TRUE(after.vertices.topRows(before.num_vertices()) == before.vertices);
  const SurfaceIntegrals a = surface_integrals(before), b = surface_integrals(after);
  EXPECT_NEAR(b.area, a.area, 1e-14 * a.area);
  EXPECT_NEAR(b.volume, a.volume, 1e-14 * a.volume);
  EXPECT_LT((b.centroid - a.centroid).norm(), 1e-14);
}

// A fine UV sphere has tiny edges at its poles: collapses remove them, keep
// the surface closed and manifold, and change its volume by no more than the
// bound they report (zero for every collapse whose volume-preserving
// position lay on its edge).
TEST(SurfaceUpkeep, CollapsesKeepTheSurfaceClosedManifoldAndItsVolume) {
  TriangleMesh surface = make_sphere(1.0, 64);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.002, 0.002);
  for (Index v = 0; v < surface.num_vertices(); ++v)
    for (int k = 0; k < 3; ++k) surface.vertices(v, k) += u(rng);
  const double V0 = surface_integrals(surface).volume;
  const Index n0 = surface.num_triangles();
  UpkeepSettings settings;
  settings.split_length = 10.0;  // no splits
  settings.collapse_length = 0.2;
  const UpkeepReport report = upkeep_surface(surface, 0.25, settings);
  EXPECT_GT(report.collapses, 100);
  EXPECT_LT(surface.num_triangles(), n0);
  expect_closed_manifold(surface);
  const double V1 = surface_integrals(surface).volume;
  EXPECT_LE(std::abs(V1 - V0), report.volume_change_bound + 1e-13 * V0);
  EXPECT_LT(report.volume_change_bound, 1e-3 * V0);
}

TEST(SurfaceUpkeep, RefusesThresholdsThatWouldFlipFlop) {
  TriangleMesh s = make_sphere(1.0, 8);
  UpkeepSettings settings;
  settings.split_length = 0.1;
  settings.collapse_length = 0.08;
  EXPECT_ANY_THROW(upkeep_surface(s, 1.0, settings));
}

/// Triangle pairs, one of `a` and one of `b`, that intersect (exactly).
std::size_t crossings_between(const TriangleMesh& a, const TriangleMesh& b) {
  std::size_t n = 0;
  for (Index s = 0; s < a.num_triangles(); ++s)
    for (Index t = 0; t < b.num_triangles(); ++t) {
      const auto p = [](const TriangleMesh& m, Index f, int k) -> Eigen::Vector3d {
        return m.vertices.row(m.triangles(f, k)).transpose();
      };
      if (triangles_intersect(p(a, s, 0), p(a, s, 1), p(a, s, 2), p(b, t, 0), p(b, t, 1), p(b, t, 2))) ++n;
    }
  return n;
}

/// The smallest angle of any triangle, degrees.
double smallest_angle(const TriangleMesh& s) {
  double out = 180.0;
  for (Index t = 0; t < s.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d a = s.vertices.row(s.triangles(t, k)).transpose();
      const Eigen::Vector3d u = s.vertices.row(s.triangles(t, (k + 1) % 3)).transpose() - a;
      const Eigen::Vector3d v = s.vertices.row(s.triangles(t, (k + 2) % 3)).transpose() - a;
      out = std::min(out, std::atan2(u.cross(v).norm(), u.dot(v)) * 180.0 / std::numbers::pi);
    }
  return out;
}

TEST(SurfaceUpkeep, FlipsRemoveSliversAndTheirCreasesMovingNoVertex) {
  // A box whose top face holds caps: a vertex moved onto an edge of its
  // star, a hair (1e-5) past it and 1e-3 above the face. The cap's normal
  // turns over (a creased edge on a nearly flat face), as a sliver's does
  // on a flowing surface. Flips restore good triangles; no vertex moves,
  // the box's own 90° edges stay, and the volume changes by the caps' few
  // tetrahedra only.
  TriangleMesh box = make_box(Eigen::Vector3d::Ones(), 12);  // vertices 1/12 apart
  const double spacing = 1.0 / 12.0;
  int caps = 0;
  for (Index v = 0; v < box.num_vertices(); ++v) {
    const Eigen::Vector3d x = box.vertices.row(v).transpose();
    const long i = std::lround((x.x() + 0.5) / spacing), j = std::lround((x.y() + 0.5) / spacing);
    if (std::abs(x.z() - 0.5) > 1e-12 || i % 3 != 1 || j % 3 != 1 || i < 2 || j < 2 || i > 10 || j > 10) continue;
    for (Index t = 0; t < box.num_triangles(); ++t) {  // v's first triangle (v, a, b)
      int k = 0;
      while (k < 3 && box.triangles(t, k) != v) ++k;
      if (k == 3) continue;
      const Eigen::Vector3d a = box.vertices.row(box.triangles(t, (k + 1) % 3)).transpose();
      const Eigen::Vector3d b = box.vertices.row(box.triangles(t, (k + 2) % 3)).transpose();
      const Eigen::Vector3d middle = 0.5 * (a + b), out = (middle - x).normalized();
      box.vertices.row(v) = (middle + 1e-5 * out + Eigen::Vector3d(0, 0, 1e-3)).transpose();
      ++caps;
      break;
    }
  }
  ASSERT_EQ(caps, 9);
  const SurfaceQuality before = measure_surface_quality(box);
  ASSERT_EQ(before.self_intersecting_pairs, 0);
  ASSERT_GE(before.creased_edges, caps);
  UpkeepSettings settings;
  settings.split_length = 10.0;     // no splits
  settings.collapse_length = 1e-6;  // no collapses
  TriangleMesh flipped = box;
  const UpkeepReport report = upkeep_surface(flipped, 1.0, settings);
  EXPECT_GE(report.flips, caps);
  EXPECT_EQ(report.splits + report.collapses, 0);
  EXPECT_TRUE(flipped.vertices == box.vertices);  // bit for bit
  const SurfaceQuality after = measure_surface_quality(flipped);
  EXPECT_EQ(after.creased_edges, 0);
  EXPECT_EQ(after.self_intersecting_pairs, 0);
  // The caps' angles (about 1.4°) are gone. What the moves leave sharpest is
  // Delaunay already: with v at the middle of its star's edge from (1, 0)
  // to (1, 1) (in spacings from where it was), the triangle
  // (v, (1, 0), (0, −1)) has atan(1/5) = 11.31° at (0, −1), and the angles
  // facing its long edge sum to 172°.
  EXPECT_LT(smallest_angle(box), 2.0);
  EXPECT_GT(smallest_angle(flipped), 11.0);
  // Each flip changes the volume by its quad's tetrahedron: at most the
  // lift × the quad's area (1e-3 × spacing²) for a cap's.
  EXPECT_NEAR(after.volume, before.volume, report.volume_change_bound * (1.0 + 1e-9) + 1e-15);
  EXPECT_LE(report.volume_change_bound, report.flips * 1e-3 * spacing * spacing);
  expect_closed_manifold(flipped);
  // The box's edges: every triangle still faces an axis (the caps' stars
  // tilt by atan(1e-3 / spacing) < 1°; a flip across a box edge, 45°).
  for (Index t = 0; t < flipped.num_triangles(); ++t) {
    const auto [a, b, c] = flipped.corners(t);
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    EXPECT_GT(n.cwiseAbs().maxCoeff(), 0.999) << "triangle " << t;
  }
  // Without flips, the caps stay.
  settings.flips = false;
  TriangleMesh kept = box;
  EXPECT_EQ(upkeep_surface(kept, 1.0, settings).flips, 0);
  EXPECT_EQ(measure_surface_quality(kept).creased_edges, before.creased_edges);
}

TEST(SurfaceUpkeep, FlipsLeaveACurvedSurfaceCloseAndDelaunay) {
  // A sphere of skewed bands (every other ring turned by 0.45 of a segment):
  // each quad's short diagonal is the Delaunay one, and near the poles the
  // long one makes slivers. Flips trade diagonals there only, where the
  // surface moves by at most a tenth of an edge; the volume changes by at
  // most the bound reported, and a second pass finds nothing to flip (no
  // flip-flop).
  TriangleMesh sphere = make_sphere(1.0, 48);
  for (Index v = 0; v < sphere.num_vertices(); ++v) {
    const Eigen::Vector3d x = sphere.vertices.row(v).transpose();
    const double rho = std::hypot(x.x(), x.y());
    if (rho < 1e-12) continue;
    const long ring = std::lround(std::acos(std::clamp(-x.z(), -1.0, 1.0)) / (std::numbers::pi / 24));
    if (ring % 2 == 0) continue;
    const double phi = std::atan2(x.y(), x.x()) + 0.45 * 2.0 * std::numbers::pi / 48;
    sphere.vertices.row(v) = Eigen::RowVector3d(rho * std::cos(phi), rho * std::sin(phi), x.z());
  }
  ASSERT_EQ(measure_surface_quality(sphere).self_intersecting_pairs, 0);
  UpkeepSettings settings;
  settings.split_length = 10.0;
  settings.collapse_length = 1e-6;
  TriangleMesh flipped = sphere;
  const UpkeepReport report = upkeep_surface(flipped, 1.0, settings);
  EXPECT_GT(report.flips, 10);
  expect_closed_manifold(flipped);
  EXPECT_EQ(measure_surface_quality(flipped).self_intersecting_pairs, 0);
  EXPECT_GT(smallest_angle(flipped), smallest_angle(sphere));
  const double v0 = surface_integrals(sphere).volume, v1 = surface_integrals(flipped).volume;
  EXPECT_LE(std::abs(v1 - v0), report.volume_change_bound * (1.0 + 1e-9));
  EXPECT_LT(std::abs(v1 - v0), 1e-3 * v0);
  EXPECT_EQ(upkeep_surface(flipped, 1.0, settings).flips, 0);
}

TEST(SurfaceUpkeep, CollapsesNeverMakeTheSurfacePassThroughAnotherBody) {
  // A dent in the top of a box, one of its edges short; a small body rests
  // in the dent, outside the box. Collapsing that edge fills the dent, and
  // the box would swallow the small body: with it as a blocker, the
  // collapse is refused.
  TriangleMesh box = make_box(Eigen::Vector3d::Ones(), 10);  // top face z = 0.5, vertices 0.1 apart
  Index dent = -1, beside = -1;
  for (Index v = 0; v < box.num_vertices(); ++v) {
    const Eigen::Vector3d x = box.vertices.row(v).transpose();
    if ((x - Eigen::Vector3d(0, 0, 0.5)).norm() < 1e-12) dent = v;
    if ((x - Eigen::Vector3d(0.1, 0, 0.5)).norm() < 1e-12) beside = v;
  }
  ASSERT_GE(dent, 0);
  ASSERT_GE(beside, 0);
  box.vertices.row(dent) = Eigen::RowVector3d(0, 0, 0.45);
  box.vertices.row(beside) = Eigen::RowVector3d(0.01, 0, 0.5);  // the edge dent–beside: 0.051 long
  TriangleMesh pebble = make_box(Eigen::Vector3d::Constant(0.01), 1);
  pebble.vertices.rowwise() += Eigen::RowVector3d(-0.03, 0.0, 0.485);  // in the dent, above its floor
  ASSERT_EQ(crossings_between(box, pebble), 0u);
  ASSERT_EQ(self_intersecting_pairs(box).size(), 0u);
  UpkeepSettings settings;
  settings.split_length = 1.0;  // no splits: edges are 0.1
  settings.collapse_length = 0.06;
  TriangleMesh alone = box;
  const UpkeepReport free = upkeep_surface(alone, 1.0, settings);
  ASSERT_GT(free.collapses, 0);
  EXPECT_GT(crossings_between(alone, pebble), 0u) << "the case must cross without the blocker";
  TriangleMesh blocked = box;
  const UpkeepReport report = upkeep_surface(blocked, 1.0, settings, &pebble);
  EXPECT_GT(report.refused_crossing, 0);
  EXPECT_EQ(crossings_between(blocked, pebble), 0u);
  EXPECT_EQ(self_intersecting_pairs(blocked).size(), 0u);
  expect_closed_manifold(blocked);
}

}  // namespace
}  // namespace goo

namespace goo {
namespace {

/// A torus pressed nearly flat, with random jitter: a clean surface whose
/// two sheets lie closer than an edge.
TriangleMesh flattened_torus(unsigned seed) {
  TriangleMesh t = make_torus(1.0, 0.3, 64, 24);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.02, 0.02);
  for (Index v = 0; v < t.num_vertices(); ++v) {
    t.vertices(v, 0) += jitter(rng);
    t.vertices(v, 1) += jitter(rng);
    t.vertices(v, 2) *= 0.03;
  }
  return t;
}

TEST(SurfaceUpkeep, CollapsesNeverMakeTheSurfacePassThroughItself) {
  // Tori pressed nearly flat, with random jitter: clean surfaces whose two
  // sheets lie closer than an edge, where a collapse's new fan can sweep
  // through the other sheet. Every such collapse is refused.
  Index refused_crossing = 0;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    TriangleMesh t = flattened_torus(seed);
    ASSERT_EQ(self_intersecting_pairs(t).size(), 0u) << "seed " << seed;
    UpkeepSettings settings;
    settings.split_length = 1.0;
    settings.collapse_length = 0.06;
    const UpkeepReport report = upkeep_surface(t, 1.0, settings);
    EXPECT_GT(report.collapses, 0);
    refused_crossing += report.refused_crossing;
    EXPECT_EQ(self_intersecting_pairs(t).size(), 0u) << "seed " << seed;
    EXPECT_TRUE(analyze_surface(t).manifold());
  }
  EXPECT_GT(refused_crossing, 0);
}

// Each pass hands the next its grid of the triangles and its list of long
// or short edges, brought up to date for the triangles it changed instead
// of made anew. Passes run in one call must then do what the same passes do
// one call each (every call starts from a fresh grid and lists): the same
// surface, to the bit.
TEST(SurfaceUpkeep, PassesKeptUpToDateDoWhatFreshPassesDo) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const TriangleMesh start = flattened_torus(seed);
    enum Kind { kSplits, kCollapses, kFlips };
    for (const Kind kind : {kSplits, kCollapses, kFlips}) {
      // One kind of pass at a time: the others have nothing to do.
      UpkeepSettings settings;
      settings.split_length = kind == kSplits ? 0.05 : 100.0;
      settings.collapse_length = kind == kCollapses ? 0.06 : 0.0;
      settings.flips = kind == kFlips;
      settings.max_passes = 16;
      auto count = [&](const UpkeepReport& r) {
        return kind == kSplits ? r.splits : kind == kCollapses ? r.collapses : r.flips;
      };
      TriangleMesh together = start;
      const UpkeepReport all = upkeep_surface(together, 1.0, settings);
      EXPECT_GT(count(all), 0) << "seed " << seed << " kind " << kind;
      settings.max_passes = 1;
      TriangleMesh apart = start;
      Index done = 0;
      for (int call = 0; call < 16; ++call) {
        const Index one = count(upkeep_surface(apart, 1.0, settings));
        done += one;
        if (one == 0) break;
      }
      EXPECT_EQ(done, count(all)) << "seed " << seed << " kind " << kind;
      ASSERT_EQ(apart.triangles.rows(), together.triangles.rows()) << "seed " << seed << " kind " << kind;
      EXPECT_TRUE(apart.triangles == together.triangles) << "seed " << seed << " kind " << kind;
      EXPECT_TRUE(apart.vertices == together.vertices) << "seed " << seed << " kind " << kind;
    }
  }
}

// order_surface renumbers a surface in space order and changes nothing
// else: the same triangles with the same corners in the same cyclic order
// (the same orientation), its vertices along a Morton curve and its
// triangles by their lowest vertex. The order depends on the geometry
// only, so a shuffled copy orders to the same arrays, and ordering twice
// is ordering once. Neighbours end up near each other in the arrays: in a
// shuffled surface an edge's two ends lie about a third of the vertices
// apart (the mean gap of two random numbers); ordered, within a few rings.
TEST(SurfaceOrder, RenumbersTheSameSurfaceInSpaceOrder) {
  const TriangleMesh sphere = make_sphere(1.0, 24);
  const Index nv = sphere.num_vertices(), nt = sphere.num_triangles();
  std::mt19937 rng(7);
  std::vector<Index> vertex_order(static_cast<std::size_t>(nv)), triangle_order(static_cast<std::size_t>(nt));
  std::iota(vertex_order.begin(), vertex_order.end(), 0);
  std::iota(triangle_order.begin(), triangle_order.end(), 0);
  std::shuffle(vertex_order.begin(), vertex_order.end(), rng);
  std::shuffle(triangle_order.begin(), triangle_order.end(), rng);
  TriangleMesh shuffled;
  shuffled.vertices.resize(nv, 3);
  shuffled.triangles.resize(nt, 3);
  std::vector<Index> moved_to(static_cast<std::size_t>(nv));
  for (Index i = 0; i < nv; ++i) {
    shuffled.vertices.row(i) = sphere.vertices.row(vertex_order[static_cast<std::size_t>(i)]);
    moved_to[static_cast<std::size_t>(vertex_order[static_cast<std::size_t>(i)])] = i;
  }
  for (Index t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c)
      shuffled.triangles(t, c) =
          moved_to[static_cast<std::size_t>(sphere.triangles(triangle_order[static_cast<std::size_t>(t)], c))];
  // Each triangle as its corners' positions, starting at the least one
  // (a cyclic rotation: the orientation stays), sorted: the surface as a
  // set of oriented triangles, whatever its numbering.
  auto oriented = [](const TriangleMesh& s) {
    std::vector<std::array<double, 9>> out;
    for (Index t = 0; t < s.num_triangles(); ++t) {
      std::array<std::array<double, 3>, 3> c;
      for (int k = 0; k < 3; ++k)
        for (int i = 0; i < 3; ++i)
          c[static_cast<std::size_t>(k)][static_cast<std::size_t>(i)] = s.vertices(s.triangles(t, k), i);
      const auto first = static_cast<std::size_t>(std::min_element(c.begin(), c.end()) - c.begin());
      std::array<double, 9> row;
      for (std::size_t k = 0; k < 3; ++k)
        for (std::size_t i = 0; i < 3; ++i) row[3 * k + i] = c[(first + k) % 3][i];
      out.push_back(row);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  auto median_gap = [](const TriangleMesh& s) {
    std::vector<Index> gaps;
    for (Index t = 0; t < s.num_triangles(); ++t)
      for (int k = 0; k < 3; ++k) gaps.push_back(std::abs(s.triangles(t, k) - s.triangles(t, (k + 1) % 3)));
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2), gaps.end());
    return gaps[gaps.size() / 2];
  };
  TriangleMesh ordered = shuffled;
  order_surface(ordered, 0.2);
  EXPECT_EQ(oriented(ordered), oriented(sphere));
  expect_closed_manifold(ordered);
  for (Index t = 1; t < nt; ++t)
    EXPECT_LE(ordered.triangles.row(t - 1).minCoeff(), ordered.triangles.row(t).minCoeff()) << "triangle " << t;
  TriangleMesh from_sphere = sphere;
  order_surface(from_sphere, 0.2);
  EXPECT_TRUE(from_sphere.vertices == ordered.vertices);
  EXPECT_EQ(from_sphere.triangles, ordered.triangles);
  // Cells of a sixteenth of the sphere's radius hold many vertices each:
  // their order within a cell comes from their coordinates, still the
  // same for the shuffled copy.
  TriangleMesh coarse = shuffled, coarse_sphere = sphere;
  order_surface(coarse, 16.0);
  order_surface(coarse_sphere, 16.0);
  EXPECT_TRUE(coarse.vertices == coarse_sphere.vertices);
  EXPECT_EQ(coarse.triangles, coarse_sphere.triangles);
  EXPECT_EQ(oriented(coarse), oriented(sphere));
  TriangleMesh twice = ordered;
  order_surface(twice, 0.2);
  EXPECT_TRUE(twice.vertices == ordered.vertices);
  EXPECT_EQ(twice.triangles, ordered.triangles);
  EXPECT_GT(median_gap(shuffled), nv / 5);
  EXPECT_LT(median_gap(ordered), nv / 20);
  // Bad input: named.
  TriangleMesh bad = sphere;
  bad.vertices(3, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(order_surface(bad, 0.2), Error);
  EXPECT_THROW(order_surface(ordered, 0.0), Error);
}

}  // namespace
}  // namespace goo
