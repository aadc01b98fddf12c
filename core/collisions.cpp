#include "core/collisions.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <limits>

#include "core/element_vertices.h"
#include "core/error.h"
#include "core/parallel.h"

namespace goo {
namespace {

Eigen::Vector3d vertex_value(const Body& body, const Points& values, Index vertex) {
  const Index e = body.embedding.parent[at(vertex)];
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int k = 0; k < 4; ++k) out += body.embedding.bary(vertex, k) * values.row(body.tets(e, k)).transpose();
  return out;
}

/// W&T eq. 4: w_i = b_i / Σ b_j², so Σ b_i w_i = 1.
Eigen::Vector4d distribution_weights(const Body& body, Index vertex) {
  const Eigen::Vector4d b = body.embedding.bary.row(vertex).transpose();
  return b / b.squaredNorm();
}

/// Whether every point Σ b_k y_k of element e, Σ b_k = 1 and each b_k in
/// [low_k, high_k], surely lies outside a half-space, its nodes y_k at
/// signed distances `distance` from the plane. Such a point's distance is
/// affine in it, d = Σ b_k d_k ≥ Σ_k min(low_k d_k, high_k d_k). The margin,
/// 10⁻⁹ of the coordinates' size (`size`, each node's largest, and the
/// plane's offset), is far above the ~10⁻¹⁵ relative rounding of the
/// per-vertex test, so no vertex that test would find is passed over.
bool surely_above(const Body& body, Index e, const Eigen::Vector4d& low, const Eigen::Vector4d& high,
                  const std::vector<double>& distance, const std::vector<double>& size, double offset) {
  double bound = 0.0, scale = 1.0 + std::abs(offset);
  for (int k = 0; k < 4; ++k) {
    const std::size_t n = at(body.tets(e, k));
    bound += std::min(low[k] * distance[n], high[k] * distance[n]);
    scale += size[n];
  }
  return bound > 1e-9 * scale;
}

}  // namespace

void SurfaceCollisions::index_vertices(const Body& body) {
  const Index ne = body.num_elements();
  const Index nv = body.embedding.num_vertices();
  // The same embedding as the last call's (a step's three calls, unless the
  // surface was smoothed or re-meshed between them): the same index.
  // Compared bit for bit (memcmp: several times faster than Eigen's
  // coefficient-wise ==; equal bits give the same index), in parallel.
  if (offsets_.size() == at(ne) + 1 && same_bits(indexed_parent_, body.embedding.parent) &&
      same_bits(indexed_bary_, body.embedding.bary))
    return;
  copy_in_parallel(body.embedding.parent, indexed_parent_);
  copy_in_parallel(body.embedding.bary, indexed_bary_);
  index_element_vertices(body.embedding.parent, ne, offsets_, vertices_);  // vertices increasing
  // Per element, the range of each barycentric coordinate over its
  // vertices (in vertex order: the embedding is read in sequence).
  bary_low_.assign(at(ne), Eigen::Vector4d::Constant(std::numeric_limits<double>::infinity()));
  bary_high_.assign(at(ne), Eigen::Vector4d::Constant(-std::numeric_limits<double>::infinity()));
  for (Index s = 0; s < nv; ++s) {
    const std::size_t e = at(body.embedding.parent[at(s)]);
    const Eigen::Vector4d b = body.embedding.bary.row(s).transpose();
    bary_low_[e] = bary_low_[e].cwiseMin(b);
    bary_high_[e] = bary_high_[e].cwiseMax(b);
  }
  bary_mid_.resize(at(ne));
  bary_reach_.resize(at(ne));
  for (Index e = 0; e < ne; ++e) {
    if (offsets_[at(e)] == offsets_[at(e) + 1]) continue;
    Eigen::Vector4d mid = 0.5 * (bary_low_[at(e)] + bary_high_[at(e)]);
    mid.array() += 0.25 * (1.0 - mid.sum());
    bary_mid_[at(e)] = mid;
    bary_reach_[at(e)] = (bary_high_[at(e)] - mid).cwiseMax(mid - bary_low_[at(e)]);
  }
}

