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
#include <memory>

#include "core/state_record.h"

namespace goo::io {

inline constexpr int kCheckpointFormatVersion = 1;

/// Writes a checkpoint to `path` atomically, each array as it is put: the
/// state is never held twice. Nothing replaces `path` until commit(); a
/// writer destroyed before then (an error, a stop) removes its temporary
/// file and leaves `path` as it was.
class CheckpointWriter final : public StateSink {
 public:
  explicit CheckpointWriter(std::filesystem::path path);
  ~CheckpointWriter() override;
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;
  CheckpointWriter(CheckpointWriter&&) = delete;
  CheckpointWriter& operator=(CheckpointWriter&&) = delete;

  void put_array(const std::string& name, StateArray array) override;
  void put_string(const std::string& name, std::string value) override;
  /// Completes the file and renames it over `path`. `before_rename` (tests)
  /// runs after the temporary file is complete; if it throws, the temporary
  /// file is removed and `path` is untouched.
  void commit(const std::function<void()>& before_rename = {});

 protected:
  /// Writes a chunk of rows at a time: a block of 64k values is all it holds.
  void put_rows(const std::string& name, std::vector<std::size_t> shape, bool integer, const RowFiller& fill) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes `record` to `path` atomically (a CheckpointWriter). `before_rename` (tests) runs after
/// the temporary file is complete and before it replaces `path`; if it
/// throws, the temporary file is removed and `path` is untouched.
void write_checkpoint(const std::filesystem::path& path, const StateRecord& record,
                      const std::function<void()>& before_rename = {});

/// Reads a checkpoint back. A truncated, corrupt (checksum), foreign or
/// wrong-version file is refused with goo::Error naming the file and what
/// is wrong with it.
StateRecord read_checkpoint(const std::filesystem::path& path);

}  // namespace goo::io
