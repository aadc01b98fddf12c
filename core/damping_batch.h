#pragma once
// The frozen damping operator of kDampingLanes consecutive elements, stored
// component-wise so that one application runs in the processor's vector
// lanes (core/damping.h; the same bits at every width).
#include "core/svd3_batch.h"

namespace goo {

inline constexpr int kDampingLanes = 8;

/// Element 8b + lane of block b: G = Fe, A = Dm⁻¹ Fp⁻¹, scale = 2βW det Fp
/// (column-major, G[i + 3 j][lane]). Lanes past the last element are zero.
struct alignas(64) DampingBlock {
  double G[9][kDampingLanes];
  double A[9][kDampingLanes];
  double scale[kDampingLanes];
};

/// A block's nodal velocities in and element forces out: v[k][i][lane] is
/// component i of corner k's velocity, f likewise.
struct alignas(64) DampingLanes {
  double v[4][3][kDampingLanes];
  double f[4][3][kDampingLanes];
};

/// Where damping_gather reads a block's corner velocities: v, or v + β p
/// (the conjugate gradients' next direction, formed as it is read), at the
/// nodes of the elements' corners.
struct DampingSources {
  const double* v = nullptr;  ///< #N×3, row by row
  const double* p = nullptr;  ///< #N×3, row by row, or none
  double beta = 0.0;          ///< β of v + β p
  const int* tets = nullptr;  ///< #E×4 node indices, row by row
};

/// The corner velocities of elements first … first + count − 1 (count ≤
/// kDampingLanes; 4 (first + kDampingLanes) must fit an int) into lanes.v's
/// first `count` lanes, each v + β p as (v + (β p)) when p is given, the
/// processor's gathers where it has them; the lanes past them zero.
void damping_gather(const DampingSources& sources, int first, int count, DampingLanes& lanes, SimdLevel level);

/// f = −C_e v for every lane of the block at `level` (which must be
/// supported).
void damping_block(const DampingBlock& block, DampingLanes& lanes, SimdLevel level);

/// A block's corner blocks of C (Damping::diagonal_blocks): d[k][i + 3 j][lane]
/// is row i, column j of corner k's 3×3 block of that lane's element.
struct alignas(64) DampingDiagonal {
  double d[4][9][kDampingLanes];
};

/// The corner blocks of every lane of the block at `level` (which must be
/// supported): the bits of the Eigen formula Damping::diagonal_blocks ran
/// element by element before.
void damping_diagonal(const DampingBlock& block, DampingDiagonal& out, SimdLevel level);

}  // namespace goo
