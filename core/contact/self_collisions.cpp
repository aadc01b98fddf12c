#include "core/contact/self_collisions.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/SVD>
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>
#include <utility>

#include "core/contact/box_pairs.h"
#include "core/contact/ccd.h"
#include "core/element_vertices.h"
#include "core/parallel.h"
#include "core/surface_topology.h"
#include "core/union_find.h"

namespace goo {
namespace {

using ccd::PairKind;
using Vec3 = Eigen::Vector3d;

constexpr double kRepulsionFraction = 0.1;  // of the missing thickness, per step (Bridson et al. 2002, sec. 7.2)
constexpr int kMaxZoneRounds = 64;
// An impact leaves its pair separating by a tenth of the thickness over the
// step, not merely at rest: other impulses of the round then rarely turn it
// back into an approach.
constexpr double kSeparationFraction = 0.1;
// Both are displacements over the step, so the velocity they set is
// target / Δt: a step cut short (the strain-rate bound, a frame's end) would
// set pairs apart the faster the shorter it is, the faster motion would cut
// the next step shorter still, and the run would run away (the armadillo
// grate: Δt fell to 1.5e-8 s and a node reached 3.6 km/s). resolve_step
// scales them by Δt / reference step (SelfCollisionParameters).
// How far an impulse may move a node, over the change it makes at its pair:
// |c_k|/(m_k K) with K = Σ c_j²/m_j. With equal masses and no node on both
// sides, one side's c (summing to 1 over at most 12 nodes) gives
// Σ c_j² ≥ c_k² + 1/12, so the ratio is at most √3 and this never binds.
constexpr double kMaxNodeMove = 2.0;
// Continuous detection reports a pair within twice its minimum distance
// (ccd.h); the list and the per-step bound keep every pair that can come
// that close, so what is reported never depends on when the list was built
// (a resumed run, which builds it anew, goes on bit for bit).
constexpr double kReported = 2.0;

/// The nodes a pair's relative point depends on, with coefficients c_i:
/// it moves by Σ c_i d_i. At most 4 vertices × 4 nodes.
struct NodeWeights {
  std::array<Index, 16> node{};
  std::array<double, 16> c{};
  int size = 0;
  void add(Index n, double w) {
    for (int k = 0; k < size; ++k)
      if (node[std::size_t(k)] == n) {
        c[std::size_t(k)] += w;
        return;
      }
    node[std::size_t(size)] = n;
    c[std::size_t(size)] = w;
    ++size;
  }
};

NodeWeights node_weights(const Body& body, const std::array<Index, 4>& vertices, const std::array<double, 4>& alpha) {
  NodeWeights w;
  for (std::size_t k = 0; k < 4; ++k) {
    const Index s = vertices[k];
    const Index e = body.embedding.parent[at(s)];
    for (int i = 0; i < 4; ++i) w.add(body.tets(e, i), alpha[k] * body.embedding.bary(s, i));
  }
  return w;
}

/// The line of a pair's closest points at positions x (unit n, from the
/// second side to the first) and the nodes its relative point hangs on: an
/// impulse on the pair changes Σ c_i d_i · n. None where the pair touches.
struct Approach {
  Vec3 n;
  NodeWeights w;
  /// The pair's relative displacement along n for node displacements d.
  [[nodiscard]] double along(const Points& d) const {
    Vec3 u = Vec3::Zero();
    for (std::size_t k = 0; k < std::size_t(w.size); ++k) u += w.c[k] * d.row(w.node[k]).transpose();
    return u.dot(n);
  }
};

std::optional<Approach> approach_of(const Body& body, PairKind kind, const std::array<Index, 4>& vertices,
                                    const ccd::Points4& x) {
  const ccd::Closest closest = ccd::closest(kind, x);
  Vec3 n = Vec3::Zero();
  for (std::size_t k = 0; k < 4; ++k) n += closest.coefficients[k] * x[k];
  if (!(n.norm() > 0.0)) return std::nullopt;  // touching: no direction to push along
  return Approach{n.normalized(), node_weights(body, vertices, closest.coefficients)};
}

/// One impulse bringing a pair's relative normal displacement over the
/// step up to `target` (m), along its approach (the line of its closest
/// points where the impulse acts), with friction. Returns whether it acted.
bool push_apart(const Body& body, const std::optional<Approach>& approach, Points& d,
                const std::vector<std::uint8_t>& fixed, double target, double friction) {
  if (!approach) return false;  // touching: no direction to push along
  const Vec3& n = approach->n;
  const NodeWeights& w = approach->w;
  Vec3 u = Vec3::Zero();
  double K = 0.0;
  std::array<double, 16> inverse_mass{};
  for (std::size_t k = 0; k < std::size_t(w.size); ++k) {
    const Index node = w.node[k];
    inverse_mass[k] = (!fixed.empty() && fixed[at(node)]) ? 0.0 : 1.0 / body.masses[node];
    u += w.c[k] * d.row(node).transpose();
    K += w.c[k] * w.c[k] * inverse_mass[k];
  }
  const double un = u.dot(n);
  if (un >= target || !(K > 0.0)) return false;
  // Inelastic normal impulse (the relative normal displacement becomes the
  // target), Coulomb friction bounded by it.
  Vec3 change = (target - un) / K * n;
  const Vec3 ut = u - un * n;
  const double slide = ut.norm();
  if (slide > 0.0) change -= std::min(slide, friction * (target - un)) / K * (ut / slide);
  // Node k moves by c_k/m_k × the impulse. Two sides whose points lie in
  // elements sharing nodes nearly cancel there (small K), and a light node
  // (a lattice node outside the material, at the mass floor) with a small
  // weight is cheap to move: the impulse would send it far for a tiny
  // change at the pair. No node moves more than kMaxNodeMove × the change
  // the impulse makes at the pair (K × change); the impulse is scaled down,
  // both sides alike (momentum kept), and what is left of the approach goes
  // to the next round or to the rigid zones.
  double largest = 0.0;
  for (std::size_t k = 0; k < std::size_t(w.size); ++k)
    largest = std::max(largest, std::abs(w.c[k]) * inverse_mass[k]);
  const double allowed = kMaxNodeMove * K;
  if (largest > allowed) change *= allowed / largest;
  for (std::size_t k = 0; k < std::size_t(w.size); ++k)
    d.row(w.node[k]) += (w.c[k] * inverse_mass[k] * change).transpose();
  return true;
}

/// How far apart a pair that starts `start` apart is kept: the thickness,
/// or half its gap if it starts closer (continuous detection reports it
/// when it comes nearer).
double kept_apart(double start, double thickness) { return start > thickness ? thickness : 0.5 * start; }

ccd::Points4 gather(const Points& xs, const std::array<Index, 4>& v) {
  return {xs.row(v[0]).transpose(), xs.row(v[1]).transpose(), xs.row(v[2]).transpose(), xs.row(v[3]).transpose()};
}

/// How far the two primitives of a pair can have come closer than they were
/// at the build, when each vertex lies within `by[v]` (each coordinate) of
/// its place then, after a common translation: √3 × the largest on each side.
double reach(PairKind kind, const std::array<Index, 4>& v, const std::vector<double>& by) {
  const std::size_t first_side = kind == PairKind::vertex_triangle ? 1 : 2;
  double a = 0.0, b = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    double& side = k < first_side ? a : b;
    side = std::max(side, by[at(v[k])]);
  }
  return std::sqrt(3.0) * (a + b);
}

Box3 grown(Box3 b, double by) {
  b.min().array() -= by;
  b.max().array() += by;
  return b;
}

/// The list's boxes: a vertex's, its place xs at the build grown by its
/// reach margin and half the reporting distance (boxes that stay apart
/// keep their primitives more than 2δ apart while the list holds); a
/// triangle's and an edge's, those of their corners together.
Box3 vertex_box(const Points& xs, Index v, double reach_margin, double thickness) {
  return grown(Box3(xs.row(v).transpose(), xs.row(v).transpose()), reach_margin + 0.5 * kReported * thickness);
}
Box3 triangle_box(const std::vector<Box3>& vb, const Triangles& tris, Index t) {
  return Box3(vb[at(tris(t, 0))]).extend(vb[at(tris(t, 1))]).extend(vb[at(tris(t, 2))]);
}
Box3 edge_box(const std::vector<Box3>& vb, const std::array<Index, 2>& e) {
  return Box3(vb[at(e[0])]).extend(vb[at(e[1])]);
}

/// Moves a zone's nodes rigidly: the mass-weighted mean displacement and the
/// rotation that keeps the angular momentum of the displacements (Bridson
/// et al. 2002, sec. 7.4). x ↦ x + u + ω × (x − c) is affine with
/// (I + [ω]×)ᵀ(I + [ω]×) = I + [ω]×ᵀ[ω]× ⪰ I, so no distance inside the zone
/// shrinks at any time of the step. A zone holding a fixed node stands still.
void rigidify(const Body& body, const Points& x0, Points& d, const std::vector<std::uint8_t>& fixed,
              const std::vector<Index>& nodes) {
  bool held = false;
  for (const Index n : nodes) held = held || (!fixed.empty() && fixed[at(n)]);
  if (held) {
    for (const Index n : nodes)
      if (fixed.empty() || !fixed[at(n)]) d.row(n).setZero();
    return;
  }
  double mass = 0.0;
  Vec3 c = Vec3::Zero(), u = Vec3::Zero();
  for (const Index n : nodes) {
    const double m = body.masses[n];
    mass += m;
    c += m * x0.row(n).transpose();
    u += m * d.row(n).transpose();
  }
  c /= mass;
  u /= mass;
  Vec3 L = Vec3::Zero();
  Eigen::Matrix3d I = Eigen::Matrix3d::Zero();
  for (const Index n : nodes) {
    const double m = body.masses[n];
    const Vec3 r = x0.row(n).transpose() - c;
    L += m * r.cross(d.row(n).transpose() - u);
    I += m * (r.squaredNorm() * Eigen::Matrix3d::Identity() - r * r.transpose());
  }
  const Vec3 omega = Eigen::JacobiSVD<Eigen::Matrix3d>(I, Eigen::ComputeFullU | Eigen::ComputeFullV).solve(L);
  for (const Index n : nodes) d.row(n) = (u + omega.cross(x0.row(n).transpose() - c)).transpose();
}

/// Whether element e's orientation det D(t) stays positive over the whole
/// step, D(t) = D₀ + t E with D₀ its edge matrix at x0 and E that of the
/// displacements d: det(D₀ + tE) = det D₀ + t tr(adj(D₀) E) + t² tr(D₀ adj(E))
/// + t³ det E, a cubic whose least value on [0, 1] is at an end or at a root
/// of its derivative. Required to exceed its rounding error (a few ulps of
/// the largest term) by a thousandfold: a near-degenerate element does not count.
bool stays_positive(const Body& body, const Points& x0, const Points& d, Index e) {
  Eigen::Matrix3d D, E;
  const Index n0 = body.tets(e, 0);
  for (int k = 1; k < 4; ++k) {
    const Index n = body.tets(e, k);
    D.col(k - 1) = (x0.row(n) - x0.row(n0)).transpose();
    E.col(k - 1) = (d.row(n) - d.row(n0)).transpose();
  }
  auto adjugate = [](const Eigen::Matrix3d& m) {
    Eigen::Matrix3d a;
    a.row(0) = m.col(1).cross(m.col(2)).transpose();
    a.row(1) = m.col(2).cross(m.col(0)).transpose();
    a.row(2) = m.col(0).cross(m.col(1)).transpose();
    return a;
  };
  const double c0 = D.determinant(), c1 = (adjugate(D) * E).trace(), c2 = (D * adjugate(E)).trace(),
               c3 = E.determinant();
  const double size = D.norm() + E.norm(), scale = size * size * size;
  const double floor = 1e3 * 64.0 * std::numeric_limits<double>::epsilon() * scale;
  auto p = [&](double t) { return c0 + t * (c1 + t * (c2 + t * c3)); };
  double least = std::min(p(0.0), p(1.0));
  // p'(t) = c1 + 2 c2 t + 3 c3 t²
  const double a = 3.0 * c3, b = 2.0 * c2, c = c1;
  if (a != 0.0) {
    const double disc = b * b - 4.0 * a * c;
    if (disc >= 0.0) {
      const double r = std::sqrt(disc);
      for (const double t : {(-b - r) / (2.0 * a), (-b + r) / (2.0 * a)})
        if (t > 0.0 && t < 1.0) least = std::min(least, p(t));
    }
  } else if (b != 0.0) {
    const double t = -c / b;
    if (t > 0.0 && t < 1.0) least = std::min(least, p(t));
  }
  return least > floor;
}

}  // namespace