std::vector<SurfaceCollisions::Hit> SurfaceCollisions::detect(const Body& body, const Points& x, const Points* v,
                                                              double dt, const std::vector<Obstacle>& obstacles,
                                                              double t, const std::vector<std::uint8_t>* only) {
  const Index ne = body.num_elements();
  const Index nv = body.embedding.num_vertices();
  std::vector<Eigen::AlignedBox3d> bounds;
  std::vector<PlacedShape> placed;
  bounds.reserve(obstacles.size());
  placed.reserve(obstacles.size());
  for (const Obstacle& o : obstacles) {
    bounds.push_back(o.bounds(t));
    placed.push_back(o.at(t));
  }

  // 1. Per element, the obstacles that may touch its surface vertices. A
  // half-space is bounded from the nodes' distances to its plane
  // (surely_above), measured here once per node; any other obstacle thus:
  // a vertex is tested where the step takes it, p = Σ b_k y_k with the
  // nodes at y_k = x_k + dt v_k, and with b̄ amid the element's vertices'
  // coordinates (Σ b̄_k = Σ b_k = 1), p − Σ b̄_k y_k = Σ_{k≠j} (b_k − b̄_k)
  // (y_k − y_j) for any corner j: every vertex lies in the ball around c =
  // Σ b̄_k y_k of radius min_j Σ_{k≠j} reach_k |y_k − y_j|. A signed distance
  // is 1-Lipschitz, so an obstacle farther from c than that (by a margin far
  // above the rounding of either) touches none.
  const Index nn = body.num_nodes();
  node_size_.resize(at(nn));
  node_distance_.resize(obstacles.size());
  for (std::size_t o = 0; o < obstacles.size(); ++o)
    if (placed[o].planar) node_distance_[o].resize(at(nn));
  tbb::parallel_for(tbb::blocked_range<Index>(0, nn, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index n = r.begin(); n != r.end(); ++n) {
      Eigen::Vector3d y = x.row(n).transpose();
      if (v) y += dt * v->row(n).transpose();
      node_size_[at(n)] = y.cwiseAbs().maxCoeff();
      for (std::size_t o = 0; o < obstacles.size(); ++o)
        if (placed[o].planar) node_distance_[o][at(n)] = placed[o].plane_normal.dot(y) - placed[o].plane_offset;
    }
  });
  const bool all_planar = std::all_of(placed.begin(), placed.end(), [](const PlacedShape& p) { return p.planar; });
  const std::size_t words = (obstacles.size() + 63) / 64;
  if (!all_planar) {
    centre_.resize(at(ne));
    centre_distance_.resize(at(ne) * obstacles.size());
  }
  // The obstacles near element e, a bit each into mask (words long).
  auto mark_near = [&](Index e, std::uint64_t* mask) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    double radius = 0.0;
    Eigen::AlignedBox3d box;
    if (!all_planar) {
      std::array<Eigen::Vector3d, 4> y;
      for (int k = 0; k < 4; ++k) {
        y[at(k)] = x.row(body.tets(e, k)).transpose();
        if (v) y[at(k)] += dt * v->row(body.tets(e, k)).transpose();
        centre += bary_mid_[at(e)][k] * y[at(k)];
      }
      // Each distance once: |y_k − y_j| and |y_j − y_k| are the same bits.
      std::array<std::array<double, 4>, 4> apart{};
      for (int j = 0; j < 4; ++j)
        for (int k = j + 1; k < 4; ++k) apart[at(j)][at(k)] = apart[at(k)][at(j)] = (y[at(k)] - y[at(j)]).norm();
      radius = std::numeric_limits<double>::infinity();
      for (int j = 0; j < 4; ++j) {
        double r = 0.0;
        for (int k = 0; k < 4; ++k)
          if (k != j) r += bary_reach_[at(e)][k] * apart[at(j)][at(k)];
        radius = std::min(radius, r);
      }
      radius = radius * (1.0 + 1e-9) + 1e-9 * centre.cwiseAbs().maxCoeff();
      box = Eigen::AlignedBox3d(centre - Eigen::Vector3d::Constant(radius), centre + Eigen::Vector3d::Constant(radius));
      centre_[at(e)] = centre;
    }
    for (std::size_t o = 0; o < obstacles.size(); ++o) {
      bool near = false;
      if (placed[o].planar) {
        near = !surely_above(body, e, bary_low_[at(e)], bary_high_[at(e)], node_distance_[o], node_size_,
                             placed[o].plane_offset);
      } else if (bounds[o].intersects(box)) {
        const double d = placed[o].query(centre).distance;
        centre_distance_[at(e) * obstacles.size() + o] = d;
        const double margin = 1e-9 * (centre.cwiseAbs().maxCoeff() + std::abs(d));
        near = d - margin <= radius;
      }
      if (near) mask[o / 64] |= std::uint64_t{1} << (o % 64);
    }
  };
  // 2. Vertex s of element e against the element's near obstacles (a
  // half-space first bounded from the nodes' distances): hit(o, sd) for
  // each it lies inside.
  auto test_vertex = [&](Index e, Index s, const std::uint64_t* mask, auto&& hit) {
    const Eigen::Vector4d b = body.embedding.bary.row(s).transpose();
    Eigen::Vector3d p;
    bool measured = false;
    for (std::size_t o = 0; o < obstacles.size(); ++o) {
      if (!((mask[o / 64] >> (o % 64)) & 1U)) continue;
      if (placed[o].planar && surely_above(body, e, b, b, node_distance_[o], node_size_, placed[o].plane_offset))
        continue;
      if (!measured) {
        p = vertex_value(body, x, s);
        if (v) p += dt * vertex_value(body, *v, s);
        measured = true;
      }
      if (!placed[o].planar) {
        // 1-Lipschitz: sd(p) ≥ sd(c) − |p − c| from the element's centre c,
        // so a vertex nearer c than c is to the obstacle is outside it
        // (with a margin far above the rounding of either distance).
        const double d = centre_distance_[at(e) * obstacles.size() + o];
        const Eigen::Vector3d& c = centre_[at(e)];
        const double margin = 1e-9 * (c.cwiseAbs().maxCoeff() + std::abs(d));
        if (d > margin && (p - c).squaredNorm() < (d - margin) * (d - margin)) continue;
      }
      const SignedDistance sd = placed[o].query(p);
      if (sd.distance < 0.0) hit(static_cast<Index>(o), sd);
    }
  };
  // 3. The deepest hit of each element; of equal depths, the lower
  // obstacle, then the lower vertex.
  auto deeper = [](const Hit& h, const Hit& best) {
    return best.element < 0 || h.contact.distance < best.contact.distance ||
           (h.contact.distance == best.contact.distance &&
            (h.obstacle < best.obstacle || (h.obstacle == best.obstacle && h.vertex < best.vertex)));
  };

  std::vector<Hit> hits;
  if (only) {
    // A later pass of the position stage: the few elements flagged, each
    // with its own vertices (the index's lists), in element order.
    // Flagged elements with vertices, ascending: found per run in parallel,
    // the runs read in order.
    constexpr Index kRun = 4096;
    flagged_runs_.resize(at((ne + kRun - 1) / kRun));
    for_each_index(
        static_cast<Index>(flagged_runs_.size()),
        [&](Index run) {
          std::vector<Index>& found = flagged_runs_[at(run)];
          found.clear();
          for (Index e = run * kRun; e < std::min(ne, (run + 1) * kRun); ++e)
            if ((*only)[at(e)] && offsets_[at(e)] != offsets_[at(e) + 1]) found.push_back(e);
        },
        1);
    flagged_.clear();
    for (const auto& found : flagged_runs_) flagged_.insert(flagged_.end(), found.begin(), found.end());
    if (flagged_hits_.size() < flagged_.size()) flagged_hits_.resize(flagged_.size());  // never shrunk: not filled anew
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, flagged_.size(), 64),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        std::vector<std::uint64_t> mask(words);
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          const Index e = flagged_[i];
                          Hit& best = flagged_hits_[i];
                          best = Hit{-1, -1, -1, {}};
                          std::fill(mask.begin(), mask.end(), 0);
                          mark_near(e, mask.data());
                          if (std::all_of(mask.begin(), mask.end(), [](std::uint64_t w) { return w == 0; })) continue;
                          for (Index c = offsets_[at(e)]; c < offsets_[at(e) + 1]; ++c) {
                            const Index s = vertices_[at(c)];
                            test_vertex(e, s, mask.data(), [&](Index o, const SignedDistance& sd) {
                              const Hit h{e, s, o, sd};
                              if (deeper(h, best)) best = h;
                            });
                          }
                        }
                      });
    for (std::size_t i = 0; i < flagged_.size(); ++i)
      if (flagged_hits_[i].element >= 0) hits.push_back(flagged_hits_[i]);
    return hits;
  }

  near_.resize(at(ne) * words);
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      std::uint64_t* mask = near_.data() + at(e) * words;
      std::fill(mask, mask + words, 0);
      if (offsets_[at(e)] != offsets_[at(e) + 1]) mark_near(e, mask);
    }
  });
  // Every vertex in vertex order: the embedding's arrays are read in
  // sequence (a fine surface has a hundred vertices and more per element,
  // and reading them element by element missed the cache at every vertex).
  constexpr Index kChunk = 4096;
  std::vector<std::vector<Hit>> chunks(at((nv + kChunk - 1) / kChunk));
  tbb::parallel_for(std::size_t{0}, chunks.size(), [&](std::size_t chunk) {
    const Index begin = static_cast<Index>(chunk) * kChunk, end = std::min(nv, begin + kChunk);
    for (Index s = begin; s < end; ++s) {
      const Index e = body.embedding.parent[at(s)];
      const std::uint64_t* mask = near_.data() + at(e) * words;
      if (std::all_of(mask, mask + words, [](std::uint64_t w) { return w == 0; })) continue;
      test_vertex(e, s, mask, [&](Index o, const SignedDistance& sd) { chunks[chunk].push_back({e, s, o, sd}); });
    }
  });
  // Each element's deepest hit (per_element_ is left empty between calls:
  // only the elements hit, flagged in hit_, are read and cleared).
  if (per_element_.size() != at(ne)) per_element_.assign(at(ne), Hit{-1, -1, -1, {}});
  hit_.resize(at(ne), 0);
  for (const auto& chunk : chunks)
    for (const Hit& h : chunk) {
      Hit& best = per_element_[at(h.element)];
      hit_[at(h.element)] = 1;
      if (deeper(h, best)) best = h;
    }
  for (Index e = 0; e < ne; ++e)
    if (hit_[at(e)]) {
      hits.push_back(per_element_[at(e)]);
      per_element_[at(e)] = Hit{-1, -1, -1, {}};
      hit_[at(e)] = 0;
    }
  return hits;
}

