#include "meshing/surface_upkeep.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <set>
#include <unordered_map>
#include <vector>

#include "core/contact/ccd.h"
#include "core/error.h"
#include "core/parallel.h"
#include "core/polygon_soup.h"
#include "core/radix_sort.h"
#include "core/surface_topology.h"
#include "meshing/surface_intersections.h"

namespace goo {
namespace {

using Edge = std::pair<Index, Index>;  // (min, max)

Edge edge(Index a, Index b) { return a < b ? Edge{a, b} : Edge{b, a}; }

Eigen::Vector3d point(const TriangleMesh& s, Index v) { return s.vertices.row(v).transpose(); }

double length(const TriangleMesh& s, const Edge& e) { return (point(s, e.first) - point(s, e.second)).norm(); }

std::vector<Edge> by_length(const TriangleMesh& s, std::vector<Edge> edges, bool longer);

/// The unique edges longer than `limit` (`longer`) or shorter than it,
/// longest (shortest) first, ties by ids. A fine surface has millions of
/// edges and, at a re-mesh, few of either kind: only those are sorted.
std::vector<Edge> edges_beyond(const TriangleMesh& s, double limit, bool longer) {
  // Gathered in parallel, in chunks of triangles concatenated in order
  // (the sort below makes the order moot anyway).
  constexpr Index kChunk = 4096;
  const Index nt = s.num_triangles();
  std::vector<std::vector<Edge>> found(at((nt + kChunk - 1) / kChunk));
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    const Index begin = static_cast<Index>(chunk) * kChunk, end = std::min(nt, begin + kChunk);
    for (Index t = begin; t < end; ++t)
      for (int k = 0; k < 3; ++k) {
        const Edge e = edge(s.triangles(t, k), s.triangles(t, (k + 1) % 3));
        const double l = length(s, e);
        if (longer ? l > limit : l < limit) found[chunk].push_back(e);
      }
  });
  std::vector<Edge> edges;
  for (const auto& f : found) edges.insert(edges.end(), f.begin(), f.end());
  return by_length(s, std::move(edges), longer);
}

/// `edges` without repeats, longest (shortest) first, ties by ids.
std::vector<Edge> by_length(const TriangleMesh& s, std::vector<Edge> edges, bool longer) {
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<double> lengths(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) lengths[i] = length(s, edges[i]);
  std::vector<std::size_t> order(edges.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return longer ? lengths[x] > lengths[y] : lengths[x] < lengths[y];
  });
  std::vector<Edge> out(edges.size());
  for (std::size_t i = 0; i < order.size(); ++i) out[i] = edges[order[i]];
  return out;
}

/// The triangles at each of `edges` (by index; triangle t has the edge at
/// corner k → k + 1), in increasing order: the first two and how many.
struct EdgeTriangles {
  std::array<Index, 2> first{-1, -1};
  Index count = 0;
};
std::vector<EdgeTriangles> edge_triangles(const TriangleMesh& s, const std::vector<Edge>& edges) {
  std::vector<std::pair<Edge, std::size_t>> sorted(edges.size());
  for (std::size_t i = 0; i < edges.size(); ++i) sorted[i] = {edges[i], i};
  std::sort(sorted.begin(), sorted.end());
  std::vector<EdgeTriangles> out(edges.size());
  std::vector<std::uint8_t> end(at(s.num_vertices()), 0);  // an end of one of the edges: searched for
  for (const Edge& e : edges) end[at(e.first)] = end[at(e.second)] = 1;
  for (Index t = 0; t < s.num_triangles(); ++t)
    for (int k = 0; k < 3; ++k) {
      if (!end[at(s.triangles(t, k))] || !end[at(s.triangles(t, (k + 1) % 3))]) continue;
      const std::pair<Edge, std::size_t> key{edge(s.triangles(t, k), s.triangles(t, (k + 1) % 3)), 0};
      const auto it = std::lower_bound(sorted.begin(), sorted.end(), key);
      if (it == sorted.end() || it->first != key.first) continue;
      EdgeTriangles& slot = out[it->second];
      if (slot.count < 2) slot.first[at(slot.count)] = t;
      ++slot.count;
    }
  return out;
}

