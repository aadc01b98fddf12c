#pragma once
// The 3×3 SVD of core/svd3.h for kSvdLanes matrices at once, in the vector
// registers of the processor it runs on (SSE2, AVX2 or AVX-512, chosen at
// run time). Each lane gives svd3's bits exactly, so the choice changes the
// speed and never the results.
#include <string_view>

namespace goo {

/// Matrices per batch: two AVX-512 registers of doubles (simd_lanes.h).
inline constexpr int kSvdLanes = 16;

/// Component-wise storage of kSvdLanes 3×3 SVDs: F[i + 3 j][lane] is row i,
/// column j of that lane's matrix, and likewise U and V; sigma[i][lane] is
/// σ_{i+1}.
struct alignas(64) Svd3Batch {
  double F[9][kSvdLanes];
  double U[9][kSvdLanes];
  double sigma[3][kSvdLanes];
  double V[9][kSvdLanes];
};

enum class SimdLevel { scalar, sse2, avx2, avx512 };

/// "scalar", "sse2", "avx2" or "avx512".
std::string_view simd_level_name(SimdLevel level);

/// Whether this processor (and this build) can run `level`.
bool simd_level_supported(SimdLevel level);

/// The level svd3_batch uses: the widest this processor supports, or a
/// narrower one named by the environment variable GOO_SIMD (scalar, sse2,
/// avx2; a wider one than the processor has is not taken; empty is unset).
/// Read once; any other value throws goo::Error naming the variable (and is
/// read again at the next call).
SimdLevel active_simd_level();

/// U, σ, V of every lane's F at `level` (which must be supported).
void svd3_batch(Svd3Batch& batch, SimdLevel level);

/// The same at active_simd_level().
void svd3_batch(Svd3Batch& batch);

}  // namespace goo
