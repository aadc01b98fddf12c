#include "core/contact/self_collisions.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/SVD>
#include <algorithm>
#include <map>

#include "core/contact/box_pairs.h"
#include "core/contact/ccd.h"
#include "core/parallel.h"
#include "core/union_find.h"

namespace goo {
namespace {

using ccd::PairKind;
using Vec3 = Eigen::Vector3d;

constexpr double kRepulsionFraction = 0.1;  // of the missing thickness, per step (Bridson et al. 2002, sec. 7.2)
constexpr int kMaxZoneRounds = 64;

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

ccd::Points4 gather(const Points& xs, const std::array<Index, 4>& v) {
  return {xs.row(v[0]).transpose(), xs.row(v[1]).transpose(), xs.row(v[2]).transpose(), xs.row(v[3]).transpose()};
}

Box3 grown(Box3 b, double by) {
  b.min().array() -= by;
  b.max().array() += by;
  return b;
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

}  // namespace

bool SelfCollisions::update_edges(const Triangles& triangles) {
  if (triangles.rows() == triangles_.rows() && triangles == triangles_) return false;
  triangles_ = triangles;
  edges_.clear();
  edges_.reserve(at(static_cast<Index>(triangles.rows())) * 3);
  for (Eigen::Index t = 0; t < triangles.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index a = triangles(t, k), b = triangles(t, (k + 1) % 3);
      edges_.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(edges_.begin(), edges_.end());
  edges_.erase(std::unique(edges_.begin(), edges_.end()), edges_.end());
  return true;
}

bool SelfCollisions::find_candidates(const Body& body, const Points& xs0, const Points& ds, double thickness,
                                     SelfCollisionStats& stats) {
  const Index nv = body.embedding.num_vertices();
  const Index nt = static_cast<Index>(body.surface_triangles.rows());
  const Triangles& tris = body.surface_triangles;
  // Boxes of primitives whose vertices have boxes `box`, grown by `grow`.
  auto primitive_boxes = [&](const std::vector<Box3>& box, double grow, std::vector<Box3>& v_out,
                             std::vector<Box3>& t_out, std::vector<Box3>& e_out) {
    v_out.resize(at(nv));
    t_out.resize(at(nt));
    e_out.resize(edges_.size());
    for (Index v = 0; v < nv; ++v) v_out[at(v)] = grown(box[at(v)], grow);
    for (Index t = 0; t < nt; ++t)
      t_out[at(t)] = grown(Box3(box[at(tris(t, 0))]).extend(box[at(tris(t, 1))]).extend(box[at(tris(t, 2))]), grow);
    for (std::size_t e = 0; e < edges_.size(); ++e)
      e_out[e] = grown(Box3(box[at(edges_[e][0])]).extend(box[at(edges_[e][1])]), grow);
  };
  std::vector<Box3> swept(at(nv));
  for (Index v = 0; v < nv; ++v) {
    swept[at(v)].extend(xs0.row(v).transpose());
    swept[at(v)].extend((xs0.row(v) + ds.row(v)).transpose());
  }
  primitive_boxes(swept, 0.5 * thickness, vertex_boxes_, triangle_boxes_, edge_boxes_);

  // Is the list still good? Every vertex, at the start and the end of the
  // step, within its margin of its place at the build, after the surface's
  // mean translation (which moves every pair alike). Then no pair missing
  // from the list can come within the thickness in this step: their grown
  // boxes, translated alike, stay apart.
  const Eigen::RowVector3d mean_step = ds.colwise().mean();
  if (list_valid_ && list_positions_.rows() == nv) {
    const Eigen::RowVector3d shift = (xs0 - list_positions_).colwise().mean();
    bool holds = true;
    for (Index v = 0; v < nv && holds; ++v) {
      const Eigen::RowVector3d start = xs0.row(v) - list_positions_.row(v) - shift;
      const Eigen::RowVector3d end = start + ds.row(v) - mean_step;
      holds = std::max(start.cwiseAbs().maxCoeff(), end.cwiseAbs().maxCoeff()) <= margin_[at(v)];
    }
    if (holds) return false;
  }
  // A new list from static boxes, each vertex's grown by its own margin: a
  // quarter of the mean edge, or twice this step's displacement relative to
  // the mean, whichever is more (one margin for all, as large as the
  // fastest vertex needed, built lists too long to sweep every step).
  double edge_length = 0.0;
  for (const auto& e : edges_) edge_length += (xs0.row(e[0]) - xs0.row(e[1])).norm();
  edge_length /= double(std::max<std::size_t>(1, edges_.size()));
  margin_.resize(at(nv));
  std::vector<Box3> at_start(at(nv));
  for (Index v = 0; v < nv; ++v) {
    margin_[at(v)] = std::max(0.25 * edge_length, 2.0 * (ds.row(v) - mean_step).cwiseAbs().maxCoeff());
    at_start[at(v)] = grown(Box3(xs0.row(v).transpose(), xs0.row(v).transpose()), margin_[at(v)]);
  }
  std::vector<Box3> vb, tb, eb;
  primitive_boxes(at_start, 0.5 * thickness, vb, tb, eb);
  list_positions_ = xs0;
  list_valid_ = true;
  ++stats.list_builds;
  candidates_.clear();
  for (const auto& [v, t] : overlapping_pairs(vb, tb)) {
    const auto tri = tris.row(t);
    if (tri[0] == v || tri[1] == v || tri[2] == v) continue;
    candidates_.push_back({static_cast<std::uint8_t>(PairKind::vertex_triangle), {v, tri[0], tri[1], tri[2]}, {v, t}});
  }
  for (const auto& [a, b] : overlapping_pairs(eb)) {
    const auto &ea = edges_[at(a)], &eb2 = edges_[at(b)];
    if (ea[0] == eb2[0] || ea[0] == eb2[1] || ea[1] == eb2[0] || ea[1] == eb2[1]) continue;
    candidates_.push_back({static_cast<std::uint8_t>(PairKind::edge_edge), {ea[0], ea[1], eb2[0], eb2[1]}, {a, b}});
  }
  return true;
}

bool SelfCollisions::boxes_meet(const Pair& p) const {
  return p.kind == static_cast<std::uint8_t>(PairKind::vertex_triangle)
             ? vertex_boxes_[at(p.primitives[0])].intersects(triangle_boxes_[at(p.primitives[1])])
             : edge_boxes_[at(p.primitives[0])].intersects(edge_boxes_[at(p.primitives[1])]);
}

std::vector<SelfCollisions::Impact> SelfCollisions::detect(const Body& body, const Points& xs0, const Points& ds,
                                                           double thickness, const std::vector<Index>* zone,
                                                           const std::vector<std::uint8_t>* only,
                                                           SelfCollisionStats& stats) {
  constexpr double kNone = -1.0;
  std::vector<double> toi(candidates_.size(), kNone);
  std::vector<double>& start = start_;
  start.assign(candidates_.size(), kNone);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, candidates_.size(), 256),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        const Pair& p = candidates_[i];
                        if (only && !((*only)[at(p.vertices[0])] || (*only)[at(p.vertices[1])] ||
                                      (*only)[at(p.vertices[2])] || (*only)[at(p.vertices[3])]))
                          continue;
                        if (!boxes_meet(p)) continue;
                        if (zone) {
                          const Index root = (*zone)[at(body.tets(body.embedding.parent[at(p.vertices[0])], 0))];
                          bool inside = true;
                          for (const Index s : p.vertices)
                            for (int k = 0; k < 4 && inside; ++k)
                              inside = (*zone)[at(body.tets(body.embedding.parent[at(s)], k))] == root;
                          if (inside) continue;  // moved by one affine map that shrinks no distance
                        }
                        const auto kind = static_cast<PairKind>(p.kind);
                        const ccd::Points4 x = gather(xs0, p.vertices);
                        start[i] = ccd::closest(kind, x).distance;
                        if (start[i] == 0.0) continue;  // touching or crossing already: left alone
                        const double keep = start[i] > thickness ? thickness : 0.5 * start[i];
                        if (const auto t = ccd::time_of_impact(kind, x, gather(ds, p.vertices), keep)) toi[i] = *t;
                      }
                    });
  std::vector<Impact> impacts;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    if (start[i] >= 0.0) ++stats.candidates;
    if (start[i] == 0.0 && !zone) ++stats.touching_at_start;
    if (toi[i] != kNone) impacts.push_back({i, toi[i]});
  }
  return impacts;
}

