#include "io/checkpoint.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include "core/error.h"
#include "io/atomic_file.h"
#include "io/detail/hdf5_handle.h"

namespace goo::io {

namespace {

using detail::H5Handle;
using detail::io_reason;

constexpr std::size_t kUserBlock = 512;
constexpr const char* kMagic = "goo-checkpoint";

/// FNV-1a, 64 bits, over a byte range.
std::uint64_t fnv1a(const char* data, std::size_t size, std::uint64_t hash = 0xcbf29ce484222325ULL) {
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(data[i]);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

/// FNV-1a of the bytes of `path` from `offset` on, read a block at a time
/// (a checkpoint is as large as the state: it is never held whole); and the
/// file's length.
std::pair<std::uint64_t, std::uintmax_t> hash_file(const std::filesystem::path& path, std::uintmax_t offset,
                                                   const std::filesystem::path& shown) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the checkpoint: {}", shown.string(), std::strerror(errno)));
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  std::uintmax_t length = 0;
  std::vector<char> block(std::size_t{1} << 20);
  while (in) {
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    const auto got = static_cast<std::uintmax_t>(in.gcount());
    if (length + got > offset) {
      const std::uintmax_t skip = length >= offset ? 0 : offset - length;
      hash = fnv1a(block.data() + skip, static_cast<std::size_t>(got - skip), hash);
    }
    length += got;
  }
  if (in.bad()) throw Error(fmt::format("{}: reading failed: {}", shown.string(), std::strerror(errno)));
  return {hash, length};
}

/// The file's first kUserBlock bytes (fewer if it is shorter).
std::string read_user_block(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(fmt::format("{}: cannot open the checkpoint: {}", path.string(), std::strerror(errno)));
  std::string block(kUserBlock, '\0');
  in.read(block.data(), static_cast<std::streamsize>(block.size()));
  block.resize(static_cast<std::size_t>(in.gcount()));
  return block;
}

// Writing: a failure is the disk's (full, a quota, a size limit), not the input's.
void check(herr_t status, const std::filesystem::path& path, std::string_view what) {
  if (status < 0) throw WriteError(fmt::format("{}: HDF5 failed to {}{}", path.string(), what, io_reason()));
}

hid_t check(hid_t id, const std::filesystem::path& path, std::string_view what) {
  if (id < 0) throw WriteError(fmt::format("{}: HDF5 failed to {}{}", path.string(), what, io_reason()));
  return id;
}

// Reading: a failure is the file's (damaged).
void check_read(herr_t status, const std::filesystem::path& path, std::string_view what) {
  if (status < 0) throw Error(fmt::format("{}: HDF5 failed to {}", path.string(), what));
}

/// A checkpoint's groups: no modification times (equal states give equal
/// files), and their links kept in the group's own checksummed header
/// ("compact", up to 4096 of them) rather than in a separate heap read link
/// by link: HDF5 1.10 frees memory it never set when a damaged heap fails
/// part way through an iteration (found by the fuzz harness under ASan).
H5Handle group_properties() {
  H5Handle gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_obj_track_times(gcpl, 0);
  H5Pset_link_phase_change(gcpl, 4096, 4096);
  return gcpl;
}

/// Creates the groups of "a/b/c" (all but the last part) under `root`.
void make_groups(hid_t root, const std::string& name, const std::filesystem::path& path) {
  for (std::size_t slash = name.find('/'); slash != std::string::npos; slash = name.find('/', slash + 1)) {
    const std::string group = name.substr(0, slash);
    if (H5Lexists(root, group.c_str(), H5P_DEFAULT) > 0) continue;
    const H5Handle gcpl = group_properties();
    H5Handle g(check(H5Gcreate2(root, group.c_str(), H5P_DEFAULT, gcpl, H5P_DEFAULT), path, "create " + group),
               H5Gclose);
  }
}

void set_int_attribute(hid_t object, const char* name, long long value, const std::filesystem::path& path) {
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  H5Handle attr(check(H5Acreate2(object, name, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT), path, name), H5Aclose);
  check(H5Awrite(attr, H5T_NATIVE_LLONG, &value), path, name);
}

void set_string_attribute(hid_t object, const char* name, const std::string& value, const std::filesystem::path& path) {
  H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, std::max<std::size_t>(value.size(), 1));
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  H5Handle attr(check(H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT), path, name), H5Aclose);
  check(H5Awrite(attr, type, value.empty() ? "" : value.data()), path, name);
}

