#pragma once
// The one logger of the goo libraries. Library code never prints; it logs here.
#include <spdlog/spdlog.h>

namespace goo {

/// The shared "goo" logger (created on first use, stderr sink). Applications
/// may change its level or sinks once, at start-up.
spdlog::logger& log();

}  // namespace goo
