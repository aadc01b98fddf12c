#include "core/memory_budget.h"

#include <fmt/format.h>
#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

#include "core/error.h"

namespace goo {
namespace {

/// The number in `path` (cgroup v2 memory.max, v1 limit_in_bytes), or 0
/// when there is none ("max", absent).
std::uint64_t number_in(const char* path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text.empty() || !std::isdigit(static_cast<unsigned char>(text[0]))) return 0;
  return std::strtoull(text.c_str(), nullptr, 10);
}

std::uint64_t parse_limit(const std::string& text) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  std::string unit = text.substr(used);
  if (!unit.empty() && (unit.back() == 'B' || unit.back() == 'b')) unit.pop_back();
  double scale = 0.0;
  if (unit.empty()) scale = 1.0;
  else if (unit == "K" || unit == "k") scale = 1024.0;
  else if (unit == "M" || unit == "m") scale = 1024.0 * 1024.0;
  else if (unit == "G" || unit == "g") scale = 1024.0 * 1024.0 * 1024.0;
  else if (unit == "T" || unit == "t") scale = 1024.0 * 1024.0 * 1024.0 * 1024.0;
  const double bytes = value * scale;
  if (used == 0 || scale == 0.0 || !(bytes >= 1.0 && bytes < 1.8e19))
    throw Error(fmt::format("GOO_MEMORY_LIMIT must be a size in bytes (a K, M, G or T suffix allowed), got '{}'", text));
  return static_cast<std::uint64_t>(bytes);
}

}  // namespace

void keep_freed_memory() {
#if defined(__GLIBC__)
  // The largest mmap threshold glibc accepts (HEAP_MAX_SIZE / 2 on 64-bit).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

std::uint64_t memory_limit_bytes() {
  if (const char* text = std::getenv("GOO_MEMORY_LIMIT"); text != nullptr) return parse_limit(text);
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  std::uint64_t limit = pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page)
                                              : ~std::uint64_t{0};
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"})
    if (const std::uint64_t group = number_in(path); group > 0) limit = std::min(limit, group);
  return limit;
}

std::string format_bytes(double bytes) {
  if (bytes >= 1e15) return fmt::format("{:.3g} PB", bytes / 1e15);
  if (bytes >= 1e12) return fmt::format("{:.3g} TB", bytes / 1e12);
  if (bytes >= 1e9) return fmt::format("{:.3g} GB", bytes / 1e9);
  if (bytes >= 1e6) return fmt::format("{:.3g} MB", bytes / 1e6);
  return fmt::format("{:.3g} kB", bytes / 1e3);
}

}  // namespace goo