/// A chunked, Fletcher32-checksummed dataset creation list for `dims`.
H5Handle checksummed(const std::vector<hsize_t>& dims) {
  H5Handle plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  std::vector<hsize_t> chunk(dims.size());
  // Chunks of about 64k values along the first axis, whole along the others.
  hsize_t row = 1;
  for (std::size_t k = 1; k < dims.size(); ++k) row *= std::max<hsize_t>(dims[k], 1);
  chunk[0] = std::clamp<hsize_t>(65536 / row, 1, std::max<hsize_t>(dims[0], 1));
  for (std::size_t k = 1; k < dims.size(); ++k) chunk[k] = std::max<hsize_t>(dims[k], 1);
  H5Pset_chunk(plist, static_cast<int>(dims.size()), chunk.data());
  H5Pset_fletcher32(plist);
  H5Pset_obj_track_times(plist, 0);  // no modification times: equal states give equal files
  return plist;
}

/// Creates dataset `name` of the given shape (a scalar: shape {}) and writes
/// it a chunk of rows at a time, each filled by `fill` into one buffer.
void write_rows(hid_t root, const std::string& name, const std::vector<std::size_t>& shape, bool integer,
                const StateSink::RowFiller& fill, const std::filesystem::path& path) {
  make_groups(root, name, path);
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  const bool scalar = dims.empty();
  if (scalar) dims = {1};
  std::vector<hsize_t> max(dims.size(), H5S_UNLIMITED);
  H5Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max.data()), H5Sclose);
  const H5Handle plist = checksummed(dims);
  H5Handle set(check(H5Dcreate2(root, name.c_str(), integer ? H5T_STD_I64LE : H5T_IEEE_F64LE, space, H5P_DEFAULT,
                                plist, H5P_DEFAULT),
                     path, "create " + name),
               H5Dclose);
  hsize_t row_size = 1;
  for (std::size_t k = 1; k < dims.size(); ++k) row_size *= dims[k];
  hsize_t block = 0;  // rows per write: one chunk's
  H5Pget_chunk(plist, 1, &block);
  std::vector<double> reals;
  std::vector<std::int64_t> integers;
  for (hsize_t first = 0; first < dims[0] && row_size > 0; first += block) {
    const hsize_t count = std::min(block, dims[0] - first);
    std::vector<hsize_t> start(dims.size(), 0), extent = dims;
    start[0] = first;
    extent[0] = count;
    check(H5Sselect_hyperslab(space, H5S_SELECT_SET, start.data(), nullptr, extent.data(), nullptr), path,
          "select rows of " + name);
    H5Handle memory(H5Screate_simple(static_cast<int>(extent.size()), extent.data(), nullptr), H5Sclose);
    if (integer) {
      integers.resize(count * row_size);
      fill(first, count, nullptr, integers.data());
      check(H5Dwrite(set, H5T_NATIVE_INT64, memory, space, H5P_DEFAULT, integers.data()), path, "write " + name);
    } else {
      reals.resize(count * row_size);
      fill(first, count, reals.data(), nullptr);
      check(H5Dwrite(set, H5T_NATIVE_DOUBLE, memory, space, H5P_DEFAULT, reals.data()), path, "write " + name);
    }
  }
  if (scalar) set_int_attribute(set, "scalar", 1, path);
}

