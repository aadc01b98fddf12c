#pragma once
// Writing a file so that a failure never leaves a half-written file behind or
// destroys the previous version: write beside it, flush, rename over it.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string_view>

namespace goo::io {

/// Calls `write` with a binary stream onto a temporary file in the same
/// folder, then renames it to `path`. On any failure (the callback throws,
/// the disk fills) the temporary file is removed, `path` is untouched, and
/// goo::Error names the file. The temporary file has an unpredictable name
/// and is created exclusively, never through a link planted in its place.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

/// A name beside `path` for a temporary file of it: ".NAME.tmp-PID-RANDOM".
std::filesystem::path temporary_name(const std::filesystem::path& path);

/// goo::Error unless `path` is a regular file (after following links): a
/// FIFO would block, a device (/dev/zero) never end, a folder fail late.
/// `what` names the file's role in the message ("the scene file").
void require_regular_file(const std::filesystem::path& path, std::string_view what);

}  // namespace goo::io
