// The batched kernels at the avx2 level; compiled with that instruction set
// (see core/CMakeLists.txt) and called only where the processor has it.
#include "core/simd_lanes.h"

namespace goo::lanes {

const SimdKernels& kernels_avx2() {
  return kVectorKernels;
}

}  // namespace goo::lanes
