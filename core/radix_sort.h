#pragma once
// A stable least-significant-digit radix sort on 64-bit keys: 11-bit
// digits, one pass per digit in which some key differs from the others
// (the digits every key shares are skipped). Items of equal keys keep their
// order, so the result is the same on any machine and thread count.
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace goo {

/// Sorts `items` by key(item) ascending, stably.
template <class T, class Key>
void radix_sort(std::vector<T>& items, Key&& key) {
  constexpr int kBits = 11;
  constexpr std::uint64_t kMask = (std::uint64_t{1} << kBits) - 1;
  std::uint64_t any = 0, all = ~std::uint64_t{0};
  for (const T& item : items) {
    const std::uint64_t k = key(item);
    any |= k, all &= k;
  }
  const std::uint64_t varying = any ^ all;
  std::vector<T> scratch(items.size());
  for (int shift = 0; shift < 64; shift += kBits) {
    if (((varying >> shift) & kMask) == 0) continue;
    std::array<std::size_t, kMask + 1> start{};
    for (const T& item : items) ++start[(key(item) >> shift) & kMask];
    std::size_t sum = 0;
    for (std::size_t& c : start) sum += std::exchange(c, sum);
    for (const T& item : items) scratch[start[(key(item) >> shift) & kMask]++] = item;
    items.swap(scratch);
  }
}

}  // namespace goo