/// One pass of splits over `long_edges` (the edges longer than the limit,
/// longest first: edges_beyond), which it brings up to date for the next
/// pass: the ones it did not split (there, and as long, still) and the
/// long ones among the sides of the triangles it cut or added.
Index split_pass(TriangleMesh& s, double limit, std::vector<Edge>& long_edges) {
  if (long_edges.empty()) return 0;
  const std::vector<EdgeTriangles> triangles_of = edge_triangles(s, long_edges);
  std::vector<std::uint8_t> touched(at(s.num_triangles()), 0), split(long_edges.size(), 0);
  std::vector<Eigen::Vector3i> added;
  std::vector<Eigen::RowVector3d> new_vertices;
  Index splits = 0;
  for (std::size_t i = 0; i < long_edges.size(); ++i) {
    const Edge& e = long_edges[i];
    const EdgeTriangles& around = triangles_of[i];
    if (around.count != 2 || touched[at(around.first[0])] || touched[at(around.first[1])]) continue;
    const auto m = static_cast<Index>(s.num_vertices() + static_cast<Index>(new_vertices.size()));
    new_vertices.push_back(0.5 * (s.vertices.row(e.first) + s.vertices.row(e.second)));
    for (const Index t : around.first) {
      touched[at(t)] = 1;
      // Rotate t so that the split edge is (corner 0 → corner 1).
      int k = 0;
      while (edge(s.triangles(t, k), s.triangles(t, (k + 1) % 3)) != e) ++k;
      const Index a = s.triangles(t, k), b = s.triangles(t, (k + 1) % 3), c = s.triangles(t, (k + 2) % 3);
      s.triangles.row(t) << a, m, c;
      added.emplace_back(m, b, c);
    }
    split[i] = 1;
    ++splits;
  }
  if (splits == 0) return 0;
  const Index nv = s.num_vertices(), nt = s.num_triangles();
  s.vertices.conservativeResize(nv + static_cast<Index>(new_vertices.size()), 3);
  for (std::size_t i = 0; i < new_vertices.size(); ++i) s.vertices.row(nv + static_cast<Index>(i)) = new_vertices[i];
  s.triangles.conservativeResize(nt + static_cast<Index>(added.size()), 3);
  for (std::size_t i = 0; i < added.size(); ++i) s.triangles.row(nt + static_cast<Index>(i)) = added[i].transpose();
  std::vector<Edge> next;
  for (std::size_t i = 0; i < long_edges.size(); ++i)
    if (!split[i]) next.push_back(long_edges[i]);
  for (Index t = 0; t < s.num_triangles(); ++t)
    if (t >= nt || touched[at(t)])
      for (int k = 0; k < 3; ++k) {
        const Edge e = edge(s.triangles(t, k), s.triangles(t, (k + 1) % 3));
        if (length(s, e) > limit) next.push_back(e);
      }
  long_edges = by_length(s, std::move(next), true);
  return splits;
}

/// Signed volume of the cone from the origin over triangle (a, b, c), ×6.
double cone6(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return a.dot(b.cross(c));
}

