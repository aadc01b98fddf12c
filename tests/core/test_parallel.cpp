#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/parallel.h"
#include "core/types.h"

namespace goo {
namespace {

// The caches of a volume projection, a self-collision list and an obstacle
// index are kept while their inputs have the same bits: the parallel
// compare must find a difference anywhere (the first entry, the last, one
// inside a run, at a run's edge), in arrays shorter and longer than a run,
// and tell nothing else apart.
TEST(SameBits, FindsOneDifferentEntryWhereverItIs) {
  for (const std::size_t n :
       {std::size_t{1}, std::size_t{7}, std::size_t{4095}, std::size_t{4096}, std::size_t{4097}, std::size_t{100003}}) {
    std::vector<double> a(n);
    for (std::size_t i = 0; i < n; ++i) a[i] = std::sin(static_cast<double>(i));
    EXPECT_TRUE(same_bits(a, a)) << n;
    const std::vector<double> copy = a;
    EXPECT_TRUE(same_bits(a, copy)) << n;
    for (const std::size_t i : {std::size_t{0}, n / 2, n - 1, std::min(n - 1, std::size_t{4096})}) {
      std::vector<double> b = a;
      b[i] = std::nextafter(b[i], 2.0);  // one bit apart
      EXPECT_FALSE(same_bits(a, b)) << n << " at " << i;
    }
  }
  std::vector<double> shorter(10, 1.0), longer(11, 1.0);
  EXPECT_FALSE(same_bits(shorter, longer));
  EXPECT_TRUE(same_bits(std::vector<double>{}, std::vector<double>{}));
}

// Bits, not values: +0 and −0 differ (a result may depend on the sign), and
// a NaN equals itself (the same input gives the same result).
TEST(SameBits, ComparesBitsNotValues) {
  const std::vector<double> plus{0.0, 1.0}, minus{-0.0, 1.0};
  EXPECT_FALSE(same_bits(plus, minus));
  const std::vector<double> nan{std::numeric_limits<double>::quiet_NaN()};
  EXPECT_TRUE(same_bits(nan, nan));
}

// Eigen's plain objects: the shape counts, then every coefficient.
TEST(SameBits, ComparesEigenShapesAndCoefficients) {
  Points a = Points::Random(5000, 3);
  Points b = a;
  EXPECT_TRUE(same_bits(a, b));
  b(4999, 2) += 1.0;
  EXPECT_FALSE(same_bits(a, b));
  const Points c = a.topRows(4999);
  EXPECT_FALSE(same_bits(a, c));
  Tets t = Tets::Zero(3000, 4), u = t;
  EXPECT_TRUE(same_bits(t, u));
  u(1500, 3) = 1;
  EXPECT_FALSE(same_bits(t, u));
}

TEST(CopyInParallel, CopiesEveryEntryAndTheShape) {
  const Points a = Points::Random(12345, 3);
  Points b(2, 3);
  copy_in_parallel(a, b);
  EXPECT_EQ(b.rows(), a.rows());
  EXPECT_TRUE(same_bits(a, b));
  std::vector<std::uint8_t> flags(70001);
  for (std::size_t i = 0; i < flags.size(); ++i) flags[i] = static_cast<std::uint8_t>(i % 3);
  std::vector<std::uint8_t> copy(5, 9);
  copy_in_parallel(flags, copy);
  EXPECT_EQ(copy, flags);
}

// any_index answers exactly whatever the number of threads; a predicate
// true nowhere is tested everywhere.
TEST(AnyIndex, FindsTheOneIndexAndTestsEveryIndexWhenNone) {
  for (const int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    for (const Index target : {Index{0}, Index{511}, Index{512}, Index{99999}}) {
      EXPECT_TRUE(any_index(100000, [&](Index i) { return i == target; })) << target;
    }
    std::vector<std::uint8_t> tested(100000, 0);
    EXPECT_FALSE(any_index(100000, [&](Index i) {
      tested[at(i)] = 1;
      return false;
    }));
    EXPECT_EQ(std::count(tested.begin(), tested.end(), 1), 100000);
    EXPECT_FALSE(any_index(0, [](Index) { return true; }));
  }
}

// A maximum over fixed runs, in parallel: the serial maximum exactly, for
// counts shorter and longer than a run and on 1, 2 and 4 threads; 0 with
// nothing to take it over.
TEST(MaxOverRuns, IsTheSerialMaximumOnAnyThreadCount) {
  std::vector<double> x(10007);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = std::abs(std::sin(0.37 * static_cast<double>(i)));
  for (const int threads : {1, 2, 4}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    for (const Index count : {Index{1}, Index{100}, Index{4096}, Index{10007}}) {
      const double serial = *std::max_element(x.begin(), x.begin() + count);
      const double runs = max_over_runs(
          count, 256, [&](Index begin, Index end) { return *std::max_element(x.begin() + begin, x.begin() + end); });
      EXPECT_EQ(runs, serial) << count << " on " << threads;
    }
    EXPECT_EQ(max_over_runs(0, 256, [](Index, Index) { return 1.0; }), 0.0);
  }
}

}  // namespace
}  // namespace goo