void SelfCollisions::set_groups(std::optional<CollisionGroups> groups) {
  groups_ = std::move(groups);
  waiting_.clear();
  list_valid_ = false;  // the list holds only the pairs the groups want
}

double SelfCollisions::friction(const Pair& pair, double own) const {
  if (!groups_) return own;
  return within(pair) ? groups_->self_friction[at(group(pair.vertices))] : groups_->between_friction;
}

bool SelfCollisions::update_edges(const Triangles& triangles) {
  if (same_bits(triangles, triangles_)) return false;
  copy_in_parallel(triangles, triangles_);
  const Index nt = static_cast<Index>(triangles.rows());
  // (a, b, triangle, corner) for every side of every triangle, sorted: runs
  // are the edges; the lowest triangle of a run owns the edge.
  const std::vector<std::array<Index, 4>> sides = sorted_sides(triangles);
  const Index nv = nt > 0 ? triangles.maxCoeff() + 1 : 0;
  edges_.clear();
  std::vector<Index> edge_owner;                            // per edge, the lowest triangle holding it
  std::vector<std::array<Index, 3>> triangle_edges(at(nt));  // per triangle, its edges (side k: corners k, k+1)
  for (std::size_t i = 0; i < sides.size(); ++i) {
    if (i == 0 || sides[i][0] != sides[i - 1][0] || sides[i][1] != sides[i - 1][1]) {
      edges_.push_back({sides[i][0], sides[i][1]});
      edge_owner.push_back(sides[i][2]);
    }
    triangle_edges[at(sides[i][2])][at(sides[i][3])] = static_cast<Index>(edges_.size() - 1);
  }
  std::vector<Index> vertex_owner(at(nv), -1);  // per vertex, the lowest triangle holding it
  for (Index t = nt - 1; t >= 0; --t)
    for (int k = 0; k < 3; ++k) vertex_owner[at(triangles(t, k))] = t;
  owned_.assign(at(nt), {});
  for (Index t = 0; t < nt; ++t) {
    Owned& own = owned_[at(t)];
    for (int k = 0; k < 3; ++k) {
      if (vertex_owner[at(triangles(t, k))] == t) own.vertices[own.num_vertices++] = triangles(t, k);
      if (const Index e = triangle_edges[at(t)][at(k)]; edge_owner[at(e)] == t) own.edges[own.num_edges++] = e;
    }
  }
  return true;
}

SelfCollisions::ListCheck SelfCollisions::list_holds(const Points& xs0, const Points& ds,
                                                     const std::vector<Index>* changed) {
  // Every vertex, at the start and the end of the step, within its margin
  // (each coordinate) of its place at the build moved by its cluster's mean
  // motion since; and every two clusters' mean motions within their
  // allowance of each other. Both are convex in t and the motions linear
  // over the step: the two ends are enough.
  const bool held = std::exchange(held_, false);
  if (changed && held && recheck_ != Recheck::everything) return list_holds_again(xs0, ds, *changed);
  const auto nv = static_cast<Index>(xs0.rows()); const Index nc = clusters_;
  std::array<Points, 2>& mean = cluster_motion_;
  mean = {Points::Zero(nc, 3), Points::Zero(nc, 3)};
  // Each cluster's sums over its vertices in their order (cluster_vertices_):
  // the same bits on any thread count.
  tbb::parallel_for(tbb::blocked_range<Index>(0, nc, 1), [&](const tbb::blocked_range<Index>& r) {
    for (Index c = r.begin(); c != r.end(); ++c) {
      Eigen::RowVector3d start_sum = Eigen::RowVector3d::Zero(), end_sum = Eigen::RowVector3d::Zero();
      for (Index i = cluster_offsets_[at(c)]; i < cluster_offsets_[at(c) + 1]; ++i) {
        const Index v = cluster_vertices_[at(i)];
        const Eigen::RowVector3d start = xs0.row(v) - list_positions_.row(v);
        start_sum += start;
        end_sum += start + ds.row(v);
      }
      mean[0].row(c) = start_sum / double(cluster_size_[at(c)]);
      mean[1].row(c) = end_sum / double(cluster_size_[at(c)]);
    }
  });
  const bool parted = any_index(
      nc,
      [&](Index a) {  // rows of cluster pairs in parallel: a yes or no
        for (Index b = a + 1; b < nc; ++b)
          if (!clusters_within(a, b)) return true;
        return false;
      },
      16);
  if (parted) return ListCheck::clusters_parted;
  // Every vertex's drift (extend_list reads those past their margins).
  std::atomic<bool> within{true};
  tbb::parallel_for(tbb::blocked_range<Index>(0, nv, 4 * kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    bool all = true;
    for (Index v = r.begin(); v != r.end(); ++v) {
      all = measure_drift(xs0, ds, v) && all;
    }
    if (!all) within.store(false, std::memory_order_relaxed);
  });
  held_ = within.load();
  return held_ ? ListCheck::holds : ListCheck::vertices_past_margins;
}

bool SelfCollisions::clusters_within(Index a, Index b) const {
  const std::array<Points, 2>& mean = cluster_motion_;
  const double allowed = allowance_[at(a * clusters_ + b)];
  return (mean[0].row(a) - mean[0].row(b)).cwiseAbs().maxCoeff() <= allowed &&
         (mean[1].row(a) - mean[1].row(b)).cwiseAbs().maxCoeff() <= allowed;
}

bool SelfCollisions::measure_drift(const Points& xs0, const Points& ds, Index v) {
  const std::array<Points, 2>& mean = cluster_motion_;
  const Index c = cluster_[at(v)];
  const Eigen::RowVector3d start = xs0.row(v) - list_positions_.row(v) - mean[0].row(c);
  const Eigen::RowVector3d end = xs0.row(v) + ds.row(v) - list_positions_.row(v) - mean[1].row(c);
  drift_[at(v)] = std::max(start.cwiseAbs().maxCoeff(), end.cwiseAbs().maxCoeff());
  return drift_[at(v)] <= margin_[at(v)];
}

