#pragma once
// The material of one body: elasticity, viscosity, plasticity, density.
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace goo {

/// Isotropic hyperelastic energy density models (algorithms.md).
enum class ElasticModel {
  neo_hookean,         ///< the paper's (Irving et al. 2004), ln continued below a threshold
  fixed_corotated,     ///< Stomakhin et al. 2012
  stable_neo_hookean,  ///< Smith et al. 2018
};

std::string_view to_string(ElasticModel model);
/// "neo_hookean", "fixed_corotated", "stable_neo_hookean"; goo::Error otherwise.
ElasticModel elastic_model_from_string(std::string_view name);

/// The lightest a node may be, as a fraction of a full node's mass (W&T
/// sec. 6): a lattice node just outside the surface would otherwise have
/// next to no mass and stop explicit time stepping. The presets and every
/// scene material start with it.
inline constexpr double kMinMassFraction = 0.05;

struct Material {
  double density = 1000.0;                                        ///< ρ, kg/m³
  double youngs_modulus = 1e5;                                    ///< E, Pa
  double poisson_ratio = 0.3;                                     ///< ν_P, in [0, 0.5)
  double viscosity = 0.0;                                         ///< β, Pa·s (corotated Rayleigh damping)
  double yield_stress = std::numeric_limits<double>::infinity();  ///< PY, Pa (∞: purely elastic)
  double flow_rate = 0.0;                                         ///< ν, 1/s (per unit time: rate-independent)
  double hardening = 0.0;                                         ///< K, dimensionless
  double min_mass_fraction = 0.0;  ///< m_min as a fraction of a full node's mass (W&T sec. 6)
  double surface_tension = 0.0;    ///< σ, N/m, on the embedded surface (W&T sec. 7)
  ElasticModel model = ElasticModel::fixed_corotated;
  /// Every node keeps its rest volume (core/volume_projection.h; Irving et
  /// al. 2007): the elasticity then acts on shape alone, whatever ν_P.
  bool incompressible = false;

  /// Lamé parameters: μ = E / (2(1+ν)), λ = E ν / ((1+ν)(1−2ν)).
  [[nodiscard]] double mu() const { return youngs_modulus / (2.0 * (1.0 + poisson_ratio)); }
  [[nodiscard]] double lambda() const {
    return youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
  }
  [[nodiscard]] bool plastic() const { return yield_stress < std::numeric_limits<double>::infinity(); }
};

/// Refuses impossible parameters with goo::Error naming the field
/// ("material.poisson_ratio must be in [0, 0.5), got 0.5"). `where` prefixes
/// the field names (a scene path, say).
void validate(const Material& material, std::string_view where = "material", char separator = '.');

/// The five behaviours of W&T figure 3, as named presets (our values: the
/// paper gives its parameters only in a figure). Density 1000 kg/m³,
/// Poisson 0.3, fixed corotated elasticity, incompressible (all five are
/// water-based gels and fluids or rubber: docs/physics.md), light nodes
/// clamped at kMinMassFraction:
/// | preset          | E (Pa) | β (Pa·s) | PY (Pa) | ν (1/s) |
/// | rigid_brick     | 1e6    | 20       | ∞       | 0       |
/// | viscous_ooze    | 1e4    | 100      | 5       | 50      |
/// | jiggly_gelatin  | 2e4    | 2        | ∞       | 0       |
/// | gooey_jelly     | 2e4    | 10       | 400     | 20      |
/// | splashing_fluid | 5e3    | 0.5      | 1       | 400     |
/// goo::Error naming the presets for an unknown name.
Material material_preset(std::string_view name);
/// The preset names, in the order of the figure (rigid to fluid).
const std::vector<std::string>& material_preset_names();

}  // namespace goo