void write_dataset(hid_t root, const std::string& name, const StateArray& a, const std::filesystem::path& path) {
  std::size_t row_size = 1;
  for (std::size_t k = 1; k < a.shape.size(); ++k) row_size *= a.shape[k];
  write_rows(root, name, a.shape, a.integer,
             [&](std::size_t first, std::size_t count, double* reals, std::int64_t* integers) {
               const std::size_t begin = first * row_size, end = (first + count) * row_size;
               if (integers) std::copy(a.integers.begin() + static_cast<std::ptrdiff_t>(begin),
                                       a.integers.begin() + static_cast<std::ptrdiff_t>(end), integers);
               else std::copy(a.reals.begin() + static_cast<std::ptrdiff_t>(begin),
                              a.reals.begin() + static_cast<std::ptrdiff_t>(end), reals);
             },
             path);
}

void write_string(hid_t root, const std::string& name, const std::string& value, const std::filesystem::path& path) {
  make_groups(root, name, path);
  H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, std::max<std::size_t>(value.size(), 1));
  H5Tset_strpad(type, H5T_STR_NULLPAD);
  const std::vector<hsize_t> dims{1};
  std::vector<hsize_t> max{H5S_UNLIMITED};
  H5Handle space(H5Screate_simple(1, dims.data(), max.data()), H5Sclose);
  const H5Handle plist = checksummed(dims);
  H5Handle set(check(H5Dcreate2(root, name.c_str(), type, space, H5P_DEFAULT, plist, H5P_DEFAULT), path,
                     "create " + name),
               H5Dclose);
  std::string padded = value;
  padded.resize(std::max<std::size_t>(value.size(), 1), '\0');
  check(H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, padded.data()), path, "write " + name);
}

struct Visit {
  StateRecord* record;
  const std::filesystem::path* path;
  std::string error;
};

herr_t read_object(hid_t root, const char* name, const H5L_info_t* /*info*/, void* data) {
  auto& visit = *static_cast<Visit*>(data);
  const std::filesystem::path& path = *visit.path;
  try {
    H5Handle object(H5Oopen(root, name, H5P_DEFAULT), H5Oclose);
    if (!object.valid()) throw Error(fmt::format("{}: cannot open /state/{}", path.string(), name));
    if (H5Iget_type(object) != H5I_DATASET) return 0;
    const hid_t set = object.get();
    H5Handle type(H5Dget_type(set), H5Tclose);
    H5Handle space(H5Dget_space(set), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space);
    if (rank < 1 || rank > 8) throw Error(fmt::format("{}: /state/{} has rank {}", path.string(), name, rank));
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    H5Sget_simple_extent_dims(space, dims.data(), nullptr);
    const H5T_class_t cls = H5Tget_class(type);
    const std::string what = fmt::format("read /state/{} (a checksum failed, or the file is damaged)", name);
    if (cls == H5T_STRING) {
      std::string value(H5Tget_size(type), '\0');
      check_read(H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, value.data()), path, what);
      value.resize(std::strlen(value.c_str()));
      visit.record->put_string(name, value);
      return 0;
    }
    StateArray a;
    a.integer = cls == H5T_INTEGER;
    if (!a.integer && cls != H5T_FLOAT) throw Error(fmt::format("{}: /state/{} has an unknown type", path.string(), name));
    a.shape.assign(dims.begin(), dims.end());
    if (H5Aexists(set, "scalar") > 0) {
      if (a.size() != 1) throw Error(fmt::format("{}: /state/{} is a scalar of {} values", path.string(), name, a.size()));
      a.shape.clear();
    }
    if (a.integer) {
      a.integers.resize(a.size());
      if (!a.integers.empty())
        check_read(H5Dread(set, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.integers.data()), path, what);
    } else {
      a.reals.resize(a.size());
      if (!a.reals.empty())
        check_read(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.reals.data()), path, what);
    }
    visit.record->put_array(name, std::move(a));
    return 0;
  } catch (const std::exception& e) {
    visit.error = e.what();
    return -1;
  }
}

}  // namespace

struct CheckpointWriter::Impl {
  detail::SilenceHdf5Errors quiet;
  std::filesystem::path path, folder, temporary;
  H5Handle file, state;
  bool committed = false;