SelfCollisions::ListCheck SelfCollisions::list_holds_again(const Points& xs0, const Points& ds,
                                                           const std::vector<Index>& changed) {
  // The last check held at these start positions: every start motion,
  // every cluster pair and every drift passed, and only the `changed`
  // vertices' end motions differ now. Their clusters' end means are summed
  // again as list_holds sums them (the same bits); the pairs and drifts
  // that read them are measured again, the rest passed with the values
  // they would have now.
  const Index nc = clusters_;
  std::array<Points, 2>& mean = cluster_motion_;
  cluster_changed_.assign(at(nc), 0);
  changed_clusters_.clear();
  for (const Index v : changed) {
    const Index c = cluster_[at(v)];
    if (!cluster_changed_[at(c)]) {
      cluster_changed_[at(c)] = 1;
      changed_clusters_.push_back(c);
    }
  }
  const auto num_changed = static_cast<Index>(changed_clusters_.size());
  for_each_index(
      num_changed,
      [&](Index k) {
        const Index c = changed_clusters_[at(k)];
        Eigen::RowVector3d end_sum = Eigen::RowVector3d::Zero();
        for (Index i = cluster_offsets_[at(c)]; i < cluster_offsets_[at(c) + 1]; ++i) {
          const Index v = cluster_vertices_[at(i)];
          const Eigen::RowVector3d start = xs0.row(v) - list_positions_.row(v);
          end_sum += start + ds.row(v);
        }
        mean[1].row(c) = end_sum / double(cluster_size_[at(c)]);
      },
      1);
  const bool parted = any_index(
      num_changed,
      [&](Index k) {  // the pairs of a changed cluster with every other (each pair a < b as list_holds reads it)
        const Index c = changed_clusters_[at(k)];
        for (Index o = 0; o < nc; ++o)
          if (o != c && !clusters_within(std::min(c, o), std::max(c, o))) return true;
        return false;
      },
      1);
  if (parted) return ListCheck::clusters_parted;
  // Each changed cluster's vertices' drifts, all of them (extend_list
  // reads those past their margins).
  cluster_past_.assign(at(num_changed), 0);
  for_each_index(
      num_changed,
      [&](Index k) {
        const Index c = changed_clusters_[at(k)];
        bool all = true;
        for (Index i = cluster_offsets_[at(c)]; i < cluster_offsets_[at(c) + 1]; ++i) {
          all = measure_drift(xs0, ds, cluster_vertices_[at(i)]) && all;
        }
        cluster_past_[at(k)] = all ? 0 : 1;
      },
      1);
  held_ = std::find(cluster_past_.begin(), cluster_past_.end(), 1) == cluster_past_.end();
  return held_ ? ListCheck::holds : ListCheck::vertices_past_margins;
}

void SelfCollisions::make_clusters(const Points& xs0) {
  // Cells of a grid an eighth of the surface's largest extent, doubled
  // until there are at most kMaxClusters; numbered in the order of their
  // first vertex.
  const auto nv = static_cast<Index>(xs0.rows());
  Box3 all;
  for (Index v = 0; v < nv; ++v) all.extend(Vec3(xs0.row(v).transpose()));
  double cell = std::max(all.sizes().maxCoeff() / 8.0, std::numeric_limits<double>::min());
  cluster_.resize(at(nv));
  while (true) {
    std::array<Index, 3> dims{};
    for (int k = 0; k < 3; ++k) dims[at(k)] = static_cast<Index>(std::floor(all.sizes()[k] / cell)) + 1;
    std::vector<Index> id(at(dims[0]) * at(dims[1]) * at(dims[2]), -1);
    Index count = 0;
    for (Index v = 0; v < nv; ++v) {
      std::array<Index, 3> c{};
      for (int k = 0; k < 3; ++k)
        c[at(k)] = static_cast<Index>(std::clamp(std::floor((xs0(v, k) - all.min()[k]) / cell), 0.0, double(dims[at(k)] - 1)));
      Index& slot = id[at(c[0] + dims[0] * (c[1] + dims[1] * c[2]))];
      if (slot < 0) slot = count++;
      cluster_[at(v)] = slot;
    }
    if (count <= kMaxClusters) {
      clusters_ = count;
      break;
    }
    cell *= 2.0;
  }
  cluster_size_.assign(at(clusters_), 0);
  for (Index v = 0; v < nv; ++v) ++cluster_size_[at(cluster_[at(v)])];
}

void SelfCollisions::set_frames(const Points& xs0, const Points& ds, double edge_length, double thickness) {
  const Triangles& tris = triangles_;
  const auto nv = static_cast<Index>(xs0.rows());
  const auto nt = static_cast<Index>(tris.rows());
  // What a cluster's slack covers of a parting over this step: twice it,
  // or after a list that ended with two clusters parted eight times it up
  // to a tenth of the mean edge (twice the slack's floor: a list's boxes
  // grow by at most that much).
  const auto cover = [&](double parting) {
    return std::max(kPartingFactor * parting, std::min(parting_factor_ * parting, kPartedCap * edge_length));
  };
  for (int attempt = 0;; ++attempt) {
    const Index nc = clusters_;
    Points step = Points::Zero(nc, 3);  // each cluster's mean motion over the step
    for (Index v = 0; v < nv; ++v) step.row(cluster_[at(v)]) += ds.row(v);
    for (Index c = 0; c < nc; ++c) step.row(c) /= double(cluster_size_[at(c)]);
    margin_.resize(at(nv));
    for (Index v = 0; v < nv; ++v) {
      drift_[at(v)] = (ds.row(v) - step.row(cluster_[at(v)])).cwiseAbs().maxCoeff();
      margin_[at(v)] = std::max(0.1 * edge_length, 4.0 * drift_[at(v)]);
    }
    // Each cluster's hull (the triangles with a corner in it, at the build),
    // the largest margin of their corners, and which clusters share a
    // triangle with it.
    std::vector<Box3>& hull = hull_;
    std::vector<double>& largest = largest_;
    hull.assign(at(nc), Box3());
    largest.assign(at(nc), 0.0);
    std::vector<std::uint8_t> shares(at(nc) * at(nc), 0);
    for (Index t = 0; t < nt; ++t) {
      Box3 box;
      double m = 0.0;
      for (int k = 0; k < 3; ++k) {
        box.extend(Vec3(xs0.row(tris(t, k)).transpose()));
        m = std::max(m, margin_[at(tris(t, k))]);
      }
      for (int k = 0; k < 3; ++k) {
        const Index c = cluster_[at(tris(t, k))];
        hull[at(c)].extend(box);
        largest[at(c)] = std::max(largest[at(c)], m);
        for (int j = 0; j < 3; ++j) shares[at(c * nc + cluster_[at(tris(t, j))])] = 1;
      }
    }
    slack_.assign(at(nc), 0.05 * edge_length);
    for (Index a = 0; a < nc; ++a)
      for (Index b = a + 1; b < nc; ++b)
        if (hull[at(a)].intersects(hull[at(b)])) {
          const double g = cover((step.row(a) - step.row(b)).cwiseAbs().maxCoeff());
          slack_[at(a)] = std::max(slack_[at(a)], g);
          slack_[at(b)] = std::max(slack_[at(b)], g);
        }
    // Two clusters may part by g_a + g_b: the boxes are grown by each
    // vertex's cluster's slack, so pairs left off stay apart. Or, when
    // their hulls lie far apart, by what keeps any two primitives of theirs
    // more than the reporting distance apart: a primitive with a corner in a
    // lies in a's hull, its points move by at most √3 (their corners'
    // margins and the parting of their clusters), and the clusters of one
    // primitive's corners share a triangle with a, so their hulls meet and
    // they part from a by at most N_a = g_a + the largest slack of a
    // cluster sharing a triangle with a. Every two clusters are
    // allowed at least four times this step's parting (the list lasts
    // about four steps of the same motion, and this one for sure): where
    // the far allowance falls short their slacks are raised, which lowers
    // the far allowances of their neighbours' pairs (N), so this repeats; after a
    // few rounds the whole surface becomes one cluster (one frame, moving
    // with its mean, and no parting at all).
    allowance_.assign(at(nc) * at(nc), 0.0);
    for (int round = 0; round < kSlackRounds; ++round) {
      near_.assign(at(nc), 0.0);  // N_a
      for (Index a = 0; a < nc; ++a)
        for (Index b = 0; b < nc; ++b)
          if (shares[at(a * nc + b)]) near_[at(a)] = std::max(near_[at(a)], slack_[at(a)] + slack_[at(b)]);
      bool raised = false;
      for (Index a = 0; a < nc; ++a)
        for (Index b = a + 1; b < nc; ++b) {
          double& allowed = allowance_[at(a * nc + b)];
          allowed = allowance(a, b, thickness);
          const double parting = (step.row(a) - step.row(b)).cwiseAbs().maxCoeff();
          if (!(allowed >= 2.0 * cover(parting))) {
            slack_[at(a)] = std::max(slack_[at(a)], cover(parting));
            slack_[at(b)] = std::max(slack_[at(b)], cover(parting));
            raised = true;
          }
        }
      if (!raised) return;
    }
    if (attempt > 0 || nc == 1) return;  // one cluster has no parting
    std::fill(cluster_.begin(), cluster_.end(), 0);
    clusters_ = 1;
    cluster_size_.assign(1, nv);
  }
}

double SelfCollisions::allowance(Index a, Index b, double thickness) const {
  const double apart = hull_[at(a)].exteriorDistance(hull_[at(b)]);
  const double far = (apart - kReported * thickness) / std::sqrt(3.0) - near_[at(a)] - near_[at(b)] -
                     largest_[at(a)] - largest_[at(b)];
  return std::max(slack_[at(a)] + slack_[at(b)], far);
}

