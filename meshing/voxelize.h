#pragma once
// Inside/outside of every node of a lattice block for a closed surface, by
// z-ray scan conversion (W&T sec. 5), exact in every degenerate case.
#include <cstdint>
#include <vector>

#include "core/triangle_mesh.h"
#include "meshing/bcc_lattice.h"

namespace goo {

/// inside[node key] = 1 if the lattice node is inside the closed,
/// outward-oriented surface. For each (x, y) column of both grids the
/// surface's crossings of the vertical line are collected with the sign of
/// their normal's z; a node's winding number is the sum of the crossings
/// above it, and it is inside when that is not zero.
///
/// Exact: the node is treated as p + (ε, ε², ε³) for an infinitesimal ε
/// (simulation of simplicity), decided with exact orientation predicates.
/// A ray through a surface vertex or edge then meets exactly one of the
/// triangles around it, and a node on the surface is inside exactly when
/// that shifted point is; e.g. for a lattice-aligned box [x0, x1] × … the
/// nodes with x0 ≤ x < x1, y0 ≤ y < y1, z0 ≤ z < z1 are inside.
std::vector<std::uint8_t> voxelize(const BccLattice& lattice, const TriangleMesh& surface);

}  // namespace goo
