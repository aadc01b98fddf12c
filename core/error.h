#pragma once
// goo::Error: bad input (a file, a scene field, an impossible parameter).
// The message names the file, field or element at fault; the goo command
// prints it and exits with code 2. goo::WriteError: output that cannot be
// written (exit code 4).
#include <stdexcept>
#include <string>

namespace goo {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An output file could not be written: the disk or a quota is full, a
/// file-size limit is reached, the folder was made read-only or removed.
/// The message names the file; the goo command exits with code 4, keeps
/// every file already written, and still tries to write summary.json.
class WriteError : public Error {
 public:
  using Error::Error;
};

}  // namespace goo