bool SelfCollisions::find_candidates(const Body& body, const Points& x0, const Points& d, const Points& xs0,
                                     const Points& ds, double thickness, SelfCollisionStats& stats,
                                     const std::vector<Index>* changed) {
  const Index nv = body.embedding.num_vertices();
  const Index nt = static_cast<Index>(body.surface_triangles.rows());
  const Triangles& tris = body.surface_triangles;

  // Is the list still good? (list_holds: each vertex near its cluster's
  // motion, the clusters near each other's.)
  drift_.resize(at(nv));
  if (stars_.update_mesh(body)) list_valid_ = false;
  ListCheck ended = ListCheck::holds;  // no list to keep
  if (list_valid_ && list_positions_.rows() == nv && same_bits(list_parents_, body.embedding.parent) &&
      cluster_.size() == at(nv)) {
    const ListCheck check = list_holds(xs0, ds, changed);
    if (check == ListCheck::holds) return false;  // (held_ set: the next check may measure the changed clusters only)
    if (check == ListCheck::vertices_past_margins && extend_list(body, ds, thickness, stats)) return true;
    ended = check;
  }
  held_ = false;  // a new list: its first check measures everything
  // Where clusters parted the last list, the next lets them part further.
  parting_factor_ = ended == ListCheck::clusters_parted ? kPartedFactor : kPartingFactor;
  // A new list, in frames that move with the surface nearby: the surface's
  // clusters (make_clusters), each with its mean motion. A vertex gets a
  // margin: a tenth of the mean edge, or four times this step's motion
  // relative to its cluster's, whichever is more. (Measured on the fine
  // fluid drop's first 16 frames, with one frame for the whole surface: a
  // quarter edge and twice the step cost 41 s in this stage; a tenth and
  // twice, 26; a tenth and four times, 21; a tenth and eight times, 36.)
  // A cluster gets a slack g: a twentieth of the mean edge, or twice this
  // step's largest motion of a cluster whose surface overlaps its own
  // relative to it, whichever is more; two clusters may part by g_a + g_b.
  // After a list that ended with two clusters parted, eight times that
  // motion up to a tenth of the mean edge (kPartedFactor): the armadillo
  // grate's lists mostly end so (34 of 36 in frames 72–75), and last about
  // half as long again; the fine drop's seldom do, and its lists stay
  // what they were (docs/benchmarks.md, session 38).
  double edge_length = 0.0;
  for (const auto& e : edges_) edge_length += (xs0.row(e[0]) - xs0.row(e[1])).norm();
  edge_length /= double(std::max<std::size_t>(1, edges_.size()));
  make_clusters(xs0);
  set_frames(xs0, ds, edge_length, thickness);
  // Each cluster's vertices, ascending (list_holds sums over them).
  cluster_offsets_.assign(at(clusters_) + 1, 0);
  for (Index v = 0; v < nv; ++v) ++cluster_offsets_[at(cluster_[at(v)]) + 1];
  for (Index c = 0; c < clusters_; ++c) cluster_offsets_[at(c) + 1] += cluster_offsets_[at(c)];
  cluster_vertices_.resize(at(nv));
  {
    std::vector<Index> next(cluster_offsets_.begin(), cluster_offsets_.end() - 1);
    for (Index v = 0; v < nv; ++v) cluster_vertices_[at(next[at(cluster_[at(v)])]++)] = v;
  }
  list_edge_length_ = edge_length;
  extensions_ = 0;
  reach_margin_.resize(at(nv));
  for (Index v = 0; v < nv; ++v) reach_margin_[at(v)] = margin_[at(v)] + slack_[at(cluster_[at(v)])];
  std::vector<Box3>&vb = vertex_boxes_, &tb = triangle_boxes_, &eb = edge_boxes_;
  vb.resize(at(nv));
  tb.resize(at(nt));
  eb.resize(edges_.size());
  for_each_index(nv, [&](Index v) { vb[at(v)] = vertex_box(xs0, v, reach_margin_[at(v)], thickness); });
  for_each_index(nt, [&](Index t) { tb[at(t)] = triangle_box(vb, tris, t); });
  for_each_index(static_cast<Index>(edges_.size()), [&](Index e) { eb[at(e)] = edge_box(vb, edges_[at(e)]); });
  list_positions_ = xs0;
  list_parents_ = body.embedding.parent;
  list_valid_ = true;
  ++stats.list_builds;

  // One broad phase over the triangles: a vertex's box lies in the box of
  // the triangle that owns it (its lowest), an edge's in its owner's, so
  // each primitive pair is found under the pair of its owners, once. A pair
  // is kept only if it can come within twice the thickness while the list
  // holds: two points of a pair part from where they were by at most √3 ×
  // (their vertices' largest margins and slacks) (the parting of their
  // clusters and the vertices' drift from them).
  // Triangles with all three corners in one element share that element as
  // their group: two of one group hold only pairs within it (left out below).
  std::vector<Index> element_of(at(nt));
  for_each_index(nt, [&](Index t) {
    const Index e = body.embedding.parent[at(tris(t, 0))];
    element_of[at(t)] =
        body.embedding.parent[at(tris(t, 1))] == e && body.embedding.parent[at(tris(t, 2))] == e ? e : -1;
  });
  // Triangles of one calm star's group hold pairs that cannot touch while
  // it stays calm (CalmStars): left out too, listed when it stops.
  stars_.update_surface(body, element_of);
  std::vector<Index> group = stars_.assign_groups(body, x0, d);
  const Index nn = body.num_nodes();
  for (Index t = 0; t < nt; ++t)
    if (group[at(t)] < 0 && element_of[at(t)] >= 0) group[at(t)] = nn + element_of[at(t)];
  const std::vector<std::array<Index, 2>> triangle_pairs = overlapping_pairs(tb, &group);
  list_groups_ = std::move(group);
  const std::size_t grain = 4096;
  std::vector<std::vector<Pair>> found((triangle_pairs.size() + grain - 1) / grain);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    auto& out = found[chunk];
    for (std::size_t i = chunk * grain; i < std::min(triangle_pairs.size(), (chunk + 1) * grain); ++i)
      expand(body, triangle_pairs[i][0], triangle_pairs[i][1], xs0, thickness, out);
  });
  candidates_.clear();
  for (const auto& f : found) candidates_.insert(candidates_.end(), f.begin(), f.end());
  clearance_.assign(candidates_.size(), -std::numeric_limits<double>::infinity());
  changed_at_.resize(candidates_.size());
  list_size_ = candidates_.size();
  index_valid_ = false;
  local_.assign(at(body.num_elements()), 0);
  return true;
}