  /// Closes and removes the unfinished temporary file. Its space is freed
  /// first: a write that failed for want of space (a full disk, a quota, a
  /// size limit) would fail again when HDF5 flushes at closing.
  void discard() {
    if (file.valid()) {
      void* handle = nullptr;
      if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) >= 0 && handle != nullptr)
        static_cast<void>(::ftruncate(*static_cast<int*>(handle), 0));
    }
    state.reset();
    file.reset();
    std::error_code ec;
    std::filesystem::remove(temporary, ec);
  }
};

CheckpointWriter::CheckpointWriter(std::filesystem::path path) : impl_(std::make_unique<Impl>()) {
  Impl& w = *impl_;
  w.path = std::move(path);
  w.folder = w.path.has_parent_path() ? w.path.parent_path() : std::filesystem::path(".");
  std::error_code ec;
  if (!std::filesystem::is_directory(w.folder, ec))
    throw WriteError(fmt::format("{}: cannot write: folder '{}' does not exist", w.path.string(), w.folder.string()));
  w.temporary = temporary_name(w.path);
  const std::filesystem::path& shown = w.path;
  H5Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  check(H5Pset_userblock(fcpl, kUserBlock), shown, "reserve the user block");
  H5Pset_obj_track_times(fcpl, 0);  // the root group too
  H5Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  // 1.10 formats: checksummed superblock and object headers.
  check(H5Pset_libver_bounds(fapl, H5F_LIBVER_V110, H5F_LIBVER_V110), shown, "select the file format");
  w.file = H5Handle(check(H5Fcreate(w.temporary.c_str(), H5F_ACC_EXCL, fcpl, fapl), shown, "create the file"),
                    H5Fclose);
  try {
    set_string_attribute(w.file, "format", kMagic, shown);
    set_int_attribute(w.file, "format_version", kCheckpointFormatVersion, shown);
    const H5Handle gcpl = group_properties();
    w.state = H5Handle(check(H5Gcreate2(w.file, "state", H5P_DEFAULT, gcpl, H5P_DEFAULT), shown, "create /state"),
                       H5Gclose);
  } catch (...) {
    w.discard();
    throw;
  }
}

CheckpointWriter::~CheckpointWriter() {
  if (impl_ && !impl_->committed) impl_->discard();
}

void CheckpointWriter::put_array(const std::string& name, StateArray array) {
  check_state_array(name, array);
  write_dataset(impl_->state, name, array, impl_->path);
}

void CheckpointWriter::put_rows(const std::string& name, std::vector<std::size_t> shape, bool integer,
                                const RowFiller& fill) {
  write_rows(impl_->state, name, shape, integer, fill, impl_->path);
}

void CheckpointWriter::put_string(const std::string& name, std::string value) {
  write_string(impl_->state, name, value, impl_->path);
}

void CheckpointWriter::commit(const std::function<void()>& before_rename) {
  Impl& w = *impl_;
  const std::filesystem::path& path = w.path;
  check(H5Fflush(w.file, H5F_SCOPE_GLOBAL), path, "flush");
  w.state.reset();
  w.file.reset();
  // The user block: magic, version, length and the checksum of the rest.
  const auto [hash, length] = hash_file(w.temporary, kUserBlock, path);
  if (length < kUserBlock) throw WriteError(fmt::format("{}: HDF5 wrote a short file", path.string()));
  std::string header = fmt::format("{}\nformat_version {}\nlength {}\nfnv1a64 {:016x}\n", kMagic,
                                   kCheckpointFormatVersion, length, hash);
  header.resize(kUserBlock, '\0');
  const int fd = ::open(w.temporary.c_str(), O_WRONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) throw WriteError(fmt::format("{}: cannot reopen: {}", path.string(), std::strerror(errno)));
  const bool ok = ::pwrite(fd, header.data(), kUserBlock, 0) == static_cast<ssize_t>(kUserBlock) && ::fsync(fd) == 0;
  ::close(fd);
  if (!ok) throw WriteError(fmt::format("{}: writing failed: {}", path.string(), std::strerror(errno)));
  if (before_rename) before_rename();
  std::error_code ec;
  std::filesystem::rename(w.temporary, path, ec);
  if (ec) throw WriteError(fmt::format("{}: cannot replace it: {}", path.string(), ec.message()));
  w.committed = true;
  const int dir = ::open(w.folder.c_str(), O_RDONLY | O_DIRECTORY);
  if (dir >= 0) {
    ::fsync(dir);
    ::close(dir);
  }
}

