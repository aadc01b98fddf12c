#pragma once
// The material of each element of a lattice mesh (the element ∩ the inside
// of the surface) split into its connected parts, decided with exact
// orientation predicates (docs/lattice.md, "Material parts"). Where two
// sheets of one body pass through an element across a gap of air, its
// material has two parts; a re-mesh that gives each element one copy glues
// them. The parts are what a re-mesh needs to give each its own copy of the
// element (the virtual-node algorithm), and their count is what such a
// re-mesh would glue.
#include <array>
#include <cstdint>
#include <vector>

#include "core/parallel.h"
#include "core/triangle_mesh.h"
#include "meshing/exact_mass.h"
#include "meshing/lattice_mesh.h"

namespace goo {

struct MaterialParts {
  /// #E + 1: element e's parts are first_part[e] .. first_part[e + 1] − 1
  /// (none where the element holds no material: kept because a triangle
  /// touches it).
  std::vector<Index> first_part;
  /// #P: the volume of each part (m³, the lattice positions), from the
  /// divergence theorem with an element corner p as apex (exact_mass.h):
  ///   V(part) = Σ over the part's surface pieces π of [cone(p, π) − cone(p, π′)]
  ///             + V(element) if p lies in the part,
  /// π′ the central projection of π from p onto the face opposite p (the
  /// rays from p leave the part through its pieces only). p is the exact
  /// masses' apex (the corner farthest from the planes of the triangles
  /// near it, on the surface only where all four corners are), so a simple
  /// element's one part has the clipped solid's volume bit for bit.
  Eigen::VectorXd part_volume;
  /// #P × 3: the centroid of each part (the element's where its volume is 0).
  Points part_centroid;
  /// #E: the part holding each corner of the element (in its tets order),
  /// −1 where the corner is outside the surface.
  std::vector<std::array<Index, 4>> corner_part;
  /// The triangles that meet each element's interior, per element
  /// (pair_first[e] .. pair_first[e + 1] − 1, triangles increasing), and the
  /// part each one's piece in the element bounds: found with exact tests in
  /// an examined element, the slicing's pieces in a simple one (the two
  /// differ by pieces of round-off size only).
  std::vector<Index> pair_first, pair_triangle, pair_part;
  /// #E: 1 where an exact test met a degenerate configuration in an
  /// examined element (a surface vertex on a face of the element, an edge
  /// through an edge, two sheets crossing an element edge within 10⁻⁹ of its
  /// length of each other): the element's material is then taken as one
  /// part, as a re-mesh without parts has it.
  std::vector<std::uint8_t> degenerate;

  /// #P: the node copy at each corner of each part (the virtual-node
  /// mesh: each part its own copy of the element; copies of parts whose
  /// material meets on a shared face are one at its three nodes).
  std::vector<std::array<Index, 4>> part_nodes;
  /// The lattice mesh node each node copy sits at.
  std::vector<Index> copy_node;

  [[nodiscard]] Index num_elements() const { return static_cast<Index>(first_part.size()) - 1; }
  [[nodiscard]] Index num_parts(Index e) const { return first_part[at(e) + 1] - first_part[at(e)]; }
  /// Elements whose material has two or more parts.
  [[nodiscard]] Index split_elements() const;
  [[nodiscard]] Index degenerate_elements() const;
  /// Lattice nodes with two or more copies.
  [[nodiscard]] Index duplicated_nodes() const;
};

/// The connected parts of every element's material. A part is a class of
/// the union of
///   - the surface's pieces in the element, joined where two triangles'
///     shared edge passes through the element's interior (a patch);
///   - the inside intervals of the element's six edges (the edge between
///     the surface's crossings of it, in order along the edge, inside and
///     outside alternating from the corner's exact inside flag);
/// where a patch joins the inside interval next to each crossing of an edge
/// by one of its triangles, and an inside corner joins the intervals of its
/// three edges that end there. A patch that crosses no edge of the element
/// (a strand through it, a droplet in it) is a part of its own if it encloses
/// material (positive volume); if it encloses air (a hole through the
/// material), every candidate part of the element is joined into one.
/// Only elements whose pieces form two or more patches are examined so
/// (exact pairs, the intervals walked): the others are *simple*, one part,
/// found without an exact test. Their pieces come from the exact masses'
/// slicing, and two pieces are joined into a patch where the shared edge
/// passes through the element a margin inside its faces (10⁻⁹ of the
/// spacing: far above round-off), so only where the exact test joins them:
/// one patch there is one patch exactly, and one surface patch bounds one
/// region of material. Requires a closed, outward-oriented surface, the
/// lattice mesh built around it (positions at rest, inside flags). Parallel
/// over TBB; the same result for any thread count.
MaterialParts material_parts(const LatticeMesh& lattice_mesh, const TriangleMesh& surface);
/// The same from the surface's pieces the exact masses sliced (exact_mass.h).
MaterialParts material_parts(const LatticeMesh& lattice_mesh, const TriangleMesh& surface,
                             const SurfacePieces& pieces);

/// The lattice mesh with each element copied once per part of its material
/// and each node once per node copy (the virtual-node mesh; docs/lattice.md,
/// "Material parts"). Nodes are numbered by lattice node, then copy; elements
/// by element, then part. Elements without material (kept because a
/// triangle touches them) are left out: they hold nothing, and on nodes of
/// different parts they would join them; so are nodes of no other element.
struct SeparatedMesh {
  /// The copies: mesh over node copies at their nodes' positions;
  /// tet_keys and node_keys per copy (repeated), node_inside per node copy.
  /// element_of_key and node_of_key are left empty (a key may have several
  /// copies): element(key) and node(key) answer −1; first_copy and the
  /// lattice mesh's own maps lead from a key to its copies.
  LatticeMesh copies;
  std::vector<Index> element;  ///< #copies: the lattice mesh element each copies
  std::vector<Index> part;     ///< #copies: the part it holds
  std::vector<Index> node;     ///< #node copies: the lattice mesh node each copies
  /// #E + 1: element e's copies are first_copy[e] .. first_copy[e + 1] − 1
  /// (none where it was left out).
  std::vector<Index> first_copy;
};
SeparatedMesh separate_parts(const LatticeMesh& lattice_mesh, const MaterialParts& parts);

/// The copy holding each surface vertex, given the lattice mesh element
/// embed() chose for it: the copy of the part its triangles bound there (a
/// vertex strictly inside an element is on all its triangles' pieces there).
/// Where no triangle of the vertex has a piece in that element (the vertex
/// on its boundary) or the element was left out, the copy of the part of one
/// of its triangles in the element that contains the vertex best. −1 only if
/// the vertex is in no element with a piece of its triangles.
std::vector<Index> vertex_copies(const LatticeMesh& lattice_mesh, const SeparatedMesh& separated,
                                 const MaterialParts& parts, const TriangleMesh& surface,
                                 const std::vector<Index>& vertex_element);

}  // namespace goo
