#pragma once
// Rotation-variant singular value decomposition of a 3×3 matrix
// (Irving, Teran, Fedkiw 2004, sec. 5): F = U diag(σ) Vᵀ with U, V proper
// rotations (det = +1) and σ1 ≥ σ2 ≥ |σ3|; an inverted F (det F < 0) has
// σ3 < 0. The hottest kernel of the solver.
#include "core/svd3_batch.h"
#include "core/types.h"

namespace goo {

struct Svd3 {
  Eigen::Matrix3d U;      ///< rotation, columns are left singular vectors
  Eigen::Vector3d sigma;  ///< σ1 ≥ σ2 ≥ |σ3|
  Eigen::Matrix3d V;      ///< rotation, columns are right singular vectors
};

/// Fast path: cyclic Jacobi on FᵀF (to relative convergence) for V and σ²,
/// then U from F V by Gram–Schmidt, u3 = u1 × u2, σ_i = u_iᵀ F v_i. The
/// reconstruction error is a few ε‖F‖; robust for repeated, zero and
/// negative singular values.
Svd3 svd3(const Eigen::Matrix3d& F);

/// Reference: Eigen's JacobiSVD, made rotation-variant. Slow (≈ 0.7 µs);
/// tests compare svd3 against it.
Svd3 svd3_reference(const Eigen::Matrix3d& F);

/// use(k, svd3(matrix(k))) for every k in [begin, end), in order, the SVDs
/// computed kSvdLanes at a time by svd3_batch (the same bits). matrix(k) is
/// called for all k of a batch before use is called for any of them.
template <class Int, class MatrixOf, class Use>
void for_each_svd3(Int begin, Int end, MatrixOf&& matrix, Use&& use) {
  Svd3Batch batch;
  for (Int first = begin; first < end; first += kSvdLanes) {
    const int lanes = end - first < kSvdLanes ? static_cast<int>(end - first) : kSvdLanes;
    for (int lane = 0; lane < kSvdLanes; ++lane) {
      // A lane past the end decomposes the identity.
      const Eigen::Matrix3d F =
          lane < lanes ? Eigen::Matrix3d(matrix(first + static_cast<Int>(lane))) : Eigen::Matrix3d::Identity();
      for (int k = 0; k < 9; ++k) batch.F[k][lane] = F.data()[k];
    }
    svd3_batch(batch);
    for (int lane = 0; lane < lanes; ++lane) {
      Svd3 svd;
      for (int k = 0; k < 9; ++k) {
        svd.U.data()[k] = batch.U[k][lane];
        svd.V.data()[k] = batch.V[k][lane];
      }
      for (int k = 0; k < 3; ++k) svd.sigma[k] = batch.sigma[k][lane];
      use(first + static_cast<Int>(lane), svd);
    }
  }
}

}  // namespace goo
