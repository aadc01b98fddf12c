#pragma once
// A checkpoint's fields are read and checked by code that knows no file
// names (StateRecord, Simulation::load): what it refuses is named by the
// checkpoint here, so every message says which file is at fault.
#include <fmt/format.h>

#include <string>
#include <string_view>

#include "core/error.h"

namespace goo::app {

/// Calls `read`; a goo::Error it throws comes back prefixed with
/// `checkpoint` (and `what`, the part of it being read), unless its message
/// names the file already.
template <class Read>
decltype(auto) reading_checkpoint(const std::string& checkpoint, std::string_view what, Read&& read) {
  try {
    return read();
  } catch (const WriteError&) {
    throw;
  } catch (const Error& e) {
    if (std::string_view(e.what()).find(checkpoint) != std::string_view::npos) throw;
    throw Error(fmt::format("{}: {}{}", checkpoint, what, e.what()));
  }
}

}  // namespace goo::app