bool SelfCollisions::apply_impulse(const Body& body, const Pair& pair, const ccd::Points4& x, Points& d,
                                   const std::vector<std::uint8_t>& fixed, double target, double friction) const {
  const auto kind = static_cast<PairKind>(pair.kind);
  const ccd::Closest closest = ccd::closest(kind, x);
  Vec3 n = Vec3::Zero();
  for (std::size_t k = 0; k < 4; ++k) n += closest.coefficients[k] * x[k];
  if (!(n.norm() > 0.0)) return false;  // touching: no direction to push along
  n.normalize();
  const NodeWeights w = node_weights(body, pair.vertices, closest.coefficients);
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
  for (std::size_t k = 0; k < std::size_t(w.size); ++k)
    d.row(w.node[k]) += (w.c[k] * inverse_mass[k] * change).transpose();
  return true;
}

SelfCollisionStats SelfCollisions::resolve(const Body& body, const Points& x0, Points& d,
                                           const std::vector<std::uint8_t>& fixed,
                                           const SelfCollisionParameters& parameters) {
  SelfCollisionStats stats;
  if (body.embedding.num_vertices() == 0 || body.surface_triangles.rows() == 0) return stats;
  const double thickness = parameters.thickness;
  if (update_edges(body.surface_triangles)) list_valid_ = false;
  const Points xs0 = body.embedding.surface_positions(body.tets, x0);
  Points ds = body.embedding.surface_positions(body.tets, d);  // W d: the surface's displacements
  find_candidates(body, xs0, ds, thickness, stats);
  std::vector<Impact> impacts = detect(body, xs0, ds, thickness, nullptr, nullptr, stats);

  // Proximity: pairs closer than the thickness at the start are pushed
  // apart by a tenth of what is missing per step.
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    const Pair& p = candidates_[i];
    const double start = start_[i];
    if (start > 0.0 && start < thickness &&
        apply_impulse(body, p, gather(xs0, p.vertices), d, fixed, kRepulsionFraction * (thickness - start), parameters.friction))
      ++stats.repulsions;
  }
  // Detection again after impulses. With `only` (per surface vertex), and
  // the candidate list kept, only pairs with a flagged vertex are measured:
  // the others' vertices stand and move as when they were measured.
  auto redetect = [&](const std::vector<Index>* zone, const std::vector<std::uint8_t>* only) {
    ds = body.embedding.surface_positions(body.tets, d);
    const bool rebuilt = find_candidates(body, xs0, ds, thickness, stats);
    return detect(body, xs0, ds, thickness, zone, rebuilt ? nullptr : only, stats);
  };
  if (stats.repulsions > 0) impacts = redetect(nullptr, nullptr);

  // Impulse rounds: each impact stops the pair's approach where CCD found it.
  std::vector<std::uint8_t> moved(at(body.num_nodes())), again(at(body.embedding.num_vertices()));
  for (int round = 0; round < parameters.max_rounds && !impacts.empty(); ++round) {
    ++stats.rounds;
    const Points d_before = d;
    for (const Impact& impact : impacts) {
      const Pair& p = candidates_[impact.pair];
      ccd::Points4 x = gather(xs0, p.vertices);
      const ccd::Points4 dx = gather(ds, p.vertices);
      for (std::size_t k = 0; k < 4; ++k) x[k] += impact.toi * dx[k];
      if (apply_impulse(body, p, x, d, fixed, 0.0, parameters.friction)) ++stats.impacts;
    }
    // Measured again: pairs of a vertex whose element has a node that moved,
    // and the impacts' own (an impulse that could not act leaves its pair).
    for (Index n = 0; n < body.num_nodes(); ++n) moved[at(n)] = d.row(n) != d_before.row(n) ? 1 : 0;
    for (Index v = 0; v < body.embedding.num_vertices(); ++v) {
      const Index e = body.embedding.parent[at(v)];
      again[at(v)] = moved[at(body.tets(e, 0))] | moved[at(body.tets(e, 1))] | moved[at(body.tets(e, 2))] |
                     moved[at(body.tets(e, 3))];
    }
    for (const Impact& impact : impacts)
      for (const Index v : candidates_[impact.pair].vertices) again[at(v)] = 1;
    impacts = redetect(nullptr, &again);
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
    rigidify_zones();
    impacts = redetect(&root, nullptr);
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
  const SelfCollisionStats stats = resolve(body, x0, d, fixed, parameters);
  for (Index n = 0; n < body.num_nodes(); ++n) {
    if (d.row(n) == before.row(n)) continue;
    body.positions.row(n) = x0.row(n) + d.row(n);
    body.velocities.row(n) += (d.row(n) - before.row(n)) / dt;
  }
  return stats;
}

}  // namespace goo