std::vector<std::vector<std::size_t>> SurfaceCollisions::colour(const Body& body, const std::vector<Hit>& hits) {
  masks_.assign(2 * at(body.num_nodes()), 0);
  std::vector<std::vector<std::size_t>> classes;
  for (std::size_t i = 0; i < hits.size(); ++i) {
    std::uint64_t used[2] = {0, 0};
    for (int k = 0; k < 4; ++k) {
      const std::size_t n = at(body.tets(hits[i].element, k));
      used[0] |= masks_[2 * n];
      used[1] |= masks_[2 * n + 1];
    }
    // At most 4 × 23 other elements share a node of a BCC element: 128 colours suffice.
    const int c = ~used[0] != 0 ? std::countr_one(used[0]) : 64 + std::countr_one(used[1]);
    if (c >= 128) throw Error("collisions: more than 128 colours needed (an element with too many neighbours)");
    for (int k = 0; k < 4; ++k) {
      const std::size_t n = at(body.tets(hits[i].element, k));
      masks_[2 * n + static_cast<std::size_t>(c / 64)] |= std::uint64_t{1} << (c % 64);
    }
    if (classes.size() <= static_cast<std::size_t>(c)) classes.resize(static_cast<std::size_t>(c) + 1);
    classes[static_cast<std::size_t>(c)].push_back(i);
  }
  return classes;
}