bool SelfCollisions::extend_list(const Body& body, const Points& ds, double thickness, SelfCollisionStats& stats) {
  // A list that a few vertices outran (the armadillo grate's: a median of
  // 17 of 26k vertices, by a median of 1.17 times their margin) is kept:
  // each of them gets the margin a build would give it now, on top of its
  // drift since the build (d + max(a tenth of the mean edge, four times its
  // motion over this step relative to its cluster's)), its primitives'
  // boxes grow to match, and the pairs holding it are listed as a build
  // with those margins would list them: every pair the wider boxes reach
  // lies under a pair of triangles of which one holds such a vertex (the
  // owner of its vertex or edge, or its triangle), so only those are
  // paired with the others. Pairs without such a vertex keep their boxes
  // and their place on the list or off it. The clusters' frames stay; a
  // cluster whose largest margin grew has its far allowances taken again
  // (set_frames), and the list is built anew if its clusters have parted
  // past one of them, if too many vertices outran it, or after
  // kMaxExtensions extensions.
  constexpr int kMaxExtensions = 16;
  constexpr Index kMaxShare = 32;  // at most one vertex in this many
  const auto nv = static_cast<Index>(list_positions_.rows());
  const Triangles& tris = body.surface_triangles;
  const auto nt = static_cast<Index>(tris.rows());
  if (extensions_ >= kMaxExtensions) return false;
  std::vector<Index> over;
  for (Index v = 0; v < nv; ++v)
    if (!(drift_[at(v)] <= margin_[at(v)])) over.push_back(v);
  if (static_cast<Index>(over.size()) > nv / kMaxShare) return false;
  std::vector<std::uint8_t> widened(at(nv), 0);
  auto holds_widened = [&](const Pair& p) {
    return widened[at(p.vertices[0])] || widened[at(p.vertices[1])] || widened[at(p.vertices[2])] ||
           widened[at(p.vertices[3])];
  };
  for (const Index v : over) {
    const Index c = cluster_[at(v)];
    const double motion = (ds.row(v) - (cluster_motion_[1].row(c) - cluster_motion_[0].row(c))).cwiseAbs().maxCoeff();
    margin_[at(v)] = drift_[at(v)] + std::max(0.1 * list_edge_length_, 4.0 * motion);
    widened[at(v)] = 1;
  }
  // The clusters' largest margins (set_frames: per triangle, its corners'
  // largest, to each corner's cluster) and the far allowances they bound.
  const Index nc = clusters_;
  std::vector<Index> wide;  // the triangles with a widened corner, ascending
  std::vector<std::uint8_t> raised(at(nc), 0);
  for (Index t = 0; t < nt; ++t) {
    if (!(widened[at(tris(t, 0))] || widened[at(tris(t, 1))] || widened[at(tris(t, 2))])) continue;
    wide.push_back(t);
    const double m = std::max({margin_[at(tris(t, 0))], margin_[at(tris(t, 1))], margin_[at(tris(t, 2))]});
    for (int k = 0; k < 3; ++k) {
      const Index c = cluster_[at(tris(t, k))];
      if (m > largest_[at(c)]) largest_[at(c)] = m, raised[at(c)] = 1;
    }
  }
  for (Index a = 0; a < nc; ++a)
    for (Index b = a + 1; b < nc; ++b) {
      if (!raised[at(a)] && !raised[at(b)]) continue;
      double& allowed = allowance_[at(a * nc + b)];
      allowed = std::min(allowed, allowance(a, b, thickness));
      if (!((cluster_motion_[0].row(a) - cluster_motion_[0].row(b)).cwiseAbs().maxCoeff() <= allowed &&
            (cluster_motion_[1].row(a) - cluster_motion_[1].row(b)).cwiseAbs().maxCoeff() <= allowed))
        return false;  // parted past it: built anew
    }
  // The wider boxes, at the build's places, as find_candidates makes them.
  std::vector<Box3>&vb = vertex_boxes_, &tb = triangle_boxes_, &eb = edge_boxes_;
  for (const Index v : over) {
    reach_margin_[at(v)] = margin_[at(v)] + slack_[at(cluster_[at(v)])];
    vb[at(v)] = vertex_box(list_positions_, v, reach_margin_[at(v)], thickness);
  }
  for (const Index t : wide) tb[at(t)] = triangle_box(vb, tris, t);
  for (std::size_t e = 0; e < edges_.size(); ++e)
    if (widened[at(edges_[e][0])] || widened[at(edges_[e][1])]) eb[e] = edge_box(vb, edges_[e]);
  // Each triangle against the grown ones, found through their lower x
  // (sorted): a pair of two grown triangles once, under the higher.
  std::vector<std::uint8_t> is_wide(at(nt), 0);
  for (const Index t : wide) is_wide[at(t)] = 1;
  std::vector<Index> by_x = wide;
  std::stable_sort(by_x.begin(), by_x.end(), [&](Index a, Index b) { return tb[at(a)].min().x() < tb[at(b)].min().x(); });
  std::vector<double> lower(by_x.size());
  double widest = 0.0;
  for (std::size_t k = 0; k < by_x.size(); ++k) {
    lower[k] = tb[at(by_x[k])].min().x();
    widest = std::max(widest, tb[at(by_x[k])].sizes().x());
  }
  const Index nn = body.num_nodes();
  constexpr Index kChunk = 2048;
  std::vector<std::vector<Pair>> found(at((nt + kChunk - 1) / kChunk));
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    std::vector<Pair>& out = found[chunk];
    std::vector<Pair> expanded;
    std::vector<Index> partners;
    for (Index t = static_cast<Index>(chunk) * kChunk; t < std::min(nt, static_cast<Index>(chunk + 1) * kChunk); ++t) {
      const Box3& box = tb[at(t)];
      partners.clear();
      for (auto k = std::size_t(std::lower_bound(lower.begin(), lower.end(), box.min().x() - widest) - lower.begin());
           k < lower.size() && lower[k] <= box.max().x(); ++k) {
        const Index g = by_x[k];
        if (g == t || (is_wide[at(t)] && g > t) || !tb[at(g)].intersects(box)) continue;
        const Index group = list_groups_[at(g)];
        if (group >= 0 && group == list_groups_[at(t)] && (group >= nn || !stars_.returned(g, t))) continue;
        partners.push_back(g);
      }
      std::sort(partners.begin(), partners.end());  // one order, whatever the boxes' places
      for (const Index g : partners) {
        expanded.clear();
        expand(body, std::min(g, t), std::max(g, t), list_positions_, thickness, expanded);
        for (const Pair& p : expanded)
          if (holds_widened(p)) out.push_back(p);
      }
    }
  });
  // Those listed already (found before by a build or a calm group's
  // return) stay where they are.
  auto key = [](const Pair& p) { return std::tie(p.kind, p.vertices); };
  std::vector<std::size_t> listed;
  for (std::size_t i = 0; i < list_size_; ++i)
    if (holds_widened(candidates_[i])) listed.push_back(i);
  std::sort(listed.begin(), listed.end(),
            [&](std::size_t a, std::size_t b) { return key(candidates_[a]) < key(candidates_[b]); });
  drop_local_pairs();  // appended again after (add_local_pairs)
  std::vector<Pair> added;
  for (const auto& f : found)
    for (const Pair& p : f) {
      const auto at_or_after = std::lower_bound(listed.begin(), listed.end(), p, [&](std::size_t i, const Pair& q) {
        return key(candidates_[i]) < key(q);
      });
      if (at_or_after == listed.end() || key(candidates_[*at_or_after]) != key(p)) added.push_back(p);
    }
  candidates_.insert(candidates_.end(), added.begin(), added.end());
  list_size_ = candidates_.size();
  clearance_.resize(list_size_, -std::numeric_limits<double>::infinity());
  changed_at_.resize(list_size_);
  ++extensions_;
  ++stats.list_extensions;
  return true;
}

void SelfCollisions::expand(const Body& body, Index A0, Index B0, const Points& xs, double thickness,
                            std::vector<Pair>& out) const {
  const Triangles& tris = body.surface_triangles;
  const std::vector<Box3>&vb = vertex_boxes_, &tb = triangle_boxes_, &eb = edge_boxes_;
  // Pairs with all four vertices in one element are left out (a step
  // moves them by that element's affine map): add_local_pairs lists them
  // for the steps in which the element does not stay positively oriented.
  auto keep = [&](PairKind kind, const std::array<Index, 4>& v, double& distance) {
    return !one_element(body, v) && keep_pair(kind, v, xs, thickness, distance);
  };
  for (std::size_t side = 0; side < 2; ++side) {  // the vertices each owns against the other
    const Index A = side == 0 ? A0 : B0, B = side == 0 ? B0 : A0;
    const Owned& own = owned_[at(A)];
    const auto tri = tris.row(B);
    const Box3& box = tb[at(B)];
    for (std::uint8_t k = 0; k < own.num_vertices; ++k) {
      const Index v = own.vertices[k];
      if (tri[0] == v || tri[1] == v || tri[2] == v || !vb[at(v)].intersects(box)) continue;
      const std::array<Index, 4> vertices{v, tri[0], tri[1], tri[2]};
      double distance = 0.0;
      if (keep(PairKind::vertex_triangle, vertices, distance))
        out.push_back({static_cast<std::uint8_t>(PairKind::vertex_triangle), vertices, distance});
    }
  }
  const Owned &own_a = owned_[at(A0)], &own_b = owned_[at(B0)];
  for (std::uint8_t i = 0; i < own_a.num_edges; ++i) {  // the edges each owns against the other's
    const Index e = own_a.edges[i];
    const auto& ea = edges_[at(e)];
    for (std::uint8_t j = 0; j < own_b.num_edges; ++j) {
      const Index f = own_b.edges[j];
      const auto& eb2 = edges_[at(f)];
      if (ea[0] == eb2[0] || ea[0] == eb2[1] || ea[1] == eb2[0] || ea[1] == eb2[1]) continue;
      if (!eb[at(e)].intersects(eb[at(f)])) continue;
      const std::array<Index, 4> vertices{ea[0], ea[1], eb2[0], eb2[1]};
      double distance = 0.0;
      if (keep(PairKind::edge_edge, vertices, distance))
        out.push_back({static_cast<std::uint8_t>(PairKind::edge_edge), vertices, distance});
    }
  }
}

bool SelfCollisions::list_unsafe_groups(const Body& body, const Points& x0, const Points& d,
                                        const std::vector<std::uint8_t>* moved, double thickness,
                                        const std::vector<Index>* moved_elements) {
  const auto unsafe = stars_.newly_unsafe(body, x0, d, moved, triangle_boxes_, moved_elements);
  if (unsafe.empty()) return false;
  std::vector<Pair> added;
  // Measured where the list was built, as the list's own pairs are.
  for (const auto& p : unsafe) expand(body, p[0], p[1], list_positions_, thickness, added);
  drop_local_pairs();
  candidates_.insert(candidates_.end(), added.begin(), added.end());
  list_size_ = candidates_.size();
  clearance_.resize(list_size_, -std::numeric_limits<double>::infinity());
  changed_at_.resize(list_size_);
  return true;
}

double SelfCollisions::relative_motion(const Points& xs0, const Points& ds, const std::array<Index, 4>& v) const {
  const Eigen::RowVector3d drift0 = xs0.row(v[0]) - list_positions_.row(v[0]);
  double largest = 0.0;
  for (std::size_t k = 1; k < 4; ++k) {
    const Eigen::RowVector3d drift = xs0.row(v[k]) - list_positions_.row(v[k]) - drift0;
    largest = std::max(largest, drift.norm() + (ds.row(v[k]) - ds.row(v[0])).norm());
  }
  return largest;
}

bool SelfCollisions::keep_pair(PairKind kind, const std::array<Index, 4>& v, const Points& xs0, double thickness,
                               double& distance) const {
  if (groups_ && within(v) && !groups_->self_pairs[at(group(v))]) return false;  // that body's self-collisions are off
  distance = ccd::closest(kind, gather(xs0, v)).distance;
  // A pair within one cluster moves apart only by its vertices' drift from
  // the cluster's motion; one across clusters by their parting too.
  return distance <= kReported * thickness + reach(kind, v, same_cluster(v) ? margin_ : reach_margin_);
}

bool SelfCollisions::index_elements(const Body& body) {
  const Index ne = body.num_elements();
  const NodeIncidence& incidence = body.incidence;
  if (incidence.offsets.size() != at(body.num_nodes()) + 1 || incidence.corners.size() != 4 * at(ne)) return false;
  if (element_vertex_offsets_.size() != at(ne) + 1 || !same_bits(indexed_parents_, body.embedding.parent)) {
    indexed_parents_ = body.embedding.parent;
    index_element_vertices(body.embedding.parent, ne, element_vertex_offsets_, element_vertices_);
  }
  if (element_stamp_.size() != at(ne)) {
    element_stamp_.assign(at(ne), 0);
    stamp_ = 0;
  }
  return true;
}

void SelfCollisions::drop_local_pairs() {
  candidates_.resize(list_size_);
  clearance_.resize(list_size_);
  changed_at_.resize(list_size_);
  std::fill(local_.begin(), local_.end(), 0);
}

