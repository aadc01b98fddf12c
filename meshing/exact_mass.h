#pragma once
// Exact sub-element masses (W&T sec. 6): the solid inside each element,
// clipped from the closed surface, and node masses spread from it with
// barycentric weights, so total mass and centre of mass are exact.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/triangle_mesh.h"
#include "meshing/convex_clip.h"
#include "meshing/lattice_mesh.h"

namespace goo {

/// Volume and centroid of (solid ∩ element) for every element.
struct ElementSolid {
  Eigen::VectorXd volume;  ///< #E, m³
  Points centroid;         ///< #E×3 (the element's centroid where the volume is 0)
};

/// Clips the closed, outward-oriented surface to every element of a lattice
/// mesh built around it, in the mesh's current positions (lattice positions:
/// what a fresh mesh has). Divergence theorem with the apex at an element
/// vertex p (algorithms.md, "Exact sub-element mass"): the three faces through
/// p contribute nothing; each clipped surface piece P contributes its cone
/// from p minus the cone over its central projection P′ onto the face
/// opposite p (the region of the element behind P seen from p), and the
/// whole element counts once more if p is inside. The apex is the vertex
/// farthest from the planes of the triangles whose bounding boxes hold it,
/// so it never lies on the surface; its inside flag is the exact one of the
/// voxelisation. The pieces come from slicing each triangle along the
/// lattice's planes (lattice_slicing.h): no search for candidate elements.
ElementSolid clip_solid_to_elements(const LatticeMesh& lattice_mesh, const TriangleMesh& surface);

/// The surface's pieces in each element (the slicing of clip_solid_to_elements,
/// kept for the material's parts, material_parts.h): element e's are
/// first[e] .. first[e + 1] − 1, their triangles increasing (a triangle has
/// one piece in an element), each with its volume integrals from the
/// element's apex.
struct SurfacePieces {
  std::vector<std::uint8_t> apex;        ///< #E: the apex corner (see above)
  std::vector<Index> first;              ///< #E + 1
  std::vector<Index> triangle;           ///< per piece
  std::vector<ConeIntegrals> integrals;  ///< per piece: cone from the apex − cone over its shadow
};
SurfacePieces slice_surface(const LatticeMesh& lattice_mesh, const TriangleMesh& surface);
/// clip_solid_to_elements from the pieces: the same numbers.
ElementSolid element_solid(const LatticeMesh& lattice_mesh, const SurfacePieces& pieces);

/// The building blocks of clip_solid_to_elements, shared with the material's
/// parts (material_parts.h):
/// for each node, the least distance to the plane of a surface triangle
/// whose bounding box holds the node (0 where the surface passes through it);
std::vector<double> node_surface_distances(const LatticeMesh& lattice_mesh, const TriangleMesh& surface);
/// each element's apex: the corner farthest from those planes (the first on
/// a tie), on the surface only where all four are;
std::vector<std::uint8_t> element_apexes(const TetMesh& mesh, const std::vector<double>& distance);
/// a surface piece's share of its element's volume integrals with corner
/// `apex` of x as apex: the cone of the piece minus the cone over its
/// central projection onto the face opposite the apex.
ConeIntegrals part_integrals(const std::array<Eigen::Vector3d, 4>& x, int apex, const Polygon& piece);

/// Node masses (W&T eq. 5): element e holds m = ρ V_e / det(Fe_e) (ρ V_e if
/// `det_Fe` is empty) and gives b_i(c_e) m to its node i, b the barycentric
/// coordinates of the solid's centroid. Then masses below
/// min_mass_fraction × ρ h³ / 2 (the mass of a node whose 24 elements are
/// all full) are raised to it.
Eigen::VectorXd exact_node_masses(const LatticeMesh& lattice_mesh, const ElementSolid& solid, double density,
                                  std::span<const double> det_Fe, double min_mass_fraction);

}  // namespace goo
