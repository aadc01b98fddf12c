#pragma once
// Rotation-variant singular value decomposition of a 3×3 matrix
// (Irving, Teran, Fedkiw 2004, sec. 5): F = U diag(σ) Vᵀ with U, V proper
// rotations (det = +1) and σ1 ≥ σ2 ≥ |σ3|; an inverted F (det F < 0) has
// σ3 < 0. The hottest kernel of the solver.
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

}  // namespace goo
