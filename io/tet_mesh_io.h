#pragma once
// Reading tetrahedral meshes, for bodies simulated on a mesh of their own
// (no lattice, no re-meshing).
#include <filesystem>

#include "core/tet_mesh.h"

namespace goo::io {

/// Reads a tetrahedral mesh:
/// - TetGen: `name.node` and `name.ele` side by side (either path, or the
///   stem `name.`); ids may start at 0 or 1, as the .node file's first id says;
///   10-node elements keep their 4 corners;
/// - MEDIT: `name.mesh` (ASCII), its `Vertices` and `Tetrahedra` sections.
/// The mesh is checked and oriented (check_and_orient). Every failure throws
/// goo::Error naming the file and its line.
TetMesh read_tet_mesh(const std::filesystem::path& path);

}  // namespace goo::io
