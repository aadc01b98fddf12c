#pragma once
// goo info MESH: what a surface mesh is, and whether goo can simulate it.
#include <filesystem>
#include <iosfwd>

namespace goo::app {

/// Prints the report of a mesh to `out` (text or JSON). Returns the exit code:
/// 0 when the mesh can be simulated; goo::Error (exit code 2 at the caller)
/// when it cannot be read or is unfit, after printing what was measured.
int run_info(const std::filesystem::path& mesh_path, bool json, std::ostream& out);

}  // namespace goo::app
