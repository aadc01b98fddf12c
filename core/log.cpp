#include "core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace goo {

spdlog::logger& log() {
  // Function-local static: thread-safe initialisation, no global constructor.
  static const std::shared_ptr<spdlog::logger> logger = [] {
    auto existing = spdlog::get("goo");
    if (existing) return existing;
    auto created = spdlog::stderr_color_mt("goo");
    created->set_pattern("[%l] %v");
    return created;
  }();
  return *logger;
}

}  // namespace goo
