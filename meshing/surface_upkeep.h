#pragma once
// Surface upkeep at re-mesh time (W&T sec. 4): long edges split at their
// midpoint, short edges collapsed, so the surface stays clean under large
// plastic flow. Operates on the world-space surface before it is embedded
// in the new lattice mesh.
#include "core/triangle_mesh.h"
#include "core/settings.h"

namespace goo {


struct UpkeepReport {
  Index splits = 0;
  Index collapses = 0;
  Index flips = 0;
  Index refused = 0;                ///< collapses and flips refused (link condition, flipped or degenerate triangles, crossings)
  Index refused_crossing = 0;       ///< of those, refused because the new triangles would meet another triangle
  double volume_change_bound = 0.0; ///< Σ |ΔV| of the collapses and flips, m³
};

/// Splits, then collapses, in passes over edges sorted by length (longest
/// first for splits, shortest first for collapses), each pass touching an
/// edge's neighbourhood once, so the result is deterministic.
/// - Split: a new vertex at the midpoint bisects both triangles: every
///   surface point stays where it was.
/// - Collapse of (a, b): refused unless a and b share exactly the two
///   opposite vertices (link condition: the surface stays closed and
///   manifold) and no surviving triangle flips (normal turning by more than
///   90°) or degenerates, and unless no triangle of the new fan meets any
///   other triangle (exact tests: a collapse never makes the surface pass
///   through itself). The merged vertex goes where the enclosed volume
///   is unchanged (the change is affine in its position: solved along ab,
///   clamped to the segment), else the nearest point of the segment.
/// - Flip (settings.flips): where one of an edge's two triangles is a
///   sliver (an angle below 15°), the two angles facing the edge sum past π
///   and its quad is nearly flat (the two diagonals within a tenth of the
///   shorter apart), the edge becomes the other diagonal, unless that is an
///   edge already, the new pair folds more than the old, or it would meet
///   another triangle. No vertex moves; slivers (caps and needles), whose
///   normals turn with any small move, go. The volume changes by the
///   quad's tetrahedron, counted in volume_change_bound.
/// With `blockers` (the other bodies' surfaces, at their places), a
/// collapse whose new fan meets one of their triangles is refused too: a
/// body's upkeep never makes it pass through another body.
UpkeepReport upkeep_surface(TriangleMesh& surface, double h, const UpkeepSettings& settings = {},
                            const TriangleMesh* blockers = nullptr);

/// Renumbers the surface in space order, the same surface: its vertices
/// along a Morton curve through cells of h / 16 (ties, within a cell, by
/// their coordinates, then by their old number), its triangles by their
/// lowest vertex, then their corners, each keeping its corners' order (and
/// so its orientation). Splits append their vertices and triangles at the
/// end and collapses remove them anywhere, so after many re-meshes a
/// surface's neighbours lie far apart in its arrays; every pass over the
/// surface (the self-collision lists, the embedding, the measurements)
/// then reads memory out of order. The order depends on the geometry only:
/// a shuffled copy of a surface orders to the same surface, bit for bit
/// (unless two vertices coincide).
void order_surface(TriangleMesh& surface, double h);

}  // namespace goo
