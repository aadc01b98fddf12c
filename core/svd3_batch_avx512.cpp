// svd3_batch at the avx512 level; compiled with that instruction set (see
// core/CMakeLists.txt) and called only where the processor has it.
#include "core/svd3_batch_simd.h"

namespace goo::svd3_detail {

void svd3_batch_avx512(Svd3Batch& batch) {
  svd3_batch_vector(batch);
}

}  // namespace goo::svd3_detail