void write_checkpoint(const std::filesystem::path& path, const StateRecord& record,
                      const std::function<void()>& before_rename) {
  CheckpointWriter writer(path);
  for (const auto& [name, array] : record.arrays()) writer.put_array(name, array);
  for (const auto& [name, value] : record.strings()) writer.put_string(name, value);
  writer.commit(before_rename);
}

StateRecord read_checkpoint(const std::filesystem::path& path) {
  require_regular_file(path, "a checkpoint");
  detail::SilenceHdf5Errors quiet;
  const std::string bytes = read_user_block(path);
  const std::string name = path.string();
  if (bytes.size() < kUserBlock || bytes.compare(0, std::strlen(kMagic), kMagic) != 0)
    throw Error(fmt::format("{}: not a goo checkpoint (no '{}' header{})", name, kMagic,
                            bytes.size() < kUserBlock ? "; the file is shorter than one" : ""));
  std::istringstream header(bytes);
  std::string magic, key;
  int version = 0;
  std::size_t length = 0;
  std::string hash_text;
  header >> magic >> key >> version;
  if (key != "format_version") throw Error(fmt::format("{}: damaged checkpoint header", name));
  if (version != kCheckpointFormatVersion)
    throw Error(fmt::format("{}: checkpoint format version {}; this goo reads version {}", name, version,
                            kCheckpointFormatVersion));
  header >> key >> length;
  if (key != "length") throw Error(fmt::format("{}: damaged checkpoint header", name));
  header >> key >> hash_text;
  if (key != "fnv1a64") throw Error(fmt::format("{}: damaged checkpoint header", name));
  const auto [hash, file_length] = hash_file(path, kUserBlock, path);
  if (file_length != length)
    throw Error(fmt::format("{}: truncated or extended checkpoint ({} bytes, the header says {})", name, file_length,
                            length));
  // The whole block must be exactly what write_checkpoint puts there (padding included).
  std::string canonical =
      fmt::format("{}\nformat_version {}\nlength {}\nfnv1a64 {}\n", kMagic, version, length, hash_text);
  canonical.resize(kUserBlock, '\0');
  if (bytes.compare(0, kUserBlock, canonical) != 0) throw Error(fmt::format("{}: damaged checkpoint header", name));
  const std::string actual = fmt::format("{:016x}", hash);
  if (actual != hash_text)
    throw Error(fmt::format("{}: corrupt checkpoint: checksum {} does not match the recorded {}", name, actual,
                            hash_text));

  H5Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) throw Error(fmt::format("{}: HDF5 cannot open the checkpoint", name));
  long long stored_version = 0;
  {
    H5Handle attr(H5Aopen(f, "format_version", H5P_DEFAULT), H5Aclose);
    if (!attr.valid() || H5Aread(attr, H5T_NATIVE_LLONG, &stored_version) < 0 ||
        stored_version != kCheckpointFormatVersion)
      throw Error(fmt::format("{}: checkpoint format_version attribute is {}; this goo reads version {}", name,
                              stored_version, kCheckpointFormatVersion));
  }
  H5Handle state(H5Gopen2(f, "state", H5P_DEFAULT), H5Gclose);
  if (!state.valid()) throw Error(fmt::format("{}: the checkpoint has no /state group", name));
  StateRecord record;
  Visit visit{&record, &path, {}};
  if (H5Lvisit(state, H5_INDEX_NAME, H5_ITER_INC, read_object, &visit) < 0)
    throw Error(visit.error.empty() ? fmt::format("{}: cannot read the checkpoint's /state", name) : visit.error);
  return record;
}

}  // namespace goo::io
