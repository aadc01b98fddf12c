#pragma once
// The elastic force pass's arithmetic for kSvdLanes elements at once, in the
// processor's vector lanes (core/elastic_forces.cpp): the deformation and
// its SVD, then, after each element's plastic flow and stress (scalar), its
// nodal forces and Fe. Each lane gives the one-element code's bits.
#include "core/svd3_batch.h"

namespace goo {

/// Component-wise, [component][lane]; 3×3 matrices column-major.
struct alignas(64) ForceBatch {
  // In: corners, Dm⁻¹ and Fp.
  double x[4][3][kSvdLanes];
  double Dm_inv[9][kSvdLanes];
  double Fp[9][kSvdLanes];
  // Fp⁻¹ (out of force_batch_deform; in to force_batch_forces, after flow).
  double Fp_inv[9][kSvdLanes];
  // F = Ds Dm⁻¹ Fp⁻¹ and its U, σ, V (σ in to force_batch_forces, after flow).
  Svd3Batch svd;
  // In to force_batch_forces: ∂ψ/∂σ and W det Fp.
  double dpsi[3][kSvdLanes];
  double volume[kSvdLanes];
  // Out: the forces on the four corners and Fe = U diag(σ) Vᵀ.
  double f[4][3][kSvdLanes];
  double Fe[9][kSvdLanes];
};

/// Fp⁻¹, then Fe = Ds Dm⁻¹ Fp⁻¹ into svd.F and its SVD.
void force_batch_deform(ForceBatch& batch, SimdLevel level);

/// H = −W det(Fp) U diag(∂ψ/∂σ) Vᵀ Fp⁻ᵀ Dm⁻ᵀ: corners 1–3 take its columns,
/// corner 0 minus their sum; Fe = U diag(σ) Vᵀ.
void force_batch_forces(ForceBatch& batch, SimdLevel level);

}  // namespace goo
