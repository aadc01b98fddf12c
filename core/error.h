#pragma once
// goo::Error: bad input (a file, a scene field, an impossible parameter).
// The message names the file, field or element at fault; the goo command
// prints it and exits with code 2.
#include <stdexcept>
#include <string>

namespace goo {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace goo