void SelfCollisions::update_orientations(const Body& body, const Points& x0, const Points& d,
                                         const std::vector<std::uint8_t>* moved,
                                         const std::vector<Index>* moved_elements) {
  if (affine_.size() != at(body.num_elements())) {
    affine_.resize(at(body.num_elements()));
    moved = nullptr;
    moved_elements = nullptr;
  }
  if (moved && moved_elements) {  // the elements with a moved node: the others are as they were
    for_each_index(
        static_cast<Index>(moved_elements->size()),
        [&](Index i) {
          const Index e = (*moved_elements)[at(i)];
          affine_[at(e)] = stays_positive(body, x0, d, e) ? 1 : 0;
        },
        64);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<Index>(0, body.num_elements(), kParallelGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      for (Index e = r.begin(); e != r.end(); ++e) {
                        if (moved && !((*moved)[at(body.tets(e, 0))] || (*moved)[at(body.tets(e, 1))] ||
                                       (*moved)[at(body.tets(e, 2))] || (*moved)[at(body.tets(e, 3))]))
                          continue;  // its nodes did not move: as it was
                        affine_[at(e)] = stays_positive(body, x0, d, e) ? 1 : 0;
                      }
                    });
}

void SelfCollisions::add_local_pairs(const Body& body, const Points& xs0, const Points& ds, double thickness) {
  const Index ne = body.num_elements();
  const auto& parent = body.embedding.parent;
  if (local_.size() != at(ne)) local_.assign(at(ne), 0);
  std::vector<Index> slot(at(ne), -1);
  Index slots = 0;
  for (Index e = 0; e < ne; ++e)
    if (!affine_[at(e)] && !local_[at(e)]) {
      local_[at(e)] = 1;
      slot[at(e)] = slots++;
    }
  if (slots == 0) return;
  // The element's own vertices, triangles and edges (all corners in it).
  std::vector<std::vector<Index>> vertices(at(slots)), triangles(at(slots)), edges(at(slots));
  for (Index v = 0; v < body.embedding.num_vertices(); ++v)
    if (slot[at(parent[at(v)])] >= 0) vertices[at(slot[at(parent[at(v)])])].push_back(v);
  const Triangles& tris = body.surface_triangles;
  for (Index t = 0; t < static_cast<Index>(tris.rows()); ++t) {
    const Index e = parent[at(tris(t, 0))];
    if (slot[at(e)] >= 0 && parent[at(tris(t, 1))] == e && parent[at(tris(t, 2))] == e)
      triangles[at(slot[at(e)])].push_back(t);
  }
  for (std::size_t i = 0; i < edges_.size(); ++i) {
    const Index e = parent[at(edges_[i][0])];
    if (slot[at(e)] >= 0 && parent[at(edges_[i][1])] == e) edges[at(slot[at(e)])].push_back(static_cast<Index>(i));
  }
  // Listed for this step only, measured at its start: a pair whose gap
  // its own motion over the step cannot close (twice the largest motion of
  // a vertex relative to its first) is left off.
  auto keep_local = [&](PairKind kind, const std::array<Index, 4>& v, double& distance) {
    if (groups_ && within(v) && !groups_->self_pairs[at(group(v))]) return false;
    distance = ccd::closest(kind, gather(xs0, v)).distance;
    double moves = 0.0;
    for (std::size_t k = 1; k < 4; ++k) moves = std::max(moves, (ds.row(v[k]) - ds.row(v[0])).norm());
    return distance <= kReported * thickness + 2.0 * moves;
  };
  for (Index k = 0; k < slots; ++k) {
    for (const Index v : vertices[at(k)])
      for (const Index t : triangles[at(k)]) {
        if (tris(t, 0) == v || tris(t, 1) == v || tris(t, 2) == v) continue;
        const std::array<Index, 4> pv{v, tris(t, 0), tris(t, 1), tris(t, 2)};
        double distance = 0.0;
        if (keep_local(PairKind::vertex_triangle, pv, distance))
          candidates_.push_back({static_cast<std::uint8_t>(PairKind::vertex_triangle), pv, distance});
      }
    const auto& own = edges[at(k)];
    for (std::size_t i = 0; i < own.size(); ++i)
      for (std::size_t j = i + 1; j < own.size(); ++j) {
        const auto &a = edges_[at(own[i])], &b = edges_[at(own[j])];
        if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
        const std::array<Index, 4> pv{a[0], a[1], b[0], b[1]};
        double distance = 0.0;
        if (keep_local(PairKind::edge_edge, pv, distance))
          candidates_.push_back({static_cast<std::uint8_t>(PairKind::edge_edge), pv, distance});
      }
  }
  clearance_.resize(candidates_.size(), -std::numeric_limits<double>::infinity());
  changed_at_.resize(candidates_.size());
}

std::vector<SelfCollisions::Impact> SelfCollisions::detect(const Body& body, const Points& xs0, const Points& ds,
                                                           double thickness, const std::vector<Index>* zone,
                                                           const std::vector<std::uint8_t>* only,
                                                           const std::vector<Index>* changed,
                                                           SelfCollisionStats& stats) {
  // How far each vertex's displacement has changed since the step's first
  // detection, summed over detections (a bound on its change since any of them).
  const Index nv = body.embedding.num_vertices();
  auto track = [&](Index v) {
    changed_[at(v)] += (ds.row(v) - ds_last_.row(v)).cwiseAbs().maxCoeff();
    ds_last_.row(v) = ds.row(v);
  };
  if (changed_.size() != at(nv) || ds_last_.rows() != nv) {
    changed_.assign(at(nv), 0.0);
    ds_last_ = ds;
  } else if (changed) {  // the others' rows: ds − ds_last = 0, nothing to add
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, changed->size(), 4 * kParallelGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) track((*changed)[i]);
                      });
  } else {
    tbb::parallel_for(tbb::blocked_range<Index>(0, nv, 4 * kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
      for (Index v = r.begin(); v != r.end(); ++v) track(v);
    });
  }
  // A round's detection measures the pairs of its flagged vertices, found
  // through the list's index: the same pairs as a pass over the list that
  // skips the others, in the same (ascending) order.
  const bool selective = only != nullptr && changed != nullptr && select_pairs(*changed);
  const std::size_t count = selective ? selected_.size() : candidates_.size();
  // Fixed runs of the list, each collecting its own findings in list order:
  // no pass over the whole list after the parallel one.
  constexpr std::size_t kDetectChunk = 1024;
  const std::size_t num_chunks = (count + kDetectChunk - 1) / kDetectChunk;
  if (found_.size() < num_chunks) found_.resize(num_chunks);
  tbb::parallel_for(std::size_t{0}, num_chunks, [&](std::size_t chunk) {
                      Found& found = found_[chunk];
                      found.impacts.clear();
                      found.close.clear();
                      found.measured = found.touching = 0;
                      const std::size_t end = std::min(count, (chunk + 1) * kDetectChunk);
                      for (std::size_t read = chunk * kDetectChunk; read != end; ++read) {
                        const std::size_t i = selective ? selected_[read] : read;
                        const Pair& p = candidates_[i];
                        if (only && !((*only)[at(p.vertices[0])] || (*only)[at(p.vertices[1])] ||
                                      (*only)[at(p.vertices[2])] || (*only)[at(p.vertices[3])]))
                          continue;
                        // A body turning an inverted element back waits, alone.
                        if (!waiting_.empty() && within(p) && waiting_[at(group(p.vertices))]) continue;
                        // Still as far apart as the build found them, less what the
                        // vertices have drifted since in their cluster's frame (one
                        // frame for all four): beyond twice the thickness all step,
                        // where continuous detection reports nothing. (An element's
                        // own pairs, appended for this step, were measured at its start.)
                        if (i < list_size_ && same_cluster(p.vertices) &&
                            p.distance - reach(static_cast<PairKind>(p.kind), p.vertices, drift_) > kReported * thickness)
                          continue;
                        // The same from the pair's own motion: a point of it is
                        // Σ c_k x_k with Σ c_k = 0 and Σ |c_k| = 2 over its vertices,
                        // so its gap shrinks by at most twice the largest motion of a
                        // vertex relative to its first, since the build and over the
                        // step (neighbours on a sheet that flows move nearly alike).
                        if (p.distance - 2.0 * relative_motion(xs0, ds, p.vertices) > kReported * thickness) continue;
                        if (zone) {
                          const Index root = (*zone)[at(body.tets(body.embedding.parent[at(p.vertices[0])], 0))];
                          bool inside = true;
                          for (const Index s : p.vertices)
                            for (int k = 0; k < 4 && inside; ++k)
                              inside = (*zone)[at(body.tets(body.embedding.parent[at(s)], k))] == root;
                          if (inside) continue;  // moved by one affine map that shrinks no distance
                        }
                        // All four vertices in one element that stays positively
                        // oriented all step: they move by one invertible affine map
                        // of the step's start, which passes nothing through anything.
                        if (one_element(body, p.vertices) && affine_[at(body.embedding.parent[at(p.vertices[0])])])
                          continue;
                        const auto kind = static_cast<PairKind>(p.kind);
                        if (clearance_[i] > 0.0) {  // measured this step without impact: moved enough since?
                          std::array<double, 4> moved{};
                          for (std::size_t k = 0; k < 4; ++k) moved[k] = changed_[at(p.vertices[k])] - changed_at_[i][k];
                          const std::size_t first_side = kind == PairKind::vertex_triangle ? 1 : 2;
                          double a = 0.0, b = 0.0;
                          for (std::size_t k = 0; k < 4; ++k) (k < first_side ? a : b) = std::max(k < first_side ? a : b, moved[k]);
                          if (std::sqrt(3.0) * (a + b) < clearance_[i]) continue;  // still no impact: not measured
                        }
                        const ccd::Points4 x = gather(xs0, p.vertices);
                        const double start = ccd::closest(kind, x).distance;
                        ++found.measured;
                        if (start == 0.0) {  // touching or crossing already: left alone
                          if (!zone) ++found.touching;
                          continue;
                        }
                        if (start < thickness) found.close.emplace_back(i, start);
                        const double keep = kept_apart(start, thickness);
                        double clearance = 0.0;
                        if (const auto t = ccd::time_of_impact(kind, x, gather(ds, p.vertices), keep, &clearance))
                          found.impacts.push_back({i, *t, start});
                        clearance_[i] = clearance;
                        for (std::size_t k = 0; k < 4; ++k) changed_at_[i][k] = changed_[at(p.vertices[k])];
                      }
                    });
  std::vector<Impact> impacts;
  close_.clear();
  for (std::size_t chunk = 0; chunk < num_chunks; ++chunk) {
    const Found& found = found_[chunk];
    stats.candidates += found.measured;
    stats.touching_at_start += found.touching;
    impacts.insert(impacts.end(), found.impacts.begin(), found.impacts.end());
    close_.insert(close_.end(), found.close.begin(), found.close.end());
  }
  // One order for the impulses, whatever the list's order: by pair.
  std::sort(impacts.begin(), impacts.end(), [&](const Impact& a, const Impact& b) {
    const Pair &p = candidates_[a.pair], &q = candidates_[b.pair];
    return std::tie(p.kind, p.vertices) < std::tie(q.kind, q.vertices);
  });
  return impacts;
}

