#pragma once
// What every per-element and per-node TBB loop of goo shares.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstring>
#include <vector>

#include "core/types.h"

namespace goo {

/// Fixed grain of parallel loops: work splits the same way whatever the
/// thread count (results never depend on it; this keeps scheduling cheap).
inline constexpr Index kParallelGrain = 512;

/// An Index as a std::vector subscript.
inline std::size_t at(Index i) {
  return static_cast<std::size_t>(i);
}

/// f(i) for every i in [0, count), in parallel over runs of `grain`: for
/// loops where each i writes only its own results.
template <class F>
void for_each_index(Index count, F&& f, std::size_t grain = kParallelGrain) {
  tbb::parallel_for(tbb::blocked_range<Index>(0, count, grain), [&](const tbb::blocked_range<Index>& r) {
    for (Index i = r.begin(); i != r.end(); ++i) f(i);
  });
}

/// f(run, begin, end) for each fixed run [run·size, min(count, (run + 1)·size))
/// of [0, count), in parallel, the runs split evenly between the arena's
/// threads in order (a static partition: the same nodes go to the same
/// thread at every call). For the passes of an iterative solve: each thread
/// then reads mostly the entries it wrote itself in the pass before, where
/// an uneven split (and vector operations on the calling thread) had the
/// other thread fetch them from the first's cache at every iteration
/// (docs/benchmarks.md, session 36). A sum kept per run and then added run
/// by run has the same bits for any number of threads.
template <class F>
void for_each_run(Index count, Index size, F&& f) {
  const Index runs = (count + size - 1) / size;
  tbb::parallel_for(
      tbb::blocked_range<Index>(0, runs, 1),
      [&](const tbb::blocked_range<Index>& range) {
        for (Index run = range.begin(); run != range.end(); ++run)
          f(run, run * size, std::min(count, (run + 1) * size));
      },
      tbb::static_partitioner());
}

/// Whether pred(i) holds for some i in [0, count), tested in parallel over
/// runs of `grain` (a run stops once another has found one). The answer is
/// exact whatever the order.
template <class Pred>
bool any_index(Index count, Pred&& pred, std::size_t grain = kParallelGrain) {
  std::atomic<bool> found{false};
  tbb::parallel_for(tbb::blocked_range<Index>(0, count, grain), [&](const tbb::blocked_range<Index>& r) {
    if (found.load(std::memory_order_relaxed)) return;
    for (Index i = r.begin(); i != r.end(); ++i)
      if (pred(i)) {
        found.store(true, std::memory_order_relaxed);
        return;
      }
  });
  return found.load();
}

/// The largest of largest_in(begin, end) over the fixed runs [run·size,
/// min(count, (run + 1)·size)) of [0, count), the runs in parallel, and 0
/// if that is larger (a maximum is exact in any order: the same on any
/// thread count). largest_in returns at least 0 and no NaN.
template <class F>
double max_over_runs(Index count, Index size, F&& largest_in) {
  const Index runs = (count + size - 1) / size;
  std::vector<double> largest(at(runs), 0.0);
  tbb::parallel_for(tbb::blocked_range<Index>(0, runs, 1), [&](const tbb::blocked_range<Index>& r) {
    for (Index run = r.begin(); run != r.end(); ++run)
      largest[at(run)] = largest_in(run * size, std::min(count, (run + 1) * size));
  });
  double out = 0.0;
  for (const double x : largest) out = std::max(out, x);
  return out;
}

/// Whether the n entries at a and at b (numbers, or fixed blocks of them:
/// no padding) have the same bits, compared in parallel runs: the checks of
/// "the same mesh, the same positions" that keep a preparation (equal bits
/// give the same results; a serial compare of a megabyte was a tenth of a
/// volume projection).
template <class T>
bool same_bits(const T* a, const T* b, std::size_t n) {
  constexpr std::size_t kRunBytes = std::size_t{1} << 15;
  const std::size_t bytes = n * sizeof(T);
  const auto* p = reinterpret_cast<const unsigned char*>(a);
  const auto* q = reinterpret_cast<const unsigned char*>(b);
  return !any_index(
      static_cast<Index>((bytes + kRunBytes - 1) / kRunBytes),
      [&](Index run) {
        const std::size_t begin = at(run) * kRunBytes, length = std::min(bytes, begin + kRunBytes) - begin;
        return std::memcmp(p + begin, q + begin, length) != 0;
      },
      1);
}

/// Eigen's plain matrices and vectors: the same shape and the same bits.
template <class Matrix>
bool same_bits(const Matrix& a, const Matrix& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         same_bits(a.data(), b.data(), static_cast<std::size_t>(a.size()));
}

/// std::vector: the same size and the same bits.
template <class T, class A>
bool same_bits(const std::vector<T, A>& a, const std::vector<T, A>& b) {
  return a.size() == b.size() && same_bits(a.data(), b.data(), a.size());
}

/// to = from, the entries copied in parallel (Eigen's plain matrices and std::vector).
template <class Matrix>
void copy_in_parallel(const Matrix& from, Matrix& to) {
  if constexpr (requires { from.rows(); }) {
    to.resize(from.rows(), from.cols());
  } else {
    to.resize(from.size());
  }
  constexpr std::size_t kRun = 4096;
  const auto n = static_cast<std::size_t>(from.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kRun), [&](const tbb::blocked_range<std::size_t>& r) {
    std::copy(from.data() + r.begin(), from.data() + r.end(), to.data() + r.begin());
  });
}

}  // namespace goo
