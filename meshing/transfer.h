#pragma once
// Carrying a body's state from its old, deformed mesh to a new lattice mesh
// built in the current configuration (W&T sec. 5 and 8; algorithms.md,
// "Remeshing"). Old elements are found through the new lattice (the nodes
// inside each old element's bounding box, and its parts in each lattice
// tetrahedron by slicing along the lattice's planes): constant time per
// query, no spatial tree.
#include <vector>

#include "core/types.h"
#include "meshing/lattice_mesh.h"

namespace goo {

/// Where each new node reads the old mesh: an old element and barycentric
/// coordinates in its deformed shape. Inside the old mesh they interpolate
/// (all ≥ 0, the most interior element wins); outside they extrapolate from
/// the nearest old element (some < 0), which is still exact for any affine
/// field.
struct NodeSources {
  std::vector<Index> element;                                      ///< #N old element
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> bary;  ///< #N×4 in its node order
  Index extrapolated = 0;                                          ///< nodes outside every old element
};

/// Locates every node of `new_mesh` in the old elements (tets at positions
/// x). Inverted or flat old elements are skipped. goo::Error if no old
/// element is usable.
NodeSources locate_in_old_mesh(const Tets& old_tets, const Points& old_x, const LatticeMesh& new_mesh);

/// Σ b_k values(old node k) for each new node (#N×3).
Points interpolate(const NodeSources& sources, const Tets& old_tets, const Points& values);

/// Exact overlap volumes of new and old elements, grouped by new element
/// (compressed rows, old elements increasing).
struct ElementOverlaps {
  std::vector<Index> offsets;      ///< #E_new + 1
  std::vector<Index> old_element;  ///< old element of each overlap
  std::vector<double> volume;      ///< its volume, m³
};

ElementOverlaps element_overlaps(const Tets& old_tets, const Points& old_x, const LatticeMesh& new_mesh);

/// The elastic state of the new elements.
struct ElasticState {
  std::vector<Eigen::Matrix3d> Fe;  ///< #E_new symmetric left stretches
  Eigen::VectorXd alpha;            ///< #E_new hardening
};

/// Only the world-frame left stretch S = U Σ Uᵀ of an old Fe = U Σ Vᵀ carries
/// stress, so S (not Fe) and α are averaged with the overlap volumes as
/// weights, S by its matrix logarithm (log-Euclidean mean: det S is the
/// weighted geometric mean of the old determinants, where a plain mean of
/// sheared stretches would inflate it and lose volume at every re-mesh); a
/// new element that overlaps no old one takes the mean of the sources of its
/// four nodes. Singular values below `min_stretch` are raised to it first (an
/// inverted old state does not survive a re-mesh: the new element is
/// positive, and its mass ρV/det Fe must be).
ElasticState transfer_elastic_state(const ElementOverlaps& overlaps, const NodeSources& sources,
                                    const std::vector<Eigen::Matrix3d>& old_Fe, const Eigen::VectorXd& old_alpha,
                                    const LatticeMesh& new_mesh, double min_stretch);

}  // namespace goo
