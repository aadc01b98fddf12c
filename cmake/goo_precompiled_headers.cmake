# Precompiled headers: the third-party headers nearly every translation unit
# of a target parses (Eigen, fmt, TBB, parts of the standard library; gtest
# and gmock in the tests) are parsed once per target instead of once per
# file. A file that includes only them costs about 7 s under the sanitizers
# and 2.5 s with them precompiled. GOO_PCH=OFF builds without (each file
# then compiles from its own includes alone, which is how to check them).
option(GOO_PCH "Precompile the common third-party headers of each target" ON)

set(GOO_PCH_HEADERS
  <algorithm> <array> <cmath> <cstdint> <filesystem> <limits> <random> <string> <vector>
  <Eigen/Dense> <fmt/format.h> <tbb/blocked_range.h> <tbb/parallel_for.h>)

# goo_precompile_headers(target [extra headers...]): for a target of five
# files or more. Compiling the headers costs about two files' time (15 s in
# release, 10 s under the sanitizers), which a smaller target does not win back.
function(goo_precompile_headers target)
  get_target_property(sources ${target} SOURCES)
  list(LENGTH sources count)
  if(GOO_PCH AND count GREATER_EQUAL 5)
    target_precompile_headers(${target} PRIVATE ${GOO_PCH_HEADERS} ${ARGN})
  endif()
endfunction()