bool SelfCollisions::select_pairs(const std::vector<Index>& changed) {
  if (!index_valid_ || indexed_ > list_size_ || list_size_ - indexed_ > indexed_ / 4) {
    // A counting sort of the list's pairs by vertex, each pair under each
    // of its four vertices, ascending within a vertex.
    const auto nv = static_cast<std::size_t>(list_positions_.rows());
    indexed_ = list_size_;
    vertex_pair_offsets_.assign(nv + 1, 0);
    for (std::size_t i = 0; i < indexed_; ++i)
      for (const Index v : candidates_[i].vertices) ++vertex_pair_offsets_[at(v) + 1];
    for (std::size_t v = 0; v < nv; ++v) vertex_pair_offsets_[v + 1] += vertex_pair_offsets_[v];
    vertex_pairs_.resize(vertex_pair_offsets_[nv]);
    std::vector<std::size_t> next(vertex_pair_offsets_.begin(), vertex_pair_offsets_.end() - 1);
    for (std::size_t i = 0; i < indexed_; ++i)
      for (const Index v : candidates_[i].vertices) vertex_pairs_[next[at(v)]++] = static_cast<std::uint32_t>(i);
    pair_marked_.assign((indexed_ + 63) / 64, 0);
    index_valid_ = true;
  }
  std::size_t reached = 0;
  for (const Index v : changed) reached += vertex_pair_offsets_[at(v) + 1] - vertex_pair_offsets_[at(v)];
  if (reached > indexed_ / 2) return false;  // a pass over the list is cheaper
  // The pairs reached, a bit each (set in parallel: a set is the same
  // whatever the order), then read off in ascending order, cleared as read:
  // the order of a sort, at a pass over a bit per pair (the armadillo
  // grate's rounds reach thousands of pairs, and sorting them was a fifth
  // of the stage's serial time).
  selected_.clear();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, changed.size(), 64),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t c = r.begin(); c != r.end(); ++c) {
                        const Index v = changed[c];
                        for (std::size_t j = vertex_pair_offsets_[at(v)]; j != vertex_pair_offsets_[at(v) + 1]; ++j) {
                          const std::uint32_t i = vertex_pairs_[j];
                          std::atomic_ref<std::uint64_t>(pair_marked_[i / 64])
                              .fetch_or(std::uint64_t{1} << (i % 64), std::memory_order_relaxed);
                        }
                      }
                    });
  for (std::size_t word = 0; word < pair_marked_.size(); ++word)
    if (pair_marked_[word] != 0)
      for (std::uint64_t bits = std::exchange(pair_marked_[word], 0); bits != 0; bits &= bits - 1)
        selected_.push_back(64 * word + static_cast<std::size_t>(std::countr_zero(bits)));
  for (std::size_t i = indexed_; i < candidates_.size(); ++i) selected_.push_back(i);  // checked against `only` as read
  return true;
}