CollisionStats SurfaceCollisions::resolve_velocities(const Body& body, Points& v,
                                                     const std::vector<Obstacle>& obstacles, double t, double dt,
                                                     const std::vector<std::uint8_t>& fixed) {
  CollisionStats stats;
  if (obstacles.empty() || body.embedding.num_vertices() == 0) return stats;
  index_vertices(body);
  const std::vector<Hit> hits = detect(body, body.positions, &v, dt, obstacles, t);
  if (hits.empty()) return stats;
  stats.passes = 1;
  for (const Hit& h : hits) stats.deepest = std::min(stats.deepest, h.contact.distance);
  std::vector<std::uint8_t> applied(hits.size(), 0);
  const Index nn = body.num_nodes();
  normal_change_.assign(at(nn), Eigen::Vector3d::Zero());
  contact_obstacle_.assign(at(nn), -1);
  for (const auto& members : colour(body, hits)) {
    tbb::parallel_for(std::size_t{0}, members.size(), [&](std::size_t m) {
      const Hit& h = hits[members[m]];
      const Obstacle& obstacle = obstacles[at(h.obstacle)];
      const Eigen::Vector3d& n = h.contact.normal;
      const Eigen::Vector3d p = vertex_value(body, body.positions, h.vertex) + dt * vertex_value(body, v, h.vertex);
      const Eigen::Vector3d relative = vertex_value(body, v, h.vertex) - obstacle.velocity(p, t);
      const double vn = relative.dot(n);
      if (vn >= 0.0) return;  // separating already
      // Inelastic normal response (W&T eq. 4's weights); each node keeps
      // the normal change it received for its friction below.
      const Eigen::Vector3d dv = -vn * n;
      const Eigen::Vector4d w = distribution_weights(body, h.vertex);
      for (int k = 0; k < 4; ++k) {
        const Index node = body.tets(h.element, k);
        if (!fixed.empty() && fixed[at(node)]) continue;
        v.row(node) += w[k] * dv.transpose();
        normal_change_[at(node)] += w[k] * dv;  // one element of a colour per node: no race
        contact_obstacle_[at(node)] = h.obstacle;
      }
      applied[members[m]] = 1;
    });
  }
  // Coulomb friction per node: a node's tangential velocity relative to
  // the obstacle drops by at most μ × the normal velocity change it
  // received (along that change; of several obstacles, the last one's).
  // Applied at each element's deepest vertex instead, it dragged an
  // element's nodes by different amounts, and a puddle's bottom, held at
  // one node and dragged at the next, buckled into folds
  // (docs/benchmarks.md, session 22).
  tbb::parallel_for(tbb::blocked_range<Index>(0, nn, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index node = r.begin(); node != r.end(); ++node) {
      const double gain = normal_change_[at(node)].norm();
      if (!(gain > 0.0)) continue;
      const Obstacle& obstacle = obstacles[at(contact_obstacle_[at(node)])];
      const Eigen::Vector3d n = normal_change_[at(node)] / gain;
      const Eigen::Vector3d relative = v.row(node).transpose() - obstacle.velocity(body.positions.row(node).transpose(), t);
      const Eigen::Vector3d tangential = relative - relative.dot(n) * n;
      const double speed = tangential.norm();
      if (speed > 0.0) v.row(node) -= std::min(1.0, obstacle.friction * gain / speed) * tangential.transpose();
    }
  });
  stats.resolved = static_cast<Index>(std::count(applied.begin(), applied.end(), 1));
  return stats;
}

