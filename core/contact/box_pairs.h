#pragma once
// Broad phase of contact: which axis-aligned boxes overlap, found on a
// uniform grid (each box is entered in every cell it covers; each pair is
// reported by one cell only: the cell of the lower corner of the two boxes'
// overlap, which both cover).
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "core/types.h"

namespace goo {

using Box3 = Eigen::AlignedBox3d;

/// Every pair (i, j), i < j, of boxes in `boxes` that overlap (closed
/// boxes: touching counts), once each, in an order fixed by the boxes (by
/// grid cell): parallel, and the same for any thread count. Empty boxes
/// are skipped, and with `groups` (per box, or −1 for none) so are pairs
/// of two boxes of one group.
std::vector<std::array<Index, 2>> overlapping_pairs(const std::vector<Box3>& boxes,
                                                    const std::vector<Index>* groups = nullptr);

/// Every pair (i, j) of a box of `a` and a box of `b` that overlap, as above.
std::vector<std::array<Index, 2>> overlapping_pairs(const std::vector<Box3>& a, const std::vector<Box3>& b);

}  // namespace goo
