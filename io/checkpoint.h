#pragma once
// Checkpoints: a StateRecord in an HDF5 file (docs/output-format.md).
//
// Layout: a 512-byte user block (ignored by HDF5 readers) holding the format
// name, version, the length of the file and an FNV-1a 64 checksum of every
// byte after the block; then HDF5 1.10 (checksummed metadata) with
//   /            attributes format = "goo-checkpoint", format_version
//   /state/...   one dataset per array of the record (Fletcher32-checksummed,
//                chunked); a scalar is a 1-element dataset with attribute
//                scalar = 1; strings are 1-element string datasets.
// Written to a temporary file in the same folder, synced, then renamed, so
// an interrupted write leaves the previous checkpoint as it was.
#include <filesystem>
#include <functional>

#include "core/state_record.h"

namespace goo::io {

inline constexpr int kCheckpointFormatVersion = 1;

/// Writes `record` to `path` atomically. `before_rename` (tests) runs after
/// the temporary file is complete and before it replaces `path`; if it
/// throws, the temporary file is removed and `path` is untouched.
void write_checkpoint(const std::filesystem::path& path, const StateRecord& record,
                      const std::function<void()>& before_rename = {});

/// Reads a checkpoint back. A truncated, corrupt (checksum), foreign or
/// wrong-version file is refused with goo::Error naming the file and what
/// is wrong with it.
StateRecord read_checkpoint(const std::filesystem::path& path);

}  // namespace goo::io
