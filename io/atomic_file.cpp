#include "io/atomic_file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "core/error.h"

namespace goo::io {

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) {
    throw Error(fmt::format("{}: cannot write: folder '{}' does not exist", path.string(), folder.string()));
  }
  const std::filesystem::path temporary =
      folder / fmt::format(".{}.tmp-{}", path.filename().string(), static_cast<long>(::getpid()));
  try {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw Error(fmt::format("{}: cannot write: {}", path.string(), std::strerror(errno)));
    write(out);
    out.flush();
    if (!out) throw Error(fmt::format("{}: writing failed: {}", path.string(), std::strerror(errno)));
    out.close();
    std::filesystem::rename(temporary, path, error);
    if (error) throw Error(fmt::format("{}: cannot replace it: {}", path.string(), error.message()));
  } catch (...) {
    std::filesystem::remove(temporary, error);
    throw;
  }
}

}  // namespace goo::io