/// Triangles by grid cell, for "which triangles may meet this box": each
/// triangle is entered in the cells its box covers (again when it changes;
/// a query checks the boxes themselves). A grid made from a whole surface
/// keeps its (cell, triangle) entries in one sorted array, filled in
/// parallel; the triangles inserted later (a pass's few changed ones) go
/// to a map of cells.
class TriangleGrid {
 public:
  explicit TriangleGrid(double cell) : cell_(cell) {}
  TriangleGrid(const TriangleMesh& s, double cell) : cell_(cell) {
    const Index nt = s.num_triangles();
    std::vector<std::size_t> offset(at(nt) + 1, 0);
    tbb::parallel_for(tbb::blocked_range<Index>(0, nt, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
      for (Index t = r.begin(); t != r.end(); ++t) {
        std::size_t count = 0;
        for_cells(box(s, t), [&](std::uint64_t) { ++count; });
        offset[at(t) + 1] = count;
      }
    });
    for (std::size_t t = 0; t < at(nt); ++t) offset[t + 1] += offset[t];
    entries_.resize(offset[at(nt)]);
    tbb::parallel_for(tbb::blocked_range<Index>(0, nt, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
      for (Index t = r.begin(); t != r.end(); ++t) {
        std::size_t e = offset[at(t)];
        for_cells(box(s, t), [&](std::uint64_t key) { entries_[e++] = {key, t}; });
      }
    });
    // Stable by cell: filled in triangle order, so sorted by (cell, triangle).
    radix_sort(entries_, [](const std::pair<std::uint64_t, Index>& entry) { return entry.first; });
  }
  void insert(const TriangleMesh& s, Index t) {
    for_cells(box(s, t), [&](std::uint64_t key) { cells_[key].push_back(t); });
  }
  /// The grid of `s` after a pass, from this one of `s` before it: old
  /// triangle t is now triangle new_index[t] (−1: gone; increasing in t),
  /// and those with `changed` set are entered anew at their new places.
  /// The same entries as a grid made from `s`; the inserted ones are dropped.
  void renumber(const TriangleMesh& s, const std::vector<Index>& new_index, const std::vector<std::uint8_t>& changed) {
    std::vector<std::pair<std::uint64_t, Index>> kept, fresh;
    kept.reserve(entries_.size());
    for (const auto& [key, t] : entries_)  // still sorted: new_index increases with t
      if (new_index[at(t)] >= 0 && !changed[at(t)]) kept.emplace_back(key, new_index[at(t)]);
    for (std::size_t t = 0; t < changed.size(); ++t)
      if (changed[t] && new_index[t] >= 0)
        for_cells(box(s, new_index[t]), [&](std::uint64_t key) { fresh.emplace_back(key, new_index[t]); });
    std::sort(fresh.begin(), fresh.end());
    entries_.resize(kept.size() + fresh.size());
    std::merge(kept.begin(), kept.end(), fresh.begin(), fresh.end(), entries_.begin());
    cells_.clear();
  }
  /// The triangles entered in the cells of `query`, each once, sorted.
  std::vector<Index> near(const Eigen::AlignedBox3d& query) const {
    std::vector<Index> out;
    for_cells(query, [&](std::uint64_t key) {
      if (!entries_.empty()) {
        const std::pair<std::uint64_t, Index> first{key, std::numeric_limits<Index>::min()};
        for (auto it = std::lower_bound(entries_.begin(), entries_.end(), first); it != entries_.end() && it->first == key; ++it)
          out.push_back(it->second);
      }
      if (const auto it = cells_.find(key); it != cells_.end()) out.insert(out.end(), it->second.begin(), it->second.end());
    });
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  static Eigen::AlignedBox3d box(const TriangleMesh& s, Index t) {
    Eigen::AlignedBox3d b;
    for (int k = 0; k < 3; ++k) b.extend(point(s, s.triangles(t, k)));
    return b;
  }

 private:
  template <typename F>
  void for_cells(const Eigen::AlignedBox3d& b, F&& f) const {
    const Eigen::Array3d lo = (b.min().array() / cell_).floor(), hi = (b.max().array() / cell_).floor();
    for (double x = lo[0]; x <= hi[0]; ++x)
      for (double y = lo[1]; y <= hi[1]; ++y)
        for (double z = lo[2]; z <= hi[2]; ++z) {
          const auto i = static_cast<std::uint64_t>(static_cast<std::int64_t>(x) & 0x1fffff);
          const auto j = static_cast<std::uint64_t>(static_cast<std::int64_t>(y) & 0x1fffff);
          const auto k = static_cast<std::uint64_t>(static_cast<std::int64_t>(z) & 0x1fffff);
          f((i << 42) | (j << 21) | k);
        }
  }
  double cell_;
  std::vector<std::pair<std::uint64_t, Index>> entries_;  // (cell, triangle), sorted
  std::unordered_map<std::uint64_t, std::vector<Index>> cells_;
};

/// True if triangle f of s meets a triangle of `blockers` (another body's
/// surface, `grid` over it) whose box meets `box` (f's).
bool meets_blocker(const TriangleMesh& s, Index f, const Eigen::AlignedBox3d& box, const TriangleMesh& blockers,
                   const TriangleGrid& grid) {
  const Eigen::Vector3d f0 = point(s, s.triangles(f, 0)), f1 = point(s, s.triangles(f, 1)), f2 = point(s, s.triangles(f, 2));
  for (const Index g : grid.near(box))
    if (TriangleGrid::box(blockers, g).intersects(box) &&
        triangles_intersect(f0, f1, f2, point(blockers, blockers.triangles(g, 0)), point(blockers, blockers.triangles(g, 1)),
                            point(blockers, blockers.triangles(g, 2))))
      return true;
  return false;
}

struct CollapsePass {
  Index collapses = 0;
  Index refused = 0;
  Index refused_crossing = 0;
  double volume_change = 0.0;
};

/// `short_edges`: the edges shorter than the limit when the pass starts,
/// shortest first (edges_beyond); `surface_grid` the grid of s. Both are brought up
/// to date for the next pass. `blockers`: other surfaces the new fans must
/// not meet either (with `blocker_grid` over their triangles).
CollapsePass collapse_pass(TriangleMesh& s, double limit, double cell, std::vector<Edge>& short_edges,
                           TriangleGrid& surface_grid, const TriangleMesh* blockers, const TriangleGrid* blocker_grid) {
  CollapsePass out;
  // (A collapse moves vertices, but only those of edges it marks dirty,
  // which the pass then skips: no other edge comes below the limit.)
  if (short_edges.empty()) return out;
  const Index nv = s.num_vertices(), nt = s.num_triangles();
  // The triangles around the ends of those edges: the only stars the pass
  // reads (slot[v] ≥ 0 for those vertices).
  std::vector<Index> slot(at(nv), -1);
  std::vector<std::vector<Index>> stars;
  for (const Edge& e : short_edges)
    for (const Index v : {e.first, e.second})
      if (slot[at(v)] < 0) {
        slot[at(v)] = static_cast<Index>(stars.size());
        stars.emplace_back();
      }
  for (Index t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k)
      if (const Index v = s.triangles(t, k); slot[at(v)] >= 0) stars[at(slot[at(v)])].push_back(t);
  auto star = [&](Index v) -> std::vector<Index>& { return stars[at(slot[at(v)])]; };
  std::vector<std::uint8_t> dead(at(nt), 0), dirty(at(nv), 0);
  std::vector<std::uint8_t> reshaped(at(nt), 0), merged(at(nv), 0);  // by the pass's collapses
  const TriangleGrid& before_pass = surface_grid;
  TriangleGrid changed(cell);  // the triangles a collapse moved, at their new places
  auto neighbours = [&](Index v) {
    std::vector<Index> out_v;
    for (const Index t : star(v))
      if (!dead[at(t)])
        for (int k = 0; k < 3; ++k)
          if (s.triangles(t, k) != v) out_v.push_back(s.triangles(t, k));
    std::sort(out_v.begin(), out_v.end());
    out_v.erase(std::unique(out_v.begin(), out_v.end()), out_v.end());
    return out_v;
  };
  for (const Edge& e : short_edges) {
    if (length(s, e) >= limit) break;
    const auto [a, b] = e;
    if (dirty[at(a)] || dirty[at(b)]) continue;
    // Link condition: a and b share exactly the two opposite vertices.
    const auto na = neighbours(a), nb = neighbours(b);
    std::vector<Index> common;
    std::set_intersection(na.begin(), na.end(), nb.begin(), nb.end(), std::back_inserter(common));
    std::vector<Index> sides, keep;
    for (const Index t : star(a))
      if (!dead[at(t)] && (s.triangles.row(t).array() == b).any()) sides.push_back(t);
    for (const Index v : {a, b})
      for (const Index t : star(v))
        if (!dead[at(t)] && !(s.triangles.row(t).array() == a).any() != !(s.triangles.row(t).array() == b).any())
          keep.push_back(t);
    if (common.size() != 2 || sides.size() != 2 || na.size() <= 3 || nb.size() <= 3) {
      ++out.refused;
      continue;
    }
    // Volume-preserving position p = m + τ (b − a): the enclosed volume
    // after the collapse is affine in p; solve for no change.
    const Eigen::Vector3d pa = point(s, a), pb = point(s, b), mid = 0.5 * (pa + pb);
    auto volume_with = [&](const Eigen::Vector3d& p) {
      double v = 0.0;
      for (const Index t : keep) {
        std::array<Eigen::Vector3d, 3> x;
        for (int k = 0; k < 3; ++k) {
          const Index w = s.triangles(t, k);
          x[static_cast<std::size_t>(k)] = (w == a || w == b) ? p : point(s, w);
        }
        v += cone6(x[0] - mid, x[1] - mid, x[2] - mid);
      }
      return v / 6.0;
    };
    double before = 0.0;
    for (const Index t : star(a))
      if (!dead[at(t)]) before += cone6(point(s, s.triangles(t, 0)) - mid, point(s, s.triangles(t, 1)) - mid,
                                         point(s, s.triangles(t, 2)) - mid) / 6.0;
    for (const Index t : star(b))
      if (!dead[at(t)] && !(s.triangles.row(t).array() == a).any())
        before += cone6(point(s, s.triangles(t, 0)) - mid, point(s, s.triangles(t, 1)) - mid,
                        point(s, s.triangles(t, 2)) - mid) / 6.0;
    const double v0 = volume_with(mid), v1 = volume_with(mid + (pb - pa));
    const double slope = v1 - v0;
    double tau = slope != 0.0 ? (before - v0) / slope : 0.0;
    tau = std::clamp(tau, -0.5, 0.5);
    const Eigen::Vector3d p = mid + tau * (pb - pa);
    // No surviving triangle may flip or degenerate.
    bool ok = true;
    for (const Index t : keep) {
      std::array<Eigen::Vector3d, 3> x, y;
      for (int k = 0; k < 3; ++k) {
        const Index w = s.triangles(t, k);
        x[static_cast<std::size_t>(k)] = point(s, w);
        y[static_cast<std::size_t>(k)] = (w == a || w == b) ? p : point(s, w);
      }
      const Eigen::Vector3d n0 = (x[1] - x[0]).cross(x[2] - x[0]), n1 = (y[1] - y[0]).cross(y[2] - y[0]);
      if (!(n0.dot(n1) > 0.0) || n1.norm() < 1e-12 * n0.norm()) ok = false;
    }
    if (!ok) {
      ++out.refused;
      continue;
    }
    // Tentatively: b merged into a at p. Refused, and undone, if a triangle
    // of the new fan meets any other triangle (surface_intersections.h): a
    // collapse must never make the surface pass through itself.
    const Eigen::Vector3d old_a = pa;
    s.vertices.row(a) = p.transpose();
    for (const Index t : sides) dead[at(t)] = 1;
    std::vector<Index> moved_from_b;
    std::vector<std::pair<Index, int>> renamed;  // (triangle, corner) that said b
    for (const Index t : star(b))
      if (!dead[at(t)]) {
        for (int k = 0; k < 3; ++k)
          if (s.triangles(t, k) == b) {
            s.triangles(t, k) = a;
            renamed.emplace_back(t, k);
          }
        moved_from_b.push_back(t);
      }
    bool crosses = false;
    for (const Index f : keep) {
      const Eigen::AlignedBox3d fan_box = TriangleGrid::box(s, f);
      for (const TriangleGrid* grid : {&before_pass, static_cast<const TriangleGrid*>(&changed)}) {
        for (const Index g : grid->near(fan_box))
          if (g != f && !dead[at(g)] && TriangleGrid::box(s, g).intersects(fan_box) && triangles_intersect(s, f, g)) {
            crosses = true;
            break;
          }
        if (crosses) break;
      }
      if (crosses) break;
      if (blockers && meets_blocker(s, f, fan_box, *blockers, *blocker_grid)) {
        crosses = true;
        break;
      }
    }
    if (crosses) {
      s.vertices.row(a) = old_a.transpose();
      for (const Index t : sides) dead[at(t)] = 0;
      for (const auto& [t, k] : renamed) s.triangles(t, k) = b;
      ++out.refused;
      ++out.refused_crossing;
      continue;
    }
    out.volume_change += std::abs(volume_with(p) - before);
    for (const Index t : moved_from_b) star(a).push_back(t);
    for (const Index t : keep) changed.insert(s, t), reshaped[at(t)] = 1;
    merged[at(a)] = merged[at(b)] = 1;
    // The neighbourhood changed: its edges wait for the next pass.
    dirty[at(a)] = dirty[at(b)] = 1;
    for (const Index v : na) dirty[at(v)] = 1;
    for (const Index v : nb) dirty[at(v)] = 1;
    ++out.collapses;
  }
  if (out.collapses > 0) {
    Triangles kept(nt, 3);
    std::vector<Index> new_index(at(nt), -1);
    Index n = 0;
    for (Index t = 0; t < nt; ++t)
      if (!dead[at(t)]) new_index[at(t)] = n, kept.row(n++) = s.triangles.row(t);
    kept.conservativeResize(n, 3);
    s.triangles = std::move(kept);
    std::vector<Index> new_id;
    remove_unreferenced_vertices(s, &new_id);
    surface_grid.renumber(s, new_index, reshaped);
    // The next pass's short edges: this pass's whose ends no collapse
    // merged or moved (there, and as short, still), and the short ones
    // among the reshaped triangles' edges (every edge at a moved vertex).
    std::vector<Edge> next;
    for (const Edge& e : short_edges)
      if (!merged[at(e.first)] && !merged[at(e.second)]) next.push_back(edge(new_id[at(e.first)], new_id[at(e.second)]));
    for (Index t = 0; t < nt; ++t)
      if (reshaped[at(t)] && !dead[at(t)])
        for (int k = 0; k < 3; ++k) {
          const Index r = new_index[at(t)];
          const Edge e = edge(s.triangles(r, k), s.triangles(r, (k + 1) % 3));
          if (length(s, e) < limit) next.push_back(e);
        }
    short_edges = by_length(s, std::move(next), false);
  }
  return out;
}

struct FlipPass {
  Index flips = 0;
  Index refused_crossing = 0;
  double volume_change = 0.0;
};

/// The angle at corner c of the triangle (a, b, c), radians.
double angle_at(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d u = a - c, v = b - c;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

/// Whether α_c + α_d, the angles facing edge ab in the triangles (a, b, c)
/// and (b, a, d), surely stays below π + 1e-7, from sin(α_c + α_d) =
/// sin α_c cos α_d + cos α_c sin α_d and cos(α_c + α_d) without an angle:
/// sin > 1e-7 puts the sum in (0, π); |sin| ≤ 1e-7 with cos < 0 within
/// 1e-7 of π (rounding adds ~1e-15). Anything else (a sum near 0 or 2π,
/// degenerate or non-finite corners) is left to the angles themselves.
constexpr double kSurelyBelow = 1e-7;

bool surely_below_pi(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& pc,
                     const Eigen::Vector3d& pd) {
  const Eigen::Vector3d uc = pa - pc, vc = pb - pc, ud = pb - pd, vd = pa - pd;
  const double sin_c = uc.cross(vc).norm(), cos_c = uc.dot(vc), sin_d = ud.cross(vd).norm(), cos_d = ud.dot(vd);
  const double scale = uc.norm() * vc.norm() * ud.norm() * vd.norm();
  if (!(scale > 0.0 && scale < std::numeric_limits<double>::infinity())) return false;
  const double sine = (sin_c * cos_d + cos_c * sin_d) / scale, cosine = (cos_c * cos_d - sin_c * sin_d) / scale;
  return sine > kSurelyBelow || (sine > -kSurelyBelow && cosine < 0.0);
}

/// Edge flips (Delaunay in the surface): the diagonal ab of the quad of two
/// triangles (a, b, c), (b, a, d), one of them a sliver (an angle below
/// 15°), becomes cd where the angles facing ab sum past π, most violating
/// first, each triangle at most once a pass; only
/// where the quad is nearly flat (the diagonals within kFlat × the shorter
/// of them: the surface moves by at most that), cd is no edge yet, the new
/// triangles neither fold more than the old nor meet another triangle (or
/// a blocker). Slivers, whose normals turn with any small move of a corner,
/// are what creases a flowing surface; a flip removes them and moves no
/// vertex.
FlipPass flip_pass(TriangleMesh& s, double cell, TriangleGrid& surface_grid, const TriangleMesh* blockers,
                   const TriangleGrid* blocker_grid) {
  constexpr double kFlat = 0.1;
  constexpr double kViolation = 1e-6;  // radians past π: no flip back and forth between cocircular diagonals
  static_assert(kSurelyBelow < kViolation, "what surely_below_pi rejects must fall short of the violation");
  constexpr double kSliver = 15.0 * std::numbers::pi / 180.0;  // a triangle with an angle this sharp is a sliver
  FlipPass out;
  const Index nt = s.num_triangles();
  // (a, b, triangle, corner) for every side, sorted: runs of two are the interior edges.
  const std::vector<std::array<Index, 4>> sides = sorted_sides(s.triangles);
  // Every edge, sorted; those a flip removes are marked, those it adds kept apart.
  std::vector<Edge> edge_list;
  edge_list.reserve(sides.size() / 2 + 1);
  for (std::size_t i = 0; i < sides.size(); ++i)
    if (i == 0 || sides[i][0] != sides[i - 1][0] || sides[i][1] != sides[i - 1][1])
      edge_list.emplace_back(sides[i][0], sides[i][1]);
  std::vector<std::uint8_t> removed(edge_list.size(), 0);
  std::set<Edge> added;
  auto find_edge = [&](const Edge& e) -> std::ptrdiff_t {
    const auto it = std::lower_bound(edge_list.begin(), edge_list.end(), e);
    return it != edge_list.end() && *it == e ? it - edge_list.begin() : -1;
  };
  auto is_edge = [&](const Edge& e) {
    const std::ptrdiff_t i = find_edge(e);
    return (i >= 0 && !removed[static_cast<std::size_t>(i)]) || added.contains(e);
  };
  struct Candidate {
    double excess;  // α_c + α_d − π
    Index t1, k1, t2;
  };
  // The candidates, found in parallel and gathered in the sides' order.
  constexpr std::size_t kChunk = 8192;
  std::vector<std::vector<Candidate>> found((sides.size() + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    for (std::size_t i = chunk * kChunk; i < std::min(sides.size(), (chunk + 1) * kChunk); ++i) {
      if (i + 1 < sides.size() && sides[i][0] == sides[i + 1][0] && sides[i][1] == sides[i + 1][1] &&
          (i + 2 >= sides.size() || sides[i + 2][0] != sides[i][0] || sides[i + 2][1] != sides[i][1]) &&
          (i == 0 || sides[i - 1][0] != sides[i][0] || sides[i - 1][1] != sides[i][1])) {
        const Index t1 = sides[i][2], k1 = sides[i][3], t2 = sides[i + 1][2], k2 = sides[i + 1][3];
        const Index a = s.triangles(t1, k1), b = s.triangles(t1, (k1 + 1) % 3), c = s.triangles(t1, (k1 + 2) % 3);
        const Index d = s.triangles(t2, (k2 + 2) % 3);
        if (c == d) continue;
        const Eigen::Vector3d pa = point(s, a), pb = point(s, b), pc = point(s, c), pd = point(s, d);
        if (surely_below_pi(pa, pb, pc, pd)) continue;  // excess < 1e-7 < kViolation
        const double excess = angle_at(pa, pb, pc) + angle_at(pb, pa, pd) - std::numbers::pi;
        if (!(excess > kViolation)) continue;
        // Only where a sliver is: a well-shaped pair is left as it is (each
        // flip moves the surface a little, and a convex one inwards).
        const double sharpest = std::min({angle_at(pa, pb, pc), angle_at(pb, pc, pa), angle_at(pc, pa, pb),
                                          angle_at(pb, pa, pd), angle_at(pa, pd, pb), angle_at(pd, pb, pa)});
        if (sharpest < kSliver) found[chunk].push_back({excess, t1, k1, t2});
      }
    }
  });
  std::vector<Candidate> candidates;
  for (const auto& f : found) candidates.insert(candidates.end(), f.begin(), f.end());
  if (candidates.empty()) return out;
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& x, const Candidate& y) { return x.excess > y.excess; });
  const TriangleGrid& before_pass = surface_grid;
  TriangleGrid changed(cell);
  std::vector<std::uint8_t> touched(at(nt), 0);
  for (const Candidate& f : candidates) {
    const Index t1 = f.t1, t2 = f.t2;
    if (touched[at(t1)] || touched[at(t2)]) continue;
    const Index a = s.triangles(t1, f.k1), b = s.triangles(t1, (f.k1 + 1) % 3), c = s.triangles(t1, (f.k1 + 2) % 3);
    Index d = -1;
    for (int k = 0; k < 3; ++k)
      if (s.triangles(t2, k) != a && s.triangles(t2, k) != b) d = s.triangles(t2, k);
    if (d < 0 || is_edge(edge(c, d))) continue;  // cd is an edge already: the flip would pinch the surface
    const Eigen::Vector3d pa = point(s, a), pb = point(s, b), pc = point(s, c), pd = point(s, d);
    if (!(std::sqrt(ccd::segment_segment_distance2(pa, pb, pc, pd)) <= kFlat * std::min((pa - pb).norm(), (pc - pd).norm())))
      continue;
    // New triangles (a, d, c) and (d, b, c): the quad's boundary a → d → b → c, as it was.
    const Eigen::Vector3d n1 = (pb - pa).cross(pc - pa), n2 = (pa - pb).cross(pd - pb);
    const Eigen::Vector3d m1 = (pd - pa).cross(pc - pa), m2 = (pb - pd).cross(pc - pd);
    const Eigen::Vector3d mean = n1 + n2;
    auto cos_between = [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) { return x.dot(y) / (x.norm() * y.norm()); };
    if (!(m1.norm() > 1e-12 * mean.norm() && m2.norm() > 1e-12 * mean.norm() && m1.dot(mean) > 0.0 && m2.dot(mean) > 0.0))
      continue;
    if (!(cos_between(m1, m2) >= cos_between(n1, n2))) continue;  // no more folded than it was
    s.triangles.row(t1) << a, d, c;
    s.triangles.row(t2) << d, b, c;
    bool crosses = false;
    for (const Index t : {t1, t2}) {
      const Eigen::AlignedBox3d box = TriangleGrid::box(s, t);
      for (const TriangleGrid* grid : {&before_pass, static_cast<const TriangleGrid*>(&changed)}) {
        for (const Index g : grid->near(box))
          if (g != t1 && g != t2 && TriangleGrid::box(s, g).intersects(box) && triangles_intersect(s, t, g)) {
            crosses = true;
            break;
          }
        if (crosses) break;
      }
      if (!crosses && blockers) crosses = meets_blocker(s, t, box, *blockers, *blocker_grid);
      if (crosses) break;
    }
    if (crosses) {
      s.triangles.row(t1) << a, b, c;
      s.triangles.row(t2) << b, a, d;
      ++out.refused_crossing;
      continue;
    }
    touched[at(t1)] = touched[at(t2)] = 1;
    if (const std::ptrdiff_t i = find_edge(edge(a, b)); i >= 0) removed[static_cast<std::size_t>(i)] = 1;
    added.erase(edge(a, b));
    added.insert(edge(c, d));
    changed.insert(s, t1);
    changed.insert(s, t2);
    out.volume_change += std::abs((pb - pa).dot((pc - pa).cross(pd - pa))) / 6.0;
    ++out.flips;
  }
  if (out.flips > 0) {  // the flipped pairs entered anew; no triangle renumbered
    std::vector<Index> same(at(nt));
    for (Index t = 0; t < nt; ++t) same[at(t)] = t;
    surface_grid.renumber(s, same, touched);
  }
  return out;
}

}  // namespace

