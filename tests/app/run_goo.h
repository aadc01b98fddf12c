#pragma once
// Runs the goo command as a user does, capturing exit code and output.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/common/test_common.h"

namespace goo {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs goo with `arguments`; `prefix` goes before the command (variables set
/// for it alone, "PATH=/x", or a wrapper, "timeout 30").
inline CommandResult goo(const std::string& arguments, const std::string& prefix = "") {
  test::TempDir dir;
  const std::string command = prefix + (prefix.empty() ? "" : " ") + std::string("'") + GOO_EXECUTABLE +
                              "' " + arguments + " > '" + (dir / "out").string() + "' 2> '" + (dir / "err").string() +
                              "'";
  const int status = std::system(command.c_str());
  CommandResult run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.out = slurp(dir / "out");
  run.err = slurp(dir / "err");
  return run;
}

}  // namespace goo
