// goo_bench: Google Benchmark executable. Run with a pinned thread count
// (scripts/bench); never part of the test suite's pass/fail.
#include <benchmark/benchmark.h>

BENCHMARK_MAIN();
