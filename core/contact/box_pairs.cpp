#include "core/contact/box_pairs.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/parallel.h"
#include "core/radix_sort.h"

namespace goo {
namespace {

/// The grid: cubic cells of one size over the boxes' bounds, numbered
/// x-fastest in 32 bits; a box covers a range of cells on each axis.
struct Grid {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double cell = 1.0;
  std::array<std::int64_t, 3> dims{1, 1, 1};

  [[nodiscard]] std::int64_t coordinate(double x, int axis) const {
    const auto c = static_cast<std::int64_t>(std::floor((x - origin[axis]) / cell));
    return std::clamp<std::int64_t>(c, 0, dims[at(axis)] - 1);
  }
};

struct Range {
  std::array<std::int32_t, 3> lo, hi;  // cells covered on each axis, inclusive
  [[nodiscard]] std::int64_t count() const {
    return std::int64_t(hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1);
  }
};

/// Cells this many times the mean largest box extent: a box covers two or
/// three cells on an axis instead of three or four, and the grid holds a
/// third as many entries. (Measured on the built-in demo's list builds,
/// 75k triangles: 16.5 ms a build at 1×, 13.0 at 2×, 13.1 at 3×.)
constexpr double kCellScale = 2.0;

/// Cell size: kCellScale × the mean largest box extent, grown until the boxes cover at
/// most 16 cells each on average and the grid has fewer than 2³¹ cells.
Grid make_grid(const std::vector<const Box3*>& boxes) {
  Grid g;
  Box3 all;
  double extent = 0.0;
  for (const Box3* b : boxes) {
    all.extend(*b);
    extent += b->sizes().maxCoeff();
  }
  g.origin = all.min();
  const double n = double(boxes.size());
  g.cell = std::max({kCellScale * extent / n, all.sizes().maxCoeff() * 1e-6, 1e-300});
  while (true) {
    double cells = 1.0;
    for (int k = 0; k < 3; ++k) cells *= std::floor(all.sizes()[k] / g.cell) + 1.0;
    double entries = 0.0;
    if (cells < 2147483647.0) {
      for (int k = 0; k < 3; ++k) g.dims[at(k)] = static_cast<std::int64_t>(std::floor(all.sizes()[k] / g.cell)) + 1;
      for (const Box3* b : boxes) {
        double c = 1.0;
        for (int k = 0; k < 3; ++k)
          c *= double(g.coordinate(b->max()[k], k) - g.coordinate(b->min()[k], k) + 1);
        entries += c;
      }
      if (entries <= 16.0 * n) break;
    }
    g.cell *= 2.0;
  }
  return g;
}

/// Pairs of overlapping boxes among `boxes`; with `split` ≥ 0, only pairs of
/// one box below `split` and one at or above it (reported as (i, j − split)).
std::vector<std::array<Index, 2>> find_pairs(const std::vector<const Box3*>& boxes, Index split,
                                             const std::vector<Index>* groups) {
  // The non-empty boxes; with groups, those of one group next to each other
  // (by group, then by box; the boxes of no group last), so that in every
  // cell below a group's boxes form one run, skipped as a whole.
  std::vector<Index> live;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (!boxes[i]->isEmpty()) live.push_back(static_cast<Index>(i));
  if (live.size() < 2) return {};
  std::vector<Index> group_of;  // per live box, its group (−1: none)
  if (groups) {
    Index largest = -1;
    for (const Index i : live) largest = std::max(largest, (*groups)[at(i)]);
    std::vector<Index> start(at(largest) + 2, 0);  // counting sort by group, the ungrouped last
    auto slot = [&](Index i) { const Index g = (*groups)[at(i)]; return g >= 0 ? g : largest + 1; };
    for (const Index i : live) ++start[at(slot(i))];
    Index sum = 0;
    for (Index& c : start) sum += std::exchange(c, sum);
    std::vector<Index> ordered(live.size());
    for (const Index i : live) ordered[at(start[at(slot(i))]++)] = i;
    live.swap(ordered);
    group_of.resize(live.size());
    for (std::size_t k = 0; k < live.size(); ++k) group_of[k] = (*groups)[at(live[k])];
  }
  std::vector<const Box3*> live_boxes(live.size());
  for (std::size_t k = 0; k < live.size(); ++k) live_boxes[k] = boxes[at(live[k])];
  const Grid g = make_grid(live_boxes);

  // Each box's cells, then (cell << bits | box) for every cell it covers.
  const std::size_t n = live.size();
  int bits = 1;
  while ((std::size_t{1} << bits) < n) ++bits;
  const std::uint64_t box_mask = (std::uint64_t{1} << bits) - 1;
  std::vector<Range> range(n);
  std::vector<std::int64_t> offset(n + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      for (int k = 0; k < 3; ++k) {
        range[i].lo[at(k)] = static_cast<std::int32_t>(g.coordinate(live_boxes[i]->min()[k], k));
        range[i].hi[at(k)] = static_cast<std::int32_t>(g.coordinate(live_boxes[i]->max()[k], k));
      }
      offset[i + 1] = range[i].count();
    }
  });
  for (std::size_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
  std::vector<std::uint64_t> entries(static_cast<std::size_t>(offset[n]));
  auto cell_id = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::uint64_t>(x + g.dims[0] * (y + g.dims[1] * z));
  };
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      auto e = static_cast<std::size_t>(offset[i]);
      const Range& c = range[i];
      for (std::int32_t z = c.lo[2]; z <= c.hi[2]; ++z)
        for (std::int32_t y = c.lo[1]; y <= c.hi[1]; ++y)
          for (std::int32_t x = c.lo[0]; x <= c.hi[0]; ++x) entries[e++] = (cell_id(x, y, z) << bits) | i;
    }
  });
  radix_sort(entries, [](std::uint64_t k) { return k; });  // distinct keys: one order for any thread count
  std::vector<std::size_t> run_start;
  for (std::size_t e = 0; e < entries.size(); ++e)
    if (e == 0 || (entries[e] >> bits) != (entries[e - 1] >> bits)) run_start.push_back(e);
  run_start.push_back(entries.size());

  // Each pair is reported by one cell: the one of the lower corner of the
  // two boxes' overlap, which both cover. A cell's boxes are first copied
  // side by side (bounds per axis, their cell ranges' lower corners), so
  // that its pairs are tested without reaching into the boxes' arrays.
  const std::size_t runs = run_start.size() - 1, grain = 256;
  std::vector<std::vector<std::array<Index, 2>>> found((runs + grain - 1) / grain);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    auto& out = found[chunk];
    std::array<std::vector<double>, 3> lo, hi;
    std::array<std::vector<std::int32_t>, 3> first_cell;
    std::vector<std::size_t> id;
    for (std::size_t r = chunk * grain; r < std::min(runs, (chunk + 1) * grain); ++r) {
      const std::size_t begin = run_start[r], end = run_start[r + 1], m = end - begin;
      const std::uint64_t cell = entries[begin] >> bits;
      id.resize(m);
      for (int k = 0; k < 3; ++k) {
        lo[at(k)].resize(m), hi[at(k)].resize(m), first_cell[at(k)].resize(m);
      }
      for (std::size_t x = 0; x < m; ++x) {
        const std::size_t i = entries[begin + x] & box_mask;
        id[x] = i;
        for (int k = 0; k < 3; ++k) {
          lo[at(k)][x] = live_boxes[i]->min()[k];
          hi[at(k)][x] = live_boxes[i]->max()[k];
          first_cell[at(k)][x] = range[i].lo[at(k)];
        }
      }
      // With a split the first side's boxes come first in a cell (sorted by
      // box): pair them with the second side's only.
      std::size_t second = 0;
      if (split >= 0)
        while (second < m && live[id[second]] < split) ++second;
      const std::size_t first_end = split >= 0 ? second : m;
      for (std::size_t x = 0; x < first_end;) {
        // The run of x's group in this cell (x alone if it has none): its
        // boxes are paired with those after it only.
        std::size_t block_end = x + 1;
        if (groups) {
          const Index group = group_of[id[x]];
          if (group >= 0)
            while (block_end < first_end && group_of[id[block_end]] == group) ++block_end;
        }
        for (; x < block_end; ++x) {
          const double lx = lo[0][x], ly = lo[1][x], lz = lo[2][x], hx = hi[0][x], hy = hi[1][x], hz = hi[2][x];
          // Box y met box x: report the pair if this cell is the one of
          // their overlap's lower corner.
          auto met = [&](std::size_t y) {
            if (cell_id(std::max(first_cell[0][x], first_cell[0][y]), std::max(first_cell[1][x], first_cell[1][y]),
                        std::max(first_cell[2][x], first_cell[2][y])) != cell)
              return;
            const Index s = live[id[x]], t = live[id[y]];
            out.push_back(split >= 0 ? std::array<Index, 2>{s, t - split}
                                     : std::array<Index, 2>{std::min(s, t), std::max(s, t)});
          };
          // Closed boxes overlap (touching counts) where they do on every
          // axis: all six tests at once, without a branch per axis, two
          // boxes y at a time in the vector registers every x86-64 has (the
          // same comparisons, so the same pairs in the same order).
          std::size_t y = split >= 0 ? second : block_end;
#if defined(__SSE2__)
          const __m128d Lx = _mm_set1_pd(lx), Ly = _mm_set1_pd(ly), Lz = _mm_set1_pd(lz);
          const __m128d Hx = _mm_set1_pd(hx), Hy = _mm_set1_pd(hy), Hz = _mm_set1_pd(hz);
          for (; y + 2 <= m; y += 2) {
            __m128d meet =
                _mm_and_pd(_mm_cmple_pd(Lx, _mm_loadu_pd(&hi[0][y])), _mm_cmple_pd(_mm_loadu_pd(&lo[0][y]), Hx));
            meet = _mm_and_pd(
                meet, _mm_and_pd(_mm_cmple_pd(Ly, _mm_loadu_pd(&hi[1][y])), _mm_cmple_pd(_mm_loadu_pd(&lo[1][y]), Hy)));
            meet = _mm_and_pd(
                meet, _mm_and_pd(_mm_cmple_pd(Lz, _mm_loadu_pd(&hi[2][y])), _mm_cmple_pd(_mm_loadu_pd(&lo[2][y]), Hz)));
            const int both = _mm_movemask_pd(meet);
            if (both & 1) met(y);
            if (both & 2) met(y + 1);
          }
#endif
          for (; y < m; ++y)
            if ((lx <= hi[0][y]) & (lo[0][y] <= hx) & (ly <= hi[1][y]) & (lo[1][y] <= hy) & (lz <= hi[2][y]) &
                (lo[2][y] <= hz))
              met(y);
        }
      }
    }
  });
  std::size_t total = 0;
  for (const auto& f : found) total += f.size();
  std::vector<std::array<Index, 2>> pairs;
  pairs.reserve(total);
  for (const auto& f : found) pairs.insert(pairs.end(), f.begin(), f.end());
  return pairs;
}

}  // namespace

std::vector<std::array<Index, 2>> overlapping_pairs(const std::vector<Box3>& boxes, const std::vector<Index>* groups) {
  std::vector<const Box3*> all;
  all.reserve(boxes.size());
  for (const Box3& b : boxes) all.push_back(&b);
  return find_pairs(all, -1, groups);
}

std::vector<std::array<Index, 2>> overlapping_pairs(const std::vector<Box3>& a, const std::vector<Box3>& b) {
  std::vector<const Box3*> all;
  all.reserve(a.size() + b.size());
  for (const Box3& x : a) all.push_back(&x);
  for (const Box3& x : b) all.push_back(&x);
  return find_pairs(all, static_cast<Index>(a.size()), nullptr);
}

}  // namespace goo
