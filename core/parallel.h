#pragma once
// What every per-element and per-node TBB loop of goo shares.
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

}  // namespace goo