CollisionStats SurfaceCollisions::resolve_positions(Body& body, const std::vector<Obstacle>& obstacles, double t,
                                                    const std::vector<std::uint8_t>& fixed, int max_passes,
                                                    std::vector<ElementContact>* contacts) {
  CollisionStats stats;
  if (obstacles.empty() || body.embedding.num_vertices() == 0) return stats;
  std::vector<PlacedShape> placed;
  for (const Obstacle& o : obstacles) placed.push_back(o.at(t));
  index_vertices(body);
  // After the first pass, only elements that had a hit or have a node that
  // moved can have one: the others' vertices stand where they were
  // measured. So later passes look at those alone, and find what a full
  // detection would.
  std::vector<std::uint8_t> moved, again;
  for (int pass = 0; pass < max_passes; ++pass) {
    std::vector<Hit> hits = detect(body, body.positions, nullptr, 0.0, obstacles, t, pass == 0 ? nullptr : &again);
    // A penetration no deeper than the rounding of the signed distance is
    // none: a corrected vertex lands on the surface only to within it, and
    // later passes chased those residues (10⁻¹⁹–10⁻¹⁸ m at the fine drop's
    // floor, on a hundred elements a pass) until max_passes ran out. The
    // distance n·Σ b_k x_k − c (or a shape's, in its own frame) is rounded
    // by a few ε of the coordinates and the placement; 64 ε of their size
    // bounds it.
    std::erase_if(hits, [&](const Hit& h) {
      double size = placed[at(h.obstacle)].planar ? std::abs(placed[at(h.obstacle)].plane_offset)
                                                  : placed[at(h.obstacle)].to_world.translation().cwiseAbs().maxCoeff();
      double nodes = 0.0;
      for (int k = 0; k < 4; ++k)
        nodes = std::max(nodes, body.positions.row(body.tets(h.element, k)).cwiseAbs().maxCoeff());
      size += nodes;
      return -h.contact.distance <= 64.0 * std::numeric_limits<double>::epsilon() * size;
    });
    if (hits.empty()) break;
    moved.assign(at(body.num_nodes()), 0);
    ++stats.passes;
    for (const Hit& h : hits) stats.deepest = std::min(stats.deepest, h.contact.distance);
    std::vector<Eigen::Vector3d> normal(contacts ? hits.size() : 0, Eigen::Vector3d::Zero());
    for (const auto& members : colour(body, hits)) {
      tbb::parallel_for(std::size_t{0}, members.size(), [&](std::size_t m) {
        const Hit& hit = hits[members[m]];
        // Re-measured: an earlier colour may have moved this element's nodes.
        Index deepest_vertex = -1;
        SignedDistance deepest;
        deepest.distance = 0.0;
        for (Index c = offsets_[at(hit.element)]; c < offsets_[at(hit.element) + 1]; ++c) {
          const Index s = vertices_[at(c)];
          const SignedDistance sd = placed[at(hit.obstacle)].query(vertex_value(body, body.positions, s));
          if (sd.distance < deepest.distance) {
            deepest = sd;
            deepest_vertex = s;
          }
        }
        if (deepest_vertex < 0) return;
        if (contacts) normal[members[m]] = deepest.normal;
        const Eigen::Vector3d dx = -deepest.distance * deepest.normal;
        const Eigen::Vector4d w = distribution_weights(body, deepest_vertex);
        for (int k = 0; k < 4; ++k) {
          const Index node = body.tets(hit.element, k);
          if (!fixed.empty() && fixed[at(node)]) continue;
          body.positions.row(node) += w[k] * dx.transpose();
          moved[at(node)] = 1;  // one element of a colour per node: no race
        }
      });
    }
    stats.resolved += static_cast<Index>(hits.size());
    if (contacts)
      for (std::size_t i = 0; i < hits.size(); ++i)
        if (normal[i] != Eigen::Vector3d::Zero()) contacts->push_back({hits[i].element, normal[i]});
    // The elements hit, and those with a node that moved (in parallel).
    again.resize(at(body.num_elements()));
    for_each_index(body.num_elements(), [&](Index e) {
      again[at(e)] = moved[at(body.tets(e, 0))] | moved[at(body.tets(e, 1))] | moved[at(body.tets(e, 2))] |
                     moved[at(body.tets(e, 3))];
    });
    for (const Hit& h : hits) again[at(h.element)] = 1;
  }
  return stats;
}

}  // namespace goo
