// The batched kernels at the avx512 level; compiled with that instruction set
// (see core/CMakeLists.txt) and called only where the processor has it.
#include "core/simd_lanes.h"

namespace goo::lanes {

void svd3_batch_avx512(Svd3Batch& batch) {
  svd3_batch_vector(batch);
}

void damping_block_avx512(const DampingBlock& block, DampingLanes& lanes) {
  damping_block_vector(block, lanes);
}

void force_batch_deform_avx512(ForceBatch& batch) {
  force_batch_deform_lanes<VectorOps>(batch);
  svd3_batch_vector(batch.svd);
}

void force_batch_forces_avx512(ForceBatch& batch) {
  force_batch_forces_lanes<VectorOps>(batch);
}

}  // namespace goo::lanes
