#include "solvers/potential_terms.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/parallel.h"

namespace goo {

namespace {

/// out = Σ_e C_e v_e, gathered in element order.
void apply_blocks(const Body& body, const std::vector<Matrix12>& C, const Points& v, Points& out) {
  out.setZero(body.num_nodes(), 3);
  for (Index e = 0; e < body.num_elements(); ++e) {
    Eigen::Matrix<double, 12, 1> ve;
    for (int k = 0; k < 4; ++k) ve.segment<3>(3 * k) = v.row(body.tets(e, k)).transpose();
    const Eigen::Matrix<double, 12, 1> f = C[at(e)] * ve;
    for (int k = 0; k < 4; ++k) out.row(body.tets(e, k)) += f.segment<3>(3 * k).transpose();
  }
}

}  // namespace

double ElasticityTerm::value(const Points& y) { return elastic_energy(body_, y); }

void ElasticityTerm::add_forces(const Points& y, Points& f) {
  elastic_.evaluate(body_, y, 0.0, scratch_);
  f += scratch_;
}

void ElasticityTerm::add_hessian(const Points& y, HessianParts& h) {
  const IsotropicEnergy energy(body_.material);
  const Index ne = body_.num_elements();
  h.elements.resize(at(ne));
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e)
      h.elements[at(e)] = element_hessian(energy, ElementRest::of(body_, e), element_corners(body_, y, e), h.project);
  });
}

double TensionTerm::value(const Points& y) { return EmbeddedTension::energy(body_, y); }

void TensionTerm::add_forces(const Points& y, Points& f) {
  tension_.add_forces(body_, y, SurfaceTensionForm::area_gradient, f);
}

void TensionTerm::add_hessian(const Points& y, HessianParts& h) {
  EmbeddedTension::triangle_hessians(body_, y, h.project, h.triangles);
}

double InertiaTerm::value(const Points& y) {
  const Eigen::VectorXd& m = body_.masses;
  double sum = 0.0;
  for (Index n = 0; n < body_.num_nodes(); ++n) sum += m[n] * (y.row(n) - target_.row(n)).squaredNorm();
  return 0.5 * sum / (dt_ * dt_);
}

void InertiaTerm::add_forces(const Points& y, Points& f) {
  const Eigen::VectorXd& m = body_.masses;
  for (Index n = 0; n < body_.num_nodes(); ++n) f.row(n) -= m[n] * (y.row(n) - target_.row(n)) / (dt_ * dt_);
}

void InertiaTerm::add_hessian(const Points& /*y*/, HessianParts& h) {
  for (Index n = 0; n < body_.num_nodes(); ++n)
    h.diagonal.segment<3>(3 * n).array() += body_.masses[n] / (dt_ * dt_);
}

DampingTerm::DampingTerm(const Body& body, const Points& xn, double dt) : body_(body), xn_(xn), dt_(dt) {
  const Index ne = body.num_elements();
  C_.resize(at(ne));
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) {
      const Eigen::Matrix3d Fe = deformation_gradient(body, xn, e) * body.Fp[at(e)].inverse();
      C_[at(e)] = element_damping_matrix(body.material.viscosity, ElementRest::of(body, e), Fe);
    }
  });
}

double DampingTerm::value(const Points& y) {
  const Points v = (y - xn_) / dt_;
  apply_blocks(body_, C_, v, scratch_);
  return 0.5 * dt_ * (v.array() * scratch_.array()).sum();
}

void DampingTerm::add_forces(const Points& y, Points& f) {
  apply_blocks(body_, C_, (y - xn_) / dt_, scratch_);
  f -= scratch_;
}

void DampingTerm::add_hessian(const Points& /*y*/, HessianParts& h) {
  const Index ne = body_.num_elements();
  tbb::parallel_for(tbb::blocked_range<Index>(0, ne, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index e = r.begin(); e != r.end(); ++e) h.elements[at(e)] += C_[at(e)] / dt_;
  });
}

double LoadTerm::value(const Points& y) {
  double work = 0.0;
  for (Index n = 0; n < body_.num_nodes(); ++n) work += body_.masses[n] * g_.dot(y.row(n).transpose());
  return -work;
}

void LoadTerm::add_forces(const Points& /*y*/, Points& f) {
  for (Index n = 0; n < body_.num_nodes(); ++n) f.row(n) += body_.masses[n] * g_.transpose();
}

void LoadTerm::add_hessian(const Points& /*y*/, HessianParts& /*h*/) {}

}  // namespace goo
