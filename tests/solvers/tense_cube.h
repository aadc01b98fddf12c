#pragma once
// What the surface-tension flow tests (explicit and implicit) share: the
// soft cube that tension rounds, and how round a surface is.
#include <cmath>
#include <numbers>

#include "core/material.h"
#include "core/surface_geometry.h"

namespace goo::test {

/// π^⅓ (6V)^⅔ / A: 1 for a ball, less for anything else (0.806 for a cube).
inline double sphericity(const TriangleMesh& s) {
  const SurfaceIntegrals i = surface_integrals(s);
  return std::cbrt(std::numbers::pi) * std::pow(6.0 * i.volume, 2.0 / 3.0) / i.area;
}

/// A soft, nearly incompressible, strongly damped material under strong
/// tension: on a 0.2 m cube σ / (E L) = 0.25, so tension visibly rounds it.
inline Material tense_cube_material() {
  Material m;
  m.density = 1000.0;
  m.youngs_modulus = 100.0;
  m.poisson_ratio = 0.499;
  m.viscosity = 20.0;
  m.surface_tension = 5.0;
  m.min_mass_fraction = 0.1;
  return m;
}

}  // namespace goo::test
