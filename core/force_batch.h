#pragma once
// The elastic force pass's arithmetic for kSvdLanes elements at once, in the
// processor's vector lanes (core/elastic_forces.cpp): the deformation and
// its SVD, then, after each element's plastic flow (scalar), its stress,
// nodal forces, Fe and stability bound. Each lane gives the one-element
// code's bits.
#include "core/svd3_batch.h"

namespace goo {

/// Where ∂ψ/∂σ comes from in force_batch_forces: the lanes evaluate the
/// polynomial models (IsotropicEnergy::dpsi's formulas and order); the
/// neo-Hookean's logarithm is the caller's, one element at a time.
enum class LaneStress : int { given, fixed_corotated, stable_neo_hookean };

/// The material's constants for force_batch_forces.
struct ForceModel {
  LaneStress stress = LaneStress::given;
  double mu = 0.0;
  double lambda = 0.0;   ///< IsotropicEnergy::lambda() (λ + μ for stable neo-Hookean)
  double modulus = 0.0;  ///< λ + 2μ of the stability bound
  double viscosity = 0.0;  ///< β of the damping (core/damping.h)
};

/// Component-wise, [component][lane]; 3×3 matrices column-major.
struct alignas(64) ForceBatch {
  // In: corners, Dm⁻¹ and Fp (to force_batch_forces: Fp after flow).
  double x[4][3][kSvdLanes];
  double Dm_inv[9][kSvdLanes];
  double Fp[9][kSvdLanes];
  // In to force_batch_forces: W (the rest volume), the element's lightest
  // node's mass and the material.
  double rest_volume[kSvdLanes];
  double least_mass[kSvdLanes];
  ForceModel model;
  // Fp⁻¹ (out of force_batch_deform; in to force_batch_forces, after flow).
  double Fp_inv[9][kSvdLanes];
  // F = Ds Dm⁻¹ Fp⁻¹ and its U, σ, V (σ in to force_batch_forces, after flow).
  Svd3Batch svd;
  // ∂ψ/∂σ: in to force_batch_forces if model.stress is `given` (else unused).
  double dpsi[3][kSvdLanes];
  // Out: the forces on the four corners, Fe = U diag(σ) Vᵀ, the squared
  // stability bound m_min / k_e (ElasticForces::critical_time_step), and
  // what the damping freezes besides Fe (core/damping_batch.h): A = Dm⁻¹ Fp⁻¹
  // and 2β W det Fp.
  double f[4][3][kSvdLanes];
  double Fe[9][kSvdLanes];
  double dt_squared[kSvdLanes];
  double A[9][kSvdLanes];
  double damping_scale[kSvdLanes];
};

/// Where force_batch_gather reads its elements: the body's arrays.
struct ForceSources {
  const double* x = nullptr;             ///< #N×3 positions, row by row
  const double* masses = nullptr;        ///< #N
  const int* tets = nullptr;             ///< #E×4 node indices, row by row
  const double* Dm_inv = nullptr;        ///< #E 3×3, column-major, one after another
  const double* Fp = nullptr;            ///< #E 3×3, likewise
  const double* rest_volumes = nullptr;  ///< #E
};

/// Elements first … first + count − 1 (count ≤ kSvdLanes; 9 (first +
/// kSvdLanes) must fit an int) into the first `count` lanes of the batch's
/// x, Dm_inv, Fp, rest_volume and least_mass, the processor's gathers where
/// it has them; a lane past them holds the unit tetrahedron at rest, of no
/// volume (and ∂ψ/∂σ zero).
void force_batch_gather(const ForceSources& sources, int first, int count, ForceBatch& batch, SimdLevel level);

/// Fp⁻¹, then Fe = Ds Dm⁻¹ Fp⁻¹ into svd.F and its SVD.
void force_batch_deform(ForceBatch& batch, SimdLevel level);

/// ∂ψ/∂σ (unless given); H = −W det(Fp) U diag(∂ψ/∂σ) Vᵀ Fp⁻ᵀ Dm⁻ᵀ:
/// corners 1–3 take its columns, corner 0 minus their sum; Fe = U diag(σ) Vᵀ;
/// m_min / ((λ + 2μ) W det(Fp) Σ_i |∇λ_i|²); A = Dm⁻¹ Fp⁻¹ and
/// 2β W / det(Fp⁻¹) (Damping::freeze's formulas and orders).
void force_batch_forces(ForceBatch& batch, SimdLevel level);

}  // namespace goo
