// The batched kernels at the avx512 level; compiled with that instruction set
// (see core/CMakeLists.txt) and called only where the processor has it.
#include "core/simd_lanes.h"

namespace goo::lanes {

const SimdKernels& kernels_avx512() {
  return kVectorKernels;
}

}  // namespace goo::lanes
