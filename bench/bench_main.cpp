// goo_bench: Google Benchmark executable. Run with a pinned thread count
// (scripts/bench); never part of the test suite's pass/fail.
#include <benchmark/benchmark.h>

#include <cstdio>

#include "core/error.h"
#include "core/memory_budget.h"
#include "core/svd3_batch.h"

int main(int argc, char** argv) {
  goo::keep_freed_memory();  // as goo does: re-meshes reuse their buffers
  // The vector width comes from GOO_SIMD: a value it does not know is
  // refused here, as `goo` refuses it, before any benchmark runs.
  try {
    (void)goo::active_simd_level();
  } catch (const goo::Error& e) {
    std::fprintf(stderr, "goo_bench: %s\n", e.what());
    return 2;
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
