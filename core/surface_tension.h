#pragma once
// Surface tension on the fine embedded surface (W&T sec. 7; algorithms.md,
// "Surface tension"), and the scale-dependent umbrella smoothing that goes
// with it (Desbrun et al. 1999).
#include "core/surface_topology.h"
#include "core/triangle_mesh.h"

namespace goo {

enum class SurfaceTensionForm {
  area_gradient,  ///< default: f = −σ ∂A/∂x_s, conservative (energy σA)
  paper,          ///< W&T eqs. 6–7 (Brochu 2006): per triangle Σ σ n_i × e_i, a third to each vertex
};

/// Per-vertex forces (#V×3, N) of surface tension σ (N/m) on the surface.
/// - area_gradient: triangle (a, b, c) with unit normal n̂ gives
///   −σ/2 n̂ × (c − b) to a (and cyclically): ∂A/∂a = ½ n̂ × (c − b).
/// - paper: f_T = Σ_i (σ/2) n_i × e_i over the three neighbours i (n_i
///   their unit normals, e_i the shared edges clockwise around T), f_T/3 to
///   each vertex of T. The ½ is ours: eq. 6 as printed converges to twice
///   the Laplace pressure (4σH); with it both forms mean the same σ.
/// Both sum to zero over a closed surface. Parallel over triangles, then a
/// gather in the topology's fixed order: deterministic.
void surface_tension_forces(const TriangleMesh& surface, const SurfaceTopology& topology, double sigma,
                            SurfaceTensionForm form, Points& forces);

/// σ × area, J.
double surface_energy(const TriangleMesh& surface, double sigma);

/// One explicit step of the scale-dependent umbrella operator:
/// x_v += λ (Σ_j (x_j − x_v)/|x_j − x_v|) / (Σ_j 1/|x_j − x_v|), λ in [0, 1].
void smooth_surface(Points& vertices, const SurfaceTopology& topology, double lambda);

/// Capillary time-step bound (Brackbill et al. 1992) at the lattice scale h:
/// Δt ≤ √(ρ h³ / (2π σ)); ∞ when σ = 0.
double surface_tension_time_step(double density, double spacing, double sigma);

}  // namespace goo
