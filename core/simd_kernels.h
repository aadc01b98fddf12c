#pragma once
// The batched kernels of one instruction-set level, as a table: svd3_batch,
// the damping's gather, block and diagonal and the force pass's three parts each look their level up
// here instead of dispatching by hand.
#include "core/damping_batch.h"
#include "core/force_batch.h"
#include "core/svd3_batch.h"

namespace goo {

struct SimdKernels {
  void (*svd3_batch)(Svd3Batch& batch);
  void (*damping_gather)(const DampingSources& sources, int first, int count, DampingLanes& lanes);
  void (*damping_block)(const DampingBlock& block, DampingLanes& lanes);
  void (*damping_diagonal)(const DampingBlock& block, DampingDiagonal& out);
  void (*force_batch_gather)(const ForceSources& sources, int first, int count, ForceBatch& batch);
  void (*force_batch_deform)(ForceBatch& batch);
  void (*force_batch_forces)(ForceBatch& batch);
};

/// The kernels compiled for `level` (which must be supported).
const SimdKernels& simd_kernels(SimdLevel level);

}  // namespace goo
