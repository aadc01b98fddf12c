#pragma once
// Meshing a body around its surface, and re-meshing it in its current
// configuration with its state carried across (W&T secs. 5, 6 and 8;
// architecture.md, "Remesh semantics").
#include "core/body.h"
#include "core/triangle_mesh.h"
#include "meshing/lattice_mesh.h"
#include "meshing/surface_upkeep.h"

namespace goo {

/// A body on a lattice mesh, and the mesh it was cut from.
struct MeshedBody {
  Body body;                 ///< with its surface embedded
  LatticeMesh lattice_mesh;  ///< the lattice mesh as built (rest configuration)

  /// The surface at the body's current positions.
  [[nodiscard]] TriangleMesh surface() const { return body.surface(); }
};

/// Wall seconds of a re-mesh by stage.
struct RemeshTimes {
  double upkeep = 0.0;        ///< surface splits, collapses and flips
  double lattice = 0.0;       ///< the new lattice mesh around the surface
  double transfer = 0.0;      ///< velocities and elastic state from the old mesh
  double masses = 0.0;        ///< the solid clipped to the elements, exact masses
  double separation = 0.0;    ///< the material's parts found and the elements and nodes copied per part
  double conservation = 0.0;  ///< mass, centre and momentum restored; the surface embedded

  RemeshTimes& operator+=(const RemeshTimes& o) {
    upkeep += o.upkeep, lattice += o.lattice, transfer += o.transfer, masses += o.masses;
    separation += o.separation, conservation += o.conservation;
    return *this;
  }
};

/// What a re-mesh did, and how far the transferred state missed the
/// conserved totals before the conservation step (discretisation error of
/// the averaged density; round-off when the old state was uniform).
/// What copying elements and nodes per part of the material did
/// (docs/lattice.md, "Material parts").
struct SeparationReport {
  Index split_elements = 0;       ///< elements whose material has two or more parts
  Index node_copies = 0;          ///< nodes added as copies
  Index degenerate_elements = 0;  ///< elements taken as one part for a degenerate configuration
};

struct RemeshReport {
  Index old_elements = 0;
  Index new_elements = 0;
  Index new_nodes = 0;
  Index extrapolated_nodes = 0;  ///< new nodes outside every old element
  double mass_error = 0.0;       ///< |M_new − M_old| / M_old
  double centre_error = 0.0;     ///< |c_new − c_old| / (size of the surface's bounding box)
  double momentum_error = 0.0;   ///< |P_new − P_old| / (M_old max |v_old|), 0 at rest
  double rest_volume_error = 0.0;  ///< |r − 1|: how far the averaged state missed the stress-free volume
  UpkeepReport upkeep;           ///< the surface upkeep before meshing, if asked for
  SeparationReport separation;   ///< the copies per part of the material, if asked for
  RemeshTimes times;
};

/// The first mesh of a body: every lattice tetrahedron of spacing h around
/// the closed surface, rest shape = lattice shape, F = Fp = I, at rest,
/// exact sub-element masses (clamped by material.min_mass_fraction).
/// With `separate`, every element is copied once per connected part of its
/// material and every node once per copy (virtual nodes, docs/lattice.md
/// "Material parts"), so that material a lattice spacing apart shares no
/// element and no node; the body then has the copies as its elements and
/// nodes (`lattice_mesh` stays the plain one). A scene's bodies are meshed
/// so unless `remesh.separate_parts` is false; here it is asked for.
MeshedBody mesh_body(const TriangleMesh& surface, const Material& material, double h, bool separate = false,
                     SeparationReport* report = nullptr);

/// A new lattice mesh of spacing h around the current surface (`surface`:
/// the body's triangles at their current, embedded positions), with rest
/// shape = current shape, so F = I and Fp = Fe⁻¹ for the transferred
/// elastic deformation Fe (algorithms.md, "Remeshing"):
/// - velocities interpolated in the old deformed elements (extrapolated
///   from the nearest outside them): exact for affine fields;
/// - left stretch and α averaged with exact old/new overlap volumes;
/// - the stress-free volume of the material (Body::rest_material_volume)
///   restored by one factor on every Fe;
/// - exact masses m = ρ V / det Fe, clamped;
/// - conservation: masses scaled by a + g·(x − c) and velocities shifted
///   uniformly so that total mass, centre of mass and linear momentum equal
///   the old body's (both corrections vanish to round-off when the old state
///   is uniform; their size before correction is in the report).
/// The surface does not move: it is re-embedded at the same positions.
/// With `upkeep`, long edges are split and short ones collapsed first
/// (W&T fig. 8); splits move nothing, collapses change the volume by at most
/// report->upkeep.volume_change_bound, and none makes the surface meet
/// itself or `others` (the other bodies' surfaces). With `separate`, the
/// new mesh is copied per part of the material as mesh_body() does: each
/// copy of a node gets the node's transferred velocity, each copy of an
/// element the element's transferred state, each its part's exact mass.
MeshedBody remesh(const Body& body, const TriangleMesh& surface, double h, RemeshReport* report = nullptr,
                  const UpkeepSettings* upkeep = nullptr, const TriangleMesh* others = nullptr, bool separate = false);

}  // namespace goo
