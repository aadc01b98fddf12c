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

/// A plastic cube dropped on the floor: contacts, plastic flow, re-meshes;
/// 4 frames, a checkpoint every 2.
inline const char* const kDrop = R"({
  "ground": {"height": 0.0, "friction": 0.4},
  "objects": [{"name": "cube", "primitive": {"type": "box", "size": [0.1, 0.1, 0.1], "subdivisions": 4},
               "transform": {"translate": [0, 0, 0.06], "rotate_degrees": [10, 20, 0]},
               "velocity": [0.2, 0, -1.5],
               "material": {"preset": "splashing_fluid", "youngs_modulus": 2e4, "min_mass_fraction": 0.05},
               "lattice_spacing": 0.03}],
  "output": {"fps": 24, "frames": 4},
  "checkpoint": {"every_frames": 2}
})";

}  // namespace goo
