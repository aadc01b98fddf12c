#pragma once
// What every per-element and per-node TBB loop of goo shares.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

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

}  // namespace goo
