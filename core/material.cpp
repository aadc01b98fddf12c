#include "core/material.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <limits>

#include "core/error.h"

namespace goo {

std::string_view to_string(ElasticModel model) {
  switch (model) {
    case ElasticModel::neo_hookean:
      return "neo_hookean";
    case ElasticModel::fixed_corotated:
      return "fixed_corotated";
    case ElasticModel::stable_neo_hookean:
      return "stable_neo_hookean";
  }
  return "?";
}

ElasticModel elastic_model_from_string(std::string_view name) {
  for (const ElasticModel m :
       {ElasticModel::neo_hookean, ElasticModel::fixed_corotated, ElasticModel::stable_neo_hookean}) {
    if (name == to_string(m)) return m;
  }
  throw Error(
      fmt::format("unknown elastic model '{}' (expected neo_hookean, fixed_corotated or stable_neo_hookean)", name));
}

void validate(const Material& m, std::string_view where, char separator) {
  auto fail = [&](std::string_view field, std::string_view rule, double value) {
    throw Error(fmt::format("{}{}{} must be {}, got {}", where, separator, field, rule, value));
  };
  if (!(m.density > 0.0) || !std::isfinite(m.density)) fail("density", "positive and finite", m.density);
  if (!(m.youngs_modulus > 0.0) || !std::isfinite(m.youngs_modulus)) {
    fail("youngs_modulus", "positive and finite", m.youngs_modulus);
  }
  if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5)) fail("poisson_ratio", "in [0, 0.5)", m.poisson_ratio);
  if (!(m.viscosity >= 0.0) || !std::isfinite(m.viscosity)) fail("viscosity", "non-negative and finite", m.viscosity);
  if (!(m.yield_stress >= 0.0)) fail("yield_stress", "non-negative (infinite: no plasticity)", m.yield_stress);
  if (!(m.flow_rate >= 0.0) || !std::isfinite(m.flow_rate)) fail("flow_rate", "non-negative and finite", m.flow_rate);
  if (!(m.hardening >= 0.0) || !std::isfinite(m.hardening)) fail("hardening", "non-negative and finite", m.hardening);
  if (!(m.surface_tension >= 0.0) || !std::isfinite(m.surface_tension))
    fail("surface_tension", "non-negative and finite", m.surface_tension);
  if (!(m.min_mass_fraction >= 0.0 && m.min_mass_fraction <= 1.0)) {
    fail("min_mass_fraction", "in [0, 1]", m.min_mass_fraction);
  }
  // Stresses are squared (norms, yield tests, the CFL bound): beyond 1e100 Pa
  // of modulus, a strain of 10¹⁰⁰ would overflow double precision's 1.8e308,
  // and measured, a body scaled by 2⁵⁰⁰ (E = 6.5e154) no longer moves as it
  // does unscaled while one scaled by 2⁴⁵⁰ moves bit for bit the same. Every
  // material is far below (diamond: E = 1.2e12 Pa).
  constexpr double kMaxStress = 1e100;
  const char* rule = "at most 1e100 (double precision squares stresses)";
  if (m.youngs_modulus > kMaxStress) fail("youngs_modulus", rule, m.youngs_modulus);
  if (m.viscosity > kMaxStress) fail("viscosity", rule, m.viscosity);
  if (std::isfinite(m.yield_stress) && m.yield_stress > kMaxStress) fail("yield_stress", rule, m.yield_stress);
  if (m.surface_tension > kMaxStress) fail("surface_tension", rule, m.surface_tension);
}

namespace {
struct Preset {
  const char* name;
  double youngs_modulus, viscosity, yield_stress, flow_rate;
};
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr Preset kPresets[] = {
    {"rigid_brick", 1e6, 20.0, kInf, 0.0},      {"viscous_ooze", 1e4, 100.0, 5.0, 50.0},
    {"jiggly_gelatin", 2e4, 2.0, kInf, 0.0},    {"gooey_jelly", 2e4, 10.0, 400.0, 20.0},
    {"splashing_fluid", 5e3, 0.5, 1.0, 400.0},
};
}  // namespace

const std::vector<std::string>& material_preset_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const Preset& p : kPresets) out.emplace_back(p.name);
    return out;
  }();
  return names;
}

Material material_preset(std::string_view name) {
  for (const Preset& p : kPresets) {
    if (name != p.name) continue;
    Material m;
    m.youngs_modulus = p.youngs_modulus;
    m.viscosity = p.viscosity;
    m.yield_stress = p.yield_stress;
    m.flow_rate = p.flow_rate;
    m.incompressible = true;
    m.min_mass_fraction = kMinMassFraction;
    return m;
  }
  throw Error(fmt::format("unknown material preset '{}' (expected one of {})", name,
                          fmt::join(material_preset_names(), ", ")));
}

}  // namespace goo