SelfCollisionStats SelfCollisions::resolve(const Body& body, const Points& x0, Points& d,
                                           const std::vector<std::uint8_t>& fixed,
                                           const SelfCollisionParameters& parameters) {
  SelfCollisionStats stats;
  if (body.embedding.num_vertices() == 0 || body.surface_triangles.rows() == 0) return stats;
  const double thickness = parameters.thickness;
  if (update_edges(body.surface_triangles)) list_valid_ = false;
  // A body with an element inverted at the start or the end of the step is
  // turning inside-out material back: that passes the surface through
  // itself (a body mirrored inside out turns right side out), so the stage
  // waits, as a re-mesh does, until no element is inverted.
  std::vector<std::uint8_t> inverted(at(body.num_elements()), 0);
  tbb::parallel_for(tbb::blocked_range<Index>(0, body.num_elements(), kParallelGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      for (Index e = r.begin(); e != r.end(); ++e) {
                        auto volume = [&](double t) {
                          Eigen::Matrix3d D;
                          const Index n0 = body.tets(e, 0);
                          const Eigen::RowVector3d p0 = x0.row(n0) + t * d.row(n0);
                          for (int k = 1; k < 4; ++k) {
                            const Index n = body.tets(e, k);
                            D.col(k - 1) = (x0.row(n) + t * d.row(n) - p0).transpose();
                          }
                          return D.determinant();
                        };
                        inverted[at(e)] = (volume(0.0) <= 0.0 || volume(1.0) <= 0.0) ? 1 : 0;
                      }
                    });
  if (groups_) {  // per body: only the body with an inverted element waits
    waiting_.assign(groups_->self_pairs.size(), 0);
    for (Index e = 0; e < body.num_elements(); ++e)
      if (inverted[at(e)]) waiting_[at(groups_->element_group[at(e)])] = 1;
    stats.waited = static_cast<Index>(std::count(waiting_.begin(), waiting_.end(), 1));
  } else if (std::find(inverted.begin(), inverted.end(), 1) != inverted.end()) {
    stats.waited = 1;
    return stats;
  }
  const Points xs0 = body.embedding.surface_positions(body.tets, x0);
  Points ds = body.embedding.surface_positions(body.tets, d);  // W d: the surface's displacements
  drop_local_pairs();  // the last step's
  find_candidates(body, x0, d, xs0, ds, thickness, stats);
  update_orientations(body, x0, d);
  list_unsafe_groups(body, x0, d, nullptr, thickness);
  add_local_pairs(body, xs0, ds, thickness);
  stats.listed += static_cast<std::int64_t>(candidates_.size());
  // A new step: every pair is measured at its first detection.
  std::fill(clearance_.begin(), clearance_.end(), -std::numeric_limits<double>::infinity());
  ds_last_.resize(0, 3);
  std::vector<Impact> impacts = detect(body, xs0, ds, thickness, nullptr, nullptr, nullptr, stats);

  // Proximity: pairs closer than the thickness at the start are pushed
  // apart by a tenth of what is missing per step.
  std::vector<std::pair<std::size_t, double>> close = close_;  // the first detection's
  std::sort(close.begin(), close.end(), [&](const auto& a, const auto& b) {  // one order, whatever the list's
    return std::tie(candidates_[a.first].kind, candidates_[a.first].vertices) <
           std::tie(candidates_[b.first].kind, candidates_[b.first].vertices);
  });
  const Points d_start = close.empty() ? Points() : d;
  for (const auto& [i, start] : close) {
    const Pair& p = candidates_[i];
    const auto kind = static_cast<PairKind>(p.kind);
    if (push_apart(body, approach_of(body, kind, p.vertices, gather(xs0, p.vertices)), d, fixed,
                   parameters.target_scale * kRepulsionFraction * (thickness - start), friction(p, parameters.friction)))
      ++stats.repulsions;
  }
  // Detection again after impulses. With `only` (per surface vertex), and
  // the candidate list kept, only pairs with a flagged vertex are measured:
  // the others' vertices stand and move as when they were measured.
  // `moved` (per node) flags the nodes moved since the last detection,
  // `changed` (ascending) the surface vertices of their elements, `only`'s
  // flagged ones: only their displacements are computed again.
  // The elements with a node moved since the last detection, when they are
  // few (flag_moved below).
  std::vector<Index> moved_elements;
  bool few_moved = false;
  auto redetect = [&](const std::vector<Index>* zone, const std::vector<std::uint8_t>* only,
                      const std::vector<std::uint8_t>* moved, const std::vector<Index>* changed) {
    if (changed)
      body.embedding.update_surface_positions(body.tets, d, *changed, ds);
    else
      ds = body.embedding.surface_positions(body.tets, d);
    const bool rebuilt = find_candidates(body, x0, d, xs0, ds, thickness, stats, changed);
    // Impulses and rigid zones move nodes: an element may no longer stay
    // positive, a star no longer calm (their pairs are measured from now
    // on; an element's vertices are among the flagged ones, as a node of it
    // moved).
    const std::vector<Index>* elements = few_moved && !rebuilt ? &moved_elements : nullptr;
    update_orientations(body, x0, d, rebuilt ? nullptr : moved, elements);
    const bool added = list_unsafe_groups(body, x0, d, rebuilt ? nullptr : moved, thickness, elements);
    add_local_pairs(body, xs0, ds, thickness);
    return detect(body, xs0, ds, thickness, zone, rebuilt || added ? nullptr : only, changed, stats);
  };
  // Measured again after impulses: pairs of a vertex whose element has a
  // node that moved since `d_before`, and those of `impacts` (an impulse
  // that could not act leaves its pair): `moved` per node, `again` per
  // surface vertex, `flagged` its vertices, ascending.
  // `again` is 1 exactly at `flagged`'s vertices. With few nodes moved (a
  // round's impulses: a few dozen), their elements (`moved_elements`) and
  // those elements' vertices are found through the incidence and an index
  // of each element's vertices, and only the last flagged ones cleared;
  // otherwise every vertex is looked at. The same flags either way.
  std::vector<std::uint8_t> moved(at(body.num_nodes())), again(at(body.embedding.num_vertices()));
  std::vector<Index> flagged;
  auto flag_moved = [&](const Points& d_before, const std::vector<Impact>& impacts_before) {
    const Index nn = body.num_nodes(), nv = body.embedding.num_vertices();
    for_each_index(nn, [&](Index n) { moved[at(n)] = d.row(n) != d_before.row(n) ? 1 : 0; });
    moved_nodes_.clear();
    for (Index n = 0; n < nn; ++n)
      if (moved[at(n)]) moved_nodes_.push_back(n);
    few_moved = (recheck_ == Recheck::what_moved || (recheck_ == Recheck::what_moved_when_few &&
                                                     static_cast<Index>(moved_nodes_.size()) * kFewMoved <= nn)) &&
                index_elements(body);
    if (few_moved) {
      if (++stamp_ == 0) {  // wrapped: no element may keep an old stamp
        std::fill(element_stamp_.begin(), element_stamp_.end(), 0);
        stamp_ = 1;
      }
      moved_elements.clear();
      for (const Index n : moved_nodes_)
        for (Index c = body.incidence.offsets[at(n)]; c < body.incidence.offsets[at(n) + 1]; ++c) {
          const Index e = body.incidence.corners[at(c)] / 4;
          if (element_stamp_[at(e)] != stamp_) {
            element_stamp_[at(e)] = stamp_;
            moved_elements.push_back(e);
          }
        }
      for (const Index v : flagged) again[at(v)] = 0;
      vertex_bits_.assign((at(nv) + 63) / 64, 0);
      auto flag = [&](Index v) {
        again[at(v)] = 1;
        vertex_bits_[at(v) / 64] |= std::uint64_t{1} << (at(v) % 64);
      };
      for (const Index e : moved_elements)
        for (Index i = element_vertex_offsets_[at(e)]; i < element_vertex_offsets_[at(e) + 1]; ++i)
          flag(element_vertices_[at(i)]);
      for (const Impact& impact : impacts_before)
        for (const Index v : candidates_[impact.pair].vertices) flag(v);
      flagged.clear();
      for (std::size_t word = 0; word < vertex_bits_.size(); ++word)
        for (std::uint64_t bits = vertex_bits_[word]; bits != 0; bits &= bits - 1)
          flagged.push_back(static_cast<Index>(64 * word + static_cast<std::size_t>(std::countr_zero(bits))));
      return;
    }
    for_each_index(nv, [&](Index v) {
      const Index e = body.embedding.parent[at(v)];
      again[at(v)] = moved[at(body.tets(e, 0))] | moved[at(body.tets(e, 1))] | moved[at(body.tets(e, 2))] |
                     moved[at(body.tets(e, 3))];
    });
    for (const Impact& impact : impacts_before)
      for (const Index v : candidates_[impact.pair].vertices) again[at(v)] = 1;
    flagged.clear();
    for (Index v = 0; v < nv; ++v)
      if (again[at(v)]) flagged.push_back(v);
  };
  if (stats.repulsions > 0) {
    flag_moved(d_start, impacts);
    impacts = redetect(nullptr, &again, &moved, &flagged);
  }

  // Impulse rounds: each impact stops the pair's approach where CCD found it.
  // How the round moved each impact's pair (all its impulses together), in
  // impact order.
  struct Progress {
    std::pair<std::uint8_t, std::array<Index, 4>> pair;
    double gained;  // the share of its lack the round gave it
    double lack;    // what it lacks after the round
    double spare;   // how much its normal displacement may fall short of the target unreported
  };
  std::vector<Progress> progress;
  const double target = parameters.target_scale * kSeparationFraction * thickness;
  for (int round = 0; round < parameters.max_rounds && !impacts.empty(); ++round) {
    ++stats.rounds;
    const Points d_before = d;
    std::vector<std::optional<Approach>> approaches(impacts.size());
    for (std::size_t i = 0; i < impacts.size(); ++i) {
      const Pair& p = candidates_[impacts[i].pair];
      ccd::Points4 x = gather(xs0, p.vertices);
      const ccd::Points4 dx = gather(ds, p.vertices);
      for (std::size_t k = 0; k < 4; ++k) x[k] += impacts[i].toi * dx[k];
      approaches[i] = approach_of(body, static_cast<PairKind>(p.kind), p.vertices, x);
      if (push_apart(body, approaches[i], d, fixed, target, friction(p, parameters.friction))) ++stats.impacts;
    }
    progress.clear();
    for (std::size_t i = 0; i < impacts.size(); ++i) {
      const Pair& p = candidates_[impacts[i].pair];
      // A pair that starts at `start` is reported when it comes within
      // `keep` (detect): it may approach by start − keep unreported.
      const double start = impacts[i].start;
      const double keep = kept_apart(start, thickness);
      Progress q{{p.kind, p.vertices}, 0.0, 0.0, target + (start - keep)};
      if (approaches[i]) {
        const double before = approaches[i]->along(d_before), after = approaches[i]->along(d);
        if (target - before > 0.0) q.gained = (after - before) / (target - before);
        q.lack = target - after;
      }
      progress.push_back(q);
    }
    flag_moved(d_before, impacts);
    impacts = redetect(nullptr, &again, &moved, &flagged);
    // A round gives each pair a share g of what it lacks; R more rounds at
    // that rate leave (1 − g)^R of what it lacks now. The pair stops being
    // reported once its normal displacement falls short of the target by
    // no more than its spare (the approach its start distance allows). When
    // every impact left is a pair of this round that the rounds left would
    // not bring within its spare, more rounds only put off the fail-safe:
    // it takes them now, after one detection rather than R. Pairs of points
    // hung on shared nodes, whose impulses nearly cancel, are cut to a few
    // percent a round (push_apart), and on a fold sitting at the
    // thickness they meet this every step. (A prediction, not a bound: the
    // rounds resolve what they can, the rigid zones the rest, and the step
    // ends with no crossing either way.)
    const int left = parameters.max_rounds - round - 1;
    const bool stalled = std::all_of(impacts.begin(), impacts.end(), [&](const Impact& impact) {
      const Pair& p = candidates_[impact.pair];
      const std::pair<std::uint8_t, std::array<Index, 4>> key{p.kind, p.vertices};
      const auto it = std::lower_bound(progress.begin(), progress.end(), key,
                                       [](const Progress& a, const auto& b) { return a.pair < b; });
      return it != progress.end() && it->pair == key &&
             std::pow(1.0 - std::clamp(it->gained, 0.0, 1.0), left) * it->lack > it->spare;
    });
    if (stalled) break;
  }
  if (impacts.empty()) return stats;

  // Fail-safe: rigid impact zones, merged until no pair across zones collides.
  const Index nn = body.num_nodes();
  UnionFind zones(nn);
  std::vector<std::uint8_t> zoned(at(nn), 0);
  std::vector<Index> root(at(nn));
  auto rigidify_zones = [&] {
    std::map<Index, std::vector<Index>> members;  // ordered by root: deterministic
    for (Index n = 0; n < nn; ++n) {
      root[at(n)] = zones.find(n);
      if (zoned[at(n)]) members[root[at(n)]].push_back(n);
    }
    for (const auto& [r, nodes] : members) rigidify(body, x0, d, fixed, nodes);
    stats.zone_nodes = static_cast<Index>(std::count(zoned.begin(), zoned.end(), 1));
  };
  for (int round = 0; round < kMaxZoneRounds && !impacts.empty(); ++round) {
    ++stats.zone_rounds;
    for (const Impact& impact : impacts) {
      const Pair& p = candidates_[impact.pair];
      const Index first = body.tets(body.embedding.parent[at(p.vertices[0])], 0);
      for (const Index s : p.vertices)
        for (int k = 0; k < 4; ++k) {
          const Index node = body.tets(body.embedding.parent[at(s)], k);
          zones.unite(first, node);
          zoned[at(node)] = 1;
        }
    }
    const Points d_before = d;
    rigidify_zones();
    flag_moved(d_before, impacts);
    impacts = redetect(&root, &again, &moved, &flagged);
  }
  if (!impacts.empty()) {  // the last resort: the whole body as one zone
    for (Index n = 1; n < nn; ++n) zones.unite(0, n);
    std::fill(zoned.begin(), zoned.end(), 1);
    rigidify_zones();
  }
  return stats;
}

SelfCollisionStats SelfCollisions::resolve_step(Body& body, const Points& x0, double dt,
                                                const std::vector<std::uint8_t>& fixed,
                                                const SelfCollisionParameters& parameters) {
  const Points before = body.positions - x0;
  Points d = before;
  SelfCollisionParameters scaled = parameters;
  if (parameters.reference_step > 0.0) scaled.target_scale = std::min(1.0, dt / parameters.reference_step);
  const SelfCollisionStats stats = resolve(body, x0, d, fixed, scaled);
  for (Index n = 0; n < body.num_nodes(); ++n) {
    if (d.row(n) == before.row(n)) continue;
    body.positions.row(n) = x0.row(n) + d.row(n);
    body.velocities.row(n) += (d.row(n) - before.row(n)) / dt;
  }
  return stats;
}

}  // namespace goo