UpkeepReport upkeep_surface(TriangleMesh& surface, double h, const UpkeepSettings& settings,
                            const TriangleMesh* blockers) {
  if (!(settings.collapse_length >= 0.0) || !(settings.split_length > 2.0 * settings.collapse_length))
    throw Error("surface upkeep: split_length must exceed twice collapse_length (or edges would flip-flop)");
  UpkeepReport report;
  std::vector<Edge> long_edges = edges_beyond(surface, settings.split_length * h, true);
  for (int pass = 0; pass < settings.max_passes; ++pass) {
    const Index n = split_pass(surface, settings.split_length * h, long_edges);
    report.splits += n;
    if (n == 0) break;
  }
  const double cell = settings.split_length * h;
  const bool blocked = blockers != nullptr && blockers->num_triangles() > 0;
  const std::optional<TriangleGrid> blocker_grid =
      blocked ? std::optional<TriangleGrid>(TriangleGrid(*blockers, cell)) : std::nullopt;
  // One grid of the surface after the splits, kept up to date by the
  // passes that follow (each changes a few triangles).
  TriangleGrid grid(surface, cell);
  std::vector<Edge> short_edges = edges_beyond(surface, settings.collapse_length * h, false);
  for (int pass = 0; pass < settings.max_passes; ++pass) {
    const CollapsePass c = collapse_pass(surface, settings.collapse_length * h, cell, short_edges, grid,
                                         blocked ? blockers : nullptr, blocked ? &*blocker_grid : nullptr);
    report.collapses += c.collapses;
    report.refused += c.refused;
    report.refused_crossing += c.refused_crossing;
    report.volume_change_bound += c.volume_change;
    if (c.collapses == 0) break;
  }
  for (int pass = 0; settings.flips && pass < settings.max_passes; ++pass) {
    const FlipPass f =
        flip_pass(surface, cell, grid, blocked ? blockers : nullptr, blocked ? &*blocker_grid : nullptr);
    report.flips += f.flips;
    report.refused += f.refused_crossing;
    report.refused_crossing += f.refused_crossing;
    report.volume_change_bound += f.volume_change;
    if (f.flips == 0) break;
  }
  return report;
}

