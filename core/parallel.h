#pragma once
// What every per-element and per-node TBB loop of goo shares.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>

#include <algorithm>
#include <cstddef>

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

}  // namespace goo
