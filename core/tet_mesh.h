#pragma once
// Tetrahedral meshes: what a body is built from.
#include <string_view>

#include "core/types.h"

namespace goo {

struct TetMesh {
  Points positions;  ///< #N×3 node positions, m
  Tets tets;         ///< #E×4 node ids

  [[nodiscard]] Index num_nodes() const { return static_cast<Index>(positions.rows()); }
  [[nodiscard]] Index num_elements() const { return static_cast<Index>(tets.rows()); }
};

/// A box of the given full size with its minimum corner at `origin`, split
/// into cells.x × cells.y × cells.z cubes-or-bricks of six tetrahedra each
/// (Kuhn subdivision along the main diagonal: conforming across cells).
TetMesh make_box_tets(const Eigen::Vector3d& size, const Eigen::Vector3i& cells,
                      const Eigen::Vector3d& origin = Eigen::Vector3d::Zero());

/// Checks a tetrahedral mesh read from `source`: finite positions, ids in
/// range, no element with a repeated node or zero volume (goo::Error naming
/// the element). Negatively oriented elements are reoriented (nodes 1 and 2
/// swapped); returns how many were.
Index check_and_orient(TetMesh& mesh, std::string_view source);

/// The element across the face opposite node k of each element (#E×4, −1
/// on the boundary).
Tets face_neighbours(const Tets& tets);

/// det[x1−x0, x2−x0, x3−x0] / 6 of element e.
double signed_volume(const Points& positions, const Tets& tets, Index e);

}  // namespace goo