void order_surface(TriangleMesh& surface, double h) {
  const Index nv = surface.num_vertices(), nt = surface.num_triangles();
  if (nv == 0) return;
  if (!(h > 0.0) || !surface.vertices.allFinite())
    throw Error("surface order: the spacing must be positive and every vertex finite");
  // Cells of h / 16 from the surface's lower corner, 21 bits an axis (past
  // 2²¹ cells, 2²¹ · h / 16 ≈ 1.3 · 10⁵ h, the last cell).
  const Eigen::RowVector3d lo = surface.vertices.colwise().minCoeff();
  const double per_cell = 16.0 / h;
  constexpr double kLast = double((1u << 21) - 1);
  std::vector<std::uint64_t> code(at(nv));
  for_each_index(nv, [&](Index v) {
    std::uint64_t c = 0;
    std::array<std::uint32_t, 3> cell{};
    for (int k = 0; k < 3; ++k)
      cell[at(k)] =
          static_cast<std::uint32_t>(std::min(kLast, std::floor((surface.vertices(v, k) - lo[k]) * per_cell)));
    for (int bit = 20; bit >= 0; --bit)
      for (int k = 2; k >= 0; --k) c = (c << 1) | ((cell[at(k)] >> bit) & 1u);
    code[at(v)] = c;
  });
  std::vector<Index> order(at(nv));
  for (Index v = 0; v < nv; ++v) order[at(v)] = v;
  std::sort(order.begin(), order.end(), [&](Index a, Index b) {
    if (code[at(a)] != code[at(b)]) return code[at(a)] < code[at(b)];
    for (int k = 0; k < 3; ++k)
      if (surface.vertices(a, k) != surface.vertices(b, k)) return surface.vertices(a, k) < surface.vertices(b, k);
    return a < b;
  });
  std::vector<Index> renumbered(at(nv));
  Points vertices(nv, 3);
  for (Index i = 0; i < nv; ++i) {
    renumbered[at(order[at(i)])] = i;
    vertices.row(i) = surface.vertices.row(order[at(i)]);
  }
  std::vector<std::array<Index, 4>> keyed(at(nt));  // lowest corner, then the corners in their order
  for (Index t = 0; t < nt; ++t) {
    std::array<Index, 4>& k = keyed[at(t)];
    for (int c = 0; c < 3; ++c) k[at(c) + 1] = renumbered[at(surface.triangles(t, c))];
    k[0] = std::min({k[1], k[2], k[3]});
  }
  std::sort(keyed.begin(), keyed.end());
  surface.vertices = std::move(vertices);
  for (Index t = 0; t < nt; ++t)
    for (int c = 0; c < 3; ++c) surface.triangles(t, c) = keyed[at(t)][at(c) + 1];
}

}  // namespace goo
