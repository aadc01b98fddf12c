#include "core/contact/box_pairs.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "core/parallel.h"

namespace goo {
namespace {

/// The grid: cells of one size, keys packed from 21 bits an axis.
struct Grid {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double cell = 1.0;

  [[nodiscard]] std::array<std::int64_t, 3> cell_of(const Eigen::Vector3d& p) const {
    std::array<std::int64_t, 3> c{};
    for (int k = 0; k < 3; ++k) c[at(k)] = static_cast<std::int64_t>(std::floor((p[k] - origin[k]) / cell));
    return c;
  }
  [[nodiscard]] static std::uint64_t key(std::int64_t i, std::int64_t j, std::int64_t k) {
    return (static_cast<std::uint64_t>(i) << 42) | (static_cast<std::uint64_t>(j) << 21) | static_cast<std::uint64_t>(k);
  }
  [[nodiscard]] double cells_covered(const Box3& box) const {
    const auto lo = cell_of(box.min()), hi = cell_of(box.max());
    return double(hi[0] - lo[0] + 1) * double(hi[1] - lo[1] + 1) * double(hi[2] - lo[2] + 1);
  }
};

/// Cell size: the mean largest box extent, grown until the grid has at most
/// 2²⁰ cells an axis and the boxes cover at most 16 cells each on average.
Grid make_grid(const std::vector<const Box3*>& boxes) {
  Grid g;
  Box3 all;
  double extent = 0.0;
  for (const Box3* b : boxes) {
    all.extend(*b);
    extent += b->sizes().maxCoeff();
  }
  g.origin = all.min();
  const double n = double(std::max<std::size_t>(boxes.size(), 1));
  g.cell = std::max({extent / n, all.sizes().maxCoeff() / double(1 << 20), 1e-300});
  while (true) {
    double entries = 0.0;
    for (const Box3* b : boxes) entries += g.cells_covered(*b);
    if (entries <= 16.0 * n) break;
    g.cell *= 2.0;
  }
  return g;
}

bool overlap(const Box3& a, const Box3& b) {
  return (a.min().array() <= b.max().array()).all() && (b.min().array() <= a.max().array()).all();
}

/// Pairs of boxes overlapping, among `boxes`; with `split` ≥ 0, only pairs of
/// one box below `split` and one at or above it (then reported as
/// (i, j − split)).
std::vector<std::array<Index, 2>> find_pairs(const std::vector<const Box3*>& boxes, Index split) {
  std::vector<std::pair<std::uint64_t, Index>> entries;
  std::vector<const Box3*> live;
  for (const Box3* b : boxes)
    if (!b->isEmpty()) live.push_back(b);
  if (live.size() < 2) return {};
  const Grid g = make_grid(live);
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const Box3& b = *boxes[i];
    if (b.isEmpty()) continue;
    const auto lo = g.cell_of(b.min()), hi = g.cell_of(b.max());
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) entries.emplace_back(Grid::key(x, y, z), static_cast<Index>(i));
  }
  tbb::parallel_sort(entries.begin(), entries.end());  // distinct entries: one order for any thread count
  std::vector<std::size_t> run_start;
  for (std::size_t e = 0; e < entries.size(); ++e)
    if (e == 0 || entries[e].first != entries[e - 1].first) run_start.push_back(e);
  run_start.push_back(entries.size());

  const std::size_t runs = run_start.size() - 1, grain = 64;
  std::vector<std::vector<std::array<Index, 2>>> found((runs + grain - 1) / grain);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    auto& out = found[chunk];
    for (std::size_t r = chunk * grain; r < std::min(runs, (chunk + 1) * grain); ++r) {
      const std::uint64_t cell = entries[run_start[r]].first;
      const std::size_t begin = run_start[r], end = run_start[r + 1];
      // With a split, the first side's boxes come first in a cell (sorted by
      // box): pair them with the second side's only.
      std::size_t second = begin;
      if (split >= 0)
        while (second < end && entries[second].second < split) ++second;
      for (std::size_t x = begin; x < (split >= 0 ? second : end); ++x) {
        const Index s = entries[x].second;
        for (std::size_t y = split >= 0 ? second : x + 1; y < end; ++y) {
          const Index t = entries[y].second;  // s < t: entries of a cell are sorted by box
          const Box3 &bs = *boxes[at(s)], &bt = *boxes[at(t)];
          if (!overlap(bs, bt)) continue;
          const auto c = g.cell_of(bs.min().cwiseMax(bt.min()));
          if (Grid::key(c[0], c[1], c[2]) != cell) continue;
          out.push_back(split >= 0 ? std::array<Index, 2>{s, t - split} : std::array<Index, 2>{s, t});
        }
      }
    }
  });
  std::vector<std::array<Index, 2>> pairs;
  for (const auto& f : found) pairs.insert(pairs.end(), f.begin(), f.end());
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

}  // namespace

std::vector<std::array<Index, 2>> overlapping_pairs(const std::vector<Box3>& boxes) {
  std::vector<const Box3*> all;
  all.reserve(boxes.size());
  for (const Box3& b : boxes) all.push_back(&b);
  return find_pairs(all, -1);
}

std::vector<std::array<Index, 2>> overlapping_pairs(const std::vector<Box3>& a, const std::vector<Box3>& b) {
  std::vector<const Box3*> all;
  all.reserve(a.size() + b.size());
  for (const Box3& x : a) all.push_back(&x);
  for (const Box3& x : b) all.push_back(&x);
  return find_pairs(all, static_cast<Index>(a.size()));
}

}  // namespace goo
