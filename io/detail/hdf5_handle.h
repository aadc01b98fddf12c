#pragma once
// RAII for HDF5 identifiers, and a guard that silences HDF5's own error
// printing (goo reports errors itself, naming the file).
#include <hdf5.h>

#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

namespace goo::io::detail {

/// What the system said of HDF5's last failed write (" (No space left on
/// device)") when it is a reason a write fails, else nothing (errno may be
/// left from an earlier call that did not fail).
inline std::string io_reason() {
  const int error = errno;
  const bool telling = error == ENOSPC || error == EDQUOT || error == EFBIG || error == EROFS || error == EIO;
  return telling ? std::string(" (") + std::strerror(error) + ")" : std::string();
}

class H5Handle {
 public:
  H5Handle() = default;
  H5Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  H5Handle(H5Handle&& other) noexcept : id_(std::exchange(other.id_, -1)), close_(other.close_) {}
  H5Handle& operator=(H5Handle&& other) noexcept {
    if (this != &other) {
      reset();
      id_ = std::exchange(other.id_, -1);
      close_ = other.close_;
    }
    return *this;
  }
  ~H5Handle() { reset(); }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = -1;
  }
  [[nodiscard]] hid_t get() const { return id_; }
  [[nodiscard]] bool valid() const { return id_ >= 0; }
  operator hid_t() const { return id_; }  // NOLINT(google-explicit-constructor): used as the C API's id

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

/// HDF5 closes the files still open when the process exits. A file whose
/// last flush failed (the disk full) cannot be closed, and closing it again
/// there crashes (SIGSEGV in H5F__close_cb); goo closes every file itself,
/// so the library is told not to. It must hear this before any other call.
inline void keep_hdf5_open_at_exit() {
  static const bool once = [] {
    H5dont_atexit();
    return true;
  }();
  static_cast<void>(once);
}

/// The first HDF5 call of every entry point into io's HDF5 code.
class SilenceHdf5Errors {
 public:
  SilenceHdf5Errors() {
    keep_hdf5_open_at_exit();
    H5Eget_auto2(H5E_DEFAULT, &function_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~SilenceHdf5Errors() { H5Eset_auto2(H5E_DEFAULT, function_, data_); }
  SilenceHdf5Errors(const SilenceHdf5Errors&) = delete;
  SilenceHdf5Errors& operator=(const SilenceHdf5Errors&) = delete;

 private:
  H5E_auto2_t function_ = nullptr;
  void* data_ = nullptr;
};

}  // namespace goo::io::detail
