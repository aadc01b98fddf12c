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
  Index refused = 0;                ///< collapses refused (link condition, flipped or degenerate triangles, crossings)
  Index refused_crossing = 0;       ///< of those, refused because the new fan would meet another triangle
  double volume_change_bound = 0.0; ///< Σ |ΔV| of the collapses, m³ (0 when every collapse preserved volume)
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
/// With `blockers` (the other bodies' surfaces, at their places), a
/// collapse whose new fan meets one of their triangles is refused too: a
/// body's upkeep never makes it pass through another body.
UpkeepReport upkeep_surface(TriangleMesh& surface, double h, const UpkeepSettings& settings = {},
                            const TriangleMesh* blockers = nullptr);

}  // namespace goo
