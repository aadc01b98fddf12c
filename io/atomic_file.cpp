#include "io/atomic_file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <ext/stdio_filebuf.h>
#include <fcntl.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <ostream>
#include <random>

#include "core/error.h"

namespace goo::io {

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) {
    throw WriteError(fmt::format("{}: cannot write: folder '{}' does not exist", path.string(), folder.string()));
  }
  const std::filesystem::path temporary = temporary_name(path);
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw WriteError(fmt::format("{}: cannot write: {}", path.string(), std::strerror(errno)));
  try {
    {
      __gnu_cxx::stdio_filebuf<char> buffer(fd, std::ios::out | std::ios::binary);  // closes fd when done
      std::ostream out(&buffer);
      write(out);
      out.flush();
      if (!out || ::fsync(fd) != 0)
        throw WriteError(fmt::format("{}: writing failed: {}", path.string(), std::strerror(errno)));
    }
    std::filesystem::rename(temporary, path, error);
    if (error) throw WriteError(fmt::format("{}: cannot replace it: {}", path.string(), error.message()));
  } catch (...) {
    std::filesystem::remove(temporary, error);
    throw;
  }
}

std::filesystem::path temporary_name(const std::filesystem::path& path) {
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  static std::random_device device;
  const unsigned long long random = (static_cast<unsigned long long>(device()) << 32) ^ device();
  return folder / fmt::format(".{}.tmp-{}-{:016x}", path.filename().string(), static_cast<long>(::getpid()), random);
}

void require_regular_file(const std::filesystem::path& path, std::string_view what) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0)
    throw Error(fmt::format("{}: cannot open {} ({})", path.string(), what, std::strerror(errno)));
  if (S_ISREG(info.st_mode)) return;
  const char* kind = S_ISDIR(info.st_mode)    ? "a folder"
                     : S_ISFIFO(info.st_mode) ? "a FIFO"
                     : S_ISCHR(info.st_mode)  ? "a character device"
                     : S_ISBLK(info.st_mode)  ? "a block device"
                     : S_ISSOCK(info.st_mode) ? "a socket"
                                              : "not a regular file";
  throw Error(fmt::format("{}: {} must be a regular file, and this is {}", path.string(), what, kind));
}

}  // namespace goo::io
