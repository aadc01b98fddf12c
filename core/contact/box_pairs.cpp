#include "core/contact/box_pairs.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/parallel.h"

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

/// Cell size: the mean largest box extent, grown until the boxes cover at
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
  g.cell = std::max({extent / n, all.sizes().maxCoeff() * 1e-6, 1e-300});
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

bool overlap(const Box3& a, const Box3& b) {
  return (a.min().array() <= b.max().array()).all() && (b.min().array() <= a.max().array()).all();
}

/// Pairs of overlapping boxes among `boxes`; with `split` ≥ 0, only pairs of
/// one box below `split` and one at or above it (reported as (i, j − split)).
std::vector<std::array<Index, 2>> find_pairs(const std::vector<const Box3*>& boxes, Index split,
                                             const std::vector<Index>* groups) {
  std::vector<Index> live;
  std::vector<const Box3*> live_boxes;
  for (std::size_t i = 0; i < boxes.size(); ++i)
    if (!boxes[i]->isEmpty()) {
      live.push_back(static_cast<Index>(i));
      live_boxes.push_back(boxes[i]);
    }
  if (live.size() < 2) return {};
  const Grid g = make_grid(live_boxes);

  // Each box's cells, then (cell << 32 | box) for every cell it covers.
  const std::size_t n = live.size();
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
          for (std::int32_t x = c.lo[0]; x <= c.hi[0]; ++x) entries[e++] = (cell_id(x, y, z) << 32) | i;
    }
  });
  tbb::parallel_sort(entries.begin(), entries.end());  // distinct keys: one order for any thread count
  std::vector<std::size_t> run_start;
  for (std::size_t e = 0; e < entries.size(); ++e)
    if (e == 0 || (entries[e] >> 32) != (entries[e - 1] >> 32)) run_start.push_back(e);
  run_start.push_back(entries.size());

  // Each pair is reported by one cell: the one of the lower corner of the
  // two boxes' overlap, which both cover.
  const std::size_t runs = run_start.size() - 1, grain = 256;
  std::vector<std::vector<std::array<Index, 2>>> found((runs + grain - 1) / grain);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    auto& out = found[chunk];
    for (std::size_t r = chunk * grain; r < std::min(runs, (chunk + 1) * grain); ++r) {
      const std::size_t begin = run_start[r], end = run_start[r + 1];
      const std::uint64_t cell = entries[begin] >> 32;
      // With a split the first side's boxes come first in a cell (sorted by
      // box): pair them with the second side's only.
      std::size_t second = begin;
      if (split >= 0)
        while (second < end && live[entries[second] & 0xffffffffU] < split) ++second;
      for (std::size_t x = begin; x < (split >= 0 ? second : end); ++x) {
        const std::size_t i = entries[x] & 0xffffffffU;
        for (std::size_t y = split >= 0 ? second : x + 1; y < end; ++y) {
          const std::size_t j = entries[y] & 0xffffffffU;
          if (groups) {
            const Index group = (*groups)[at(live[i])];
            if (group >= 0 && group == (*groups)[at(live[j])]) continue;
          }
          if (!overlap(*live_boxes[i], *live_boxes[j])) continue;
          const Range &a = range[i], &b = range[j];
          if (cell_id(std::max(a.lo[0], b.lo[0]), std::max(a.lo[1], b.lo[1]), std::max(a.lo[2], b.lo[2])) != cell)
            continue;
          const Index s = live[i], t = live[j];
          out.push_back(split >= 0 ? std::array<Index, 2>{s, t - split} : std::array<Index, 2>{s, t});
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
