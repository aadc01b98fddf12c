#pragma once
// The settings of the integrators, the re-mesh trigger and the surface
// upkeep: plain values, in core so that a scene (io) can carry them and the
// solvers and meshing read them.
#include <Eigen/Core>

#include "core/surface_tension.h"

namespace goo {

/// An incompressible material's nodes keep their volume to this fraction
/// (core/volume_projection.h).
inline constexpr double kVolumeTolerance = 1e-4;

/// Gravity at the Earth's surface along −z, m/s²: a scene's default, and an
/// integrator's when a test or benchmark gives none.
inline Eigen::Vector3d standard_gravity() { return {0.0, 0.0, -9.81}; }

/// A scene's `surface_tension`, for every body and integrator (the tension
/// σ itself is the material's).
struct SurfaceTensionSettings {
  /// The forces' form; backward Euler and the static solve minimise an
  /// energy, so they take only area_gradient.
  SurfaceTensionForm form = SurfaceTensionForm::area_gradient;
  /// Umbrella smoothing of the surface per step: λ = smoothing × σ × Δt
  /// (capped at ½), so the smoothing per unit time does not depend on Δt.
  /// Units 1/(N/m · s); 0 turns it off.
  double smoothing = 0.0;
};

struct NewmarkSettings {
  double cfl = 0.5;                                            ///< fraction of the elastic stability limit
  double max_strain_per_step = 0.1;                            ///< bound on ‖Ḟ‖ Δt
  double max_time_step = 1e-2;                                 ///< s
  /// The damping solves stop when the residual is this fraction of the half
  /// step's impulse h (f_e + M g − C v) at the velocities they start from:
  /// the velocity increment right to six digits, far finer than the
  /// scheme's own O(Δt²) error in it (docs/physics.md).
  double cg_tolerance = 1e-6;
  int cg_max_iterations = 1000;
  /// The damping solves' preconditioner (C's diagonal blocks at the last
  /// force evaluation's Fe) is recomputed once the deformation since it was,
  /// Σ ‖Ḟ‖ Δt over the steps, passes preconditioner_strain, and at least
  /// every preconditioner_steps steps; 0 and 1: at every step. It sets how
  /// fast the solves converge, never where they stop. (Not scene keys.)
  double preconditioner_strain = 0.05;
  int preconditioner_steps = 8;
  /// Incompressible materials: |V_i − V̄_i| ≤ this × V̄_i after each step.
  double volume_tolerance = kVolumeTolerance;
};

/// How each Newton system is solved.
enum class LinearSolver {
  direct,      ///< CHOLMOD factorisation every iteration
  lagged_pcg,  ///< conjugate gradients preconditioned with the last factor, refactored when CG needs too many iterations
  /// direct below kLaggedPcgUnknowns unknowns, lagged_pcg above. Measured
  /// here (docs/implicit.md): a refactorisation costs 64 solves at 32k
  /// unknowns and 55 at 89k, so ≤ 25 preconditioned CG iterations are cheaper;
  /// below ~10k unknowns a factorisation takes milliseconds and CG gains nothing.
  automatic,
};

inline constexpr long kLaggedPcgUnknowns = 10000;

struct BackwardEulerSettings {
  double time_step = 1e-2;                                     ///< s, the step it tries first
  double tolerance = 1e-8;    ///< ‖∇E‖∞ over free nodes, relative to the scene's force scale
  int max_newton_iterations = 30;
  /// When the iterations run out, a residual below this is still accepted:
  /// with projected (semi-definite) element Hessians Newton may converge only
  /// linearly (stiff bodies in contact: measured 0.77 per iteration), and a
  /// residual force of 10⁻⁵ of the scene's force scale moves nothing visible.
  double acceptable_tolerance = 1e-5;
  int max_halvings = 8;  ///< a step that does not converge is retried at half Δt
  LinearSolver linear_solver = LinearSolver::automatic;
  int pcg_max_iterations = 25;  ///< lagged_pcg: more than this and the factor is renewed
  /// Incompressible materials: as NewmarkSettings::volume_tolerance.
  double volume_tolerance = kVolumeTolerance;
  /// Static equilibrium instead of dynamics (a scene's `{"type": "static"}`;
  /// docs/implicit.md, "Static equilibrium"): no inertia, no damping; a
  /// step ends at the equilibrium of the loads at its end time, reached in
  /// load steps from the last equilibrium when one Newton solve does not
  /// converge (at most max_halvings halvings of the load increment).
  bool statics = false;
  /// Static: gravity grows linearly from zero at t = 0 to its full value
  /// at this time, s (0: the full gravity from the start).
  double gravity_ramp = 0.0;
};

/// Self-collisions of a body's embedded surface (docs/embedded-surface.md,
/// "Self-collisions"): a scene's per-object `self_collisions`.
struct SelfCollisionSettings {
  bool enabled = true;
  /// Pairs of surface primitives are kept at least this far apart, m; 0:
  /// kSelfCollisionThicknessFraction × the lattice spacing (a tetrahedral
  /// mesh: × its mean rest edge length).
  double thickness = 0.0;
  double friction = 0.0;  ///< Coulomb coefficient between sheets of the surface
};

/// Collisions between the surfaces of different bodies (W&T sec. 4), with
/// two objects or more: resolved in one stage with each body's
/// self-collisions, all bodies stepping together.
struct BodyCollisionSettings {
  bool enabled = true;
  /// Pairs of two bodies are kept at least this far apart, m; 0: the
  /// smallest of the bodies' self-collision thicknesses.
  double thickness = 0.0;
  double friction = 0.0;  ///< Coulomb coefficient between two bodies
};

/// The default thickness, as a fraction of the element size: far below
/// anything visible, far above the round-off of the positions.
inline constexpr double kSelfCollisionThicknessFraction = 1e-3;

struct RemeshThresholds {
  double condition_growth = 3.0;  ///< κ(Ds) / κ(Dm) that triggers
  double min_barycentric = -0.2;  ///< a surface vertex's coordinate that triggers
};

struct UpkeepSettings {
  /// Thresholds as fractions of the lattice spacing h (scene parameters).
  double split_length = 0.5;     ///< split edges longer than this × h
  double collapse_length = 0.05; ///< collapse edges shorter than this × h
  int max_passes = 16;
  bool flips = true;  ///< flip diagonals of nearly flat quads to the Delaunay one (removes slivers)
};

}  // namespace goo
