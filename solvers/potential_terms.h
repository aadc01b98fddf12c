#pragma once
// The terms of backward Euler's incremental potential and of the static
// solve's potential energy (docs/implicit.md; algorithms.md, "Time
// integration"), each with its value, its forces (the negative gradient) and
// its part of the Hessian:
//   inertia     ½ Δt⁻² ‖y − x̂‖²_M                 (dynamics)
//   elasticity  Ψ(y) = Σ_e W_e ψ(F_e Fp_e⁻¹)
//   tension     σ A(W y)                          (σ > 0 and a surface)
//   damping     Δt D((y − xⁿ)/Δt), D(v) = ½ vᵀCv   (dynamics, viscosity > 0)
//   load        −Σ m γ g·y                        (statics)
// A term adds its forces to a sum, and the potential's gradient is that sum
// negated: with the elastic and surface forces summed first, this has the
// bits of the force sums each of them is (round-to-nearest is symmetric).
#include <cstdint>
#include <vector>

#include "core/body.h"
#include "core/elastic_forces.h"
#include "core/element_elasticity.h"
#include "solvers/embedded_tension.h"

namespace goo {

/// What a term's add_hessian adds to: per-element 12×12 blocks (the
/// elasticity sets them, later terms add), the 3N diagonal (zero to
/// start), per-surface-triangle 9×9 blocks in corner positions.
struct HessianParts {
  std::vector<Matrix12>& elements;
  Eigen::VectorXd& diagonal;
  std::vector<Matrix9d>& triangles;
  bool project = false;  ///< element and triangle blocks projected to positive semi-definite
};

class PotentialTerm {
 public:
  virtual ~PotentialTerm() = default;
  [[nodiscard]] virtual double value(const Points& y) = 0;
  /// f += −∇value(y).
  virtual void add_forces(const Points& y, Points& f) = 0;
  virtual void add_hessian(const Points& y, HessianParts& h) = 0;
};

/// Ψ(y): its forces with no plastic flow (plasticity follows convergence).
class ElasticityTerm final : public PotentialTerm {
 public:
  ElasticityTerm(Body& body, ElasticForces& elastic) : body_(body), elastic_(elastic) {}
  double value(const Points& y) override;
  void add_forces(const Points& y, Points& f) override;
  /// Sets every element's block to its Hessian K_e (K_e⁺ when projecting).
  void add_hessian(const Points& y, HessianParts& h) override;

 private:
  Body& body_;  // ElasticForces::evaluate keeps per-element state in it
  ElasticForces& elastic_;
  Points scratch_;
};

/// σ A(W y), the area-gradient surface tension (W&T sec. 7 as an energy).
class TensionTerm final : public PotentialTerm {
 public:
  TensionTerm(const Body& body, EmbeddedTension& tension) : body_(body), tension_(tension) {}
  double value(const Points& y) override;
  void add_forces(const Points& y, Points& f) override;
  void add_hessian(const Points& y, HessianParts& h) override;

 private:
  const Body& body_;
  EmbeddedTension& tension_;
};

/// ½ Δt⁻² ‖y − x̂‖²_M, x̂ the position inertia and the constant loads reach.
class InertiaTerm final : public PotentialTerm {
 public:
  InertiaTerm(const Body& body, Points target, double dt) : body_(body), target_(std::move(target)), dt_(dt) {}
  double value(const Points& y) override;
  void add_forces(const Points& y, Points& f) override;
  void add_hessian(const Points& y, HessianParts& h) override;
  [[nodiscard]] const Points& target() const { return target_; }

 private:
  const Body& body_;
  Points target_;
  double dt_;
};

/// Δt D((y − xⁿ)/Δt) with C_e at Fe frozen at xⁿ (damping is linear in v:
/// one matrix per element a step).
class DampingTerm final : public PotentialTerm {
 public:
  DampingTerm(const Body& body, const Points& xn, double dt);
  double value(const Points& y) override;
  void add_forces(const Points& y, Points& f) override;
  /// Adds C_e/Δt to every element's block.
  void add_hessian(const Points& y, HessianParts& h) override;

 private:
  const Body& body_;
  Points xn_;
  double dt_;
  std::vector<Matrix12> C_;
  Points scratch_;
};

/// −Σ_n m_n g·y_n: the work of a constant load g (statics: gravity × its ramp).
class LoadTerm final : public PotentialTerm {
 public:
  LoadTerm(const Body& body, const Eigen::Vector3d& g) : body_(body), g_(g) {}
  double value(const Points& y) override;
  void add_forces(const Points& y, Points& f) override;
  void add_hessian(const Points& y, HessianParts& h) override;

 private:
  const Body& body_;
  Eigen::Vector3d g_;
};

}  // namespace goo
