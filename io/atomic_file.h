#pragma once
// Writing a file so that a failure never leaves a half-written file behind or
// destroys the previous version: write beside it, flush, rename over it.
#include <filesystem>
#include <functional>
#include <ostream>

namespace goo::io {

/// Calls `write` with a binary stream onto a temporary file in the same
/// folder, then renames it to `path`. On any failure (the callback throws,
/// the disk fills) the temporary file is removed, `path` is untouched, and
/// goo::Error names the file.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

}  // namespace goo::io
