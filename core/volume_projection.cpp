#include "core/volume_projection.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "core/elastic_forces.h"
#include "core/node_sums.h"
#include "core/parallel.h"
#include "core/surface_geometry.h"

namespace goo {
namespace {

/// out_i = ¼ Σ_{e∋i} per_element_e, in the incidence's fixed order.
void quarter_node_sums(const NodeIncidence& incidence, const Eigen::VectorXd& per_element, Eigen::VectorXd& out) {
  out.resize(static_cast<Index>(incidence.offsets.size() - 1));
  sum_over_corners(
      incidence, 0.0, [&](Index corner) { return per_element[corner / 4]; },
      [&](Index n, double sum) { out[n] = 0.25 * sum; });
}

/// store(n, Σ_{corners (e, k) of n} scale_e G_e.col(k)) for every node, in
/// the incidence's fixed order, from G's columns kept in that order
/// (`corner_gradient`): read in sequence, not gathered from the elements.
template <class Store>
void gather_scaled_to_nodes(const NodeIncidence& incidence, const std::vector<Eigen::Vector3d>& corner_gradient,
                            const Eigen::VectorXd& scale, Store&& store) {
  sum_over_incidence(
      incidence, Eigen::Vector3d::Zero().eval(),
      [&](Index i, Index corner) -> Eigen::Vector3d { return scale[corner / 4] * corner_gradient[at(i)]; }, store);
}

/// ∂V/∂x of a tetrahedron's four corners (columns), and V = det(Ds) / 6.
double volume_gradient(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1, const Eigen::Vector3d& x2,
                       const Eigen::Vector3d& x3, Matrix34& g) {
  const Eigen::Vector3d d1 = x1 - x0, d2 = x2 - x0, d3 = x3 - x0;
  g.col(1) = d2.cross(d3) / 6.0;
  g.col(2) = d3.cross(d1) / 6.0;
  g.col(3) = d1.cross(d2) / 6.0;
  g.col(0) = -(g.col(1) + g.col(2) + g.col(3));
  return d1.dot(g.col(1));
}

/// The largest |error_i| / rest_i over the nodes with rest_i > 0 (and
/// flagged in `active`), in parallel runs: a maximum is exact in any order.
double max_relative(const Eigen::VectorXd& error, const Eigen::VectorXd& rest, const std::vector<std::uint8_t>* active) {
  return max_over_runs(static_cast<Index>(error.size()), 2048, [&](Index begin, Index end) {
    double worst = 0.0;
    for (Index n = begin; n < end; ++n) {
      if (active && !(*active)[at(n)]) continue;
      if (rest[n] > 0.0) worst = std::max(worst, std::abs(error[n]) / rest[n]);
    }
    return worst;
  });
}


/// True if an element of `body` is inverted or flat at positions x.
bool any_inverted(const Body& body, const Points& x) {
  return any_index(body.num_elements(), [&](Index e) {
    const Eigen::Vector3d x0 = x.row(body.tets(e, 0)).transpose();
    const Eigen::Matrix3d Ds = (Eigen::Matrix3d() << x.row(body.tets(e, 1)) - x0.transpose(),
                                x.row(body.tets(e, 2)) - x0.transpose(), x.row(body.tets(e, 3)) - x0.transpose())
                                   .finished()
                                   .transpose();
    return !(Ds.determinant() > 0.0);
  });
}

/// An element below this fraction of its rest volume is not constrained.
constexpr double kCrushed = 0.1;
/// A node carries its multiplier into the pressures only where its
/// material, ¼ Σ φ_e V̄_e, is at least this share of a full node's elements
/// (¼ Σ V̄_e of the node that has the most, or of its own if more). A node
/// with share s has a row of G M⁻¹ Gᵀ of order s against its neighbours'
/// and a residual of order s, so its multiplier is of order 1/s of theirs:
/// a fine correction of that step (its G column is of order s too), but
/// summed over steps as a pressure it grows without bound (lattice nodes
/// beside slivers of material, s down to 10⁻¹⁴ in the paper-resolution
/// fluid drop, carried 10¹⁷ Pa, and a fluid on a ball run without restart
/// points blew up at 0.21 s). A full node's, not the node's own elements':
/// a node with few elements (the copies of a separated re-mesh, a node
/// whose empty elements were left out) holds a sliver of material however
/// full those few are (the fluid on the ball, separated, blew up at 0.21 s
/// again while four elements a node had left, 3% full, carried). The
/// constraint itself stays: a node left unconstrained is flung by its
/// neighbours' multipliers (a light node at the mass floor moved 2 m in one
/// drift correction after a re-mesh, and the run blew up).
constexpr double kMinMaterialShare = 0.01;
/// The most of a node's volume the drift correction restores in one step.
constexpr double kMaxDrift = 0.1;
/// Projections between two measurements of the surface's volume.
constexpr int kSurfaceEvery = 8;
/// The contacts' volume is given back at once only where a node is off by
/// more than this many tolerances; less is left to the next step's drift
/// correction. (The paper-resolution fluid drop, whose floor takes a little
/// every step: 176.6 s with every loss given back at once, 150.8 s with
/// ten tolerances, 154.8 s without giving any back; its lowest frame's
/// volume 1.0000, 0.9998 and 0.9980. The bunny press's frames 25–40: 82.6,
/// 74.9 and 70.9 s; 1.0000, 0.9999 and 0.9826.)
constexpr double kRestoreFrom = 10.0;
/// Newton iterations of a restore at most.
constexpr int kRestoreIterations = 3;
/// Iterations with G at xⁿ before the projection turns to Newton's method.
constexpr int kChordIterations = 6;

}  // namespace

VolumeProjectionStats& VolumeProjectionStats::operator+=(const VolumeProjectionStats& o) {
  newton_iterations += o.newton_iterations;
  waited += o.waited;
  cg_iterations += o.cg_iterations;
  error_before = std::max(error_before, o.error_before);
  error = std::max(error, o.error);
  return *this;
}

VolumeProjection::VolumeProjection(VolumeProjectionSettings settings) : settings_(settings) {}

SlidingNodes SlidingNodes::from_contacts(const Body& body, const std::vector<ElementContact>& contacts) {
  SlidingNodes s;
  const Index nn = body.num_nodes();
  s.sliding.assign(at(nn), 0);
  s.free.assign(at(nn), Eigen::Matrix3d::Identity());
  // Gram–Schmidt over each node's normals in the contacts' order (one order
  // for any thread count); sin 1° below which a normal is in the span.
  constexpr double kNewDirection = 0.0175;
  std::vector<std::array<Eigen::Vector3d, 3>> basis(at(nn));
  for (const ElementContact& c : contacts) {
    if (!(c.normal.norm() > 0.0)) continue;
    for (int k = 0; k < 4; ++k) {
      const Index n = body.tets(c.element, k);
      std::uint8_t& count = s.sliding[at(n)];
      if (count == 3) continue;
      Eigen::Vector3d q = c.normal.normalized();
      for (std::uint8_t i = 0; i < count; ++i) q -= q.dot(basis[at(n)][i]) * basis[at(n)][i];
      if (!(q.norm() > kNewDirection)) continue;
      q.normalize();
      basis[at(n)][count++] = q;
      s.free[at(n)] -= q * q.transpose();
    }
  }
  for (std::uint8_t& count : s.sliding) count = count > 0 ? 1 : 0;
  return s;
}

void VolumeProjection::weights(const Body& body) {
  // φ_e, the share of element e the material fills (1 for a tet-mesh body):
  // the constraints hold the material's volume, and an element's empty
  // part is free to change (it is no material).
  const Index ne = body.num_elements();
  weight_ = body.solid_fractions.size() == ne ? body.solid_fractions : Eigen::VectorXd::Ones(ne);
}

void VolumeProjection::gradients(const Body& body, const Points& start) {
  const Index ne = body.num_elements();
  weights(body);
  // The velocity projection prepares G where the force evaluation just
  // took it (add_pressure_forces, then project_velocities at xⁿ⁺¹): the
  // same positions, mesh and fractions give the same G.
  if (gradient_at_.valid && same_bits(gradient_at_.positions, start) && same_bits(gradient_at_.tets, body.tets) &&
      same_bits(gradient_at_.weight, weight_))
    return;
  gradient_at_.valid = true;
  copy_in_parallel(start, gradient_at_.positions);
  copy_in_parallel(body.tets, gradient_at_.tets);
  copy_in_parallel(weight_, gradient_at_.weight);
  gradient_.resize(at(ne));
  // The same columns also in the incidence's order, for the node sums.
  const NodeIncidence& incidence = body.incidence;
  corner_gradient_.resize(incidence.corners.size());
  for_each_index(ne, [&](Index e) {
    const auto x = [&](int k) { return Eigen::Vector3d(start.row(body.tets(e, k)).transpose()); };
    Matrix34& g = gradient_[at(e)];
    volume_gradient(x(0), x(1), x(2), x(3), g);
    g *= weight_[e];
    for (int k = 0; k < 4; ++k) corner_gradient_[at(incidence.slots[at(4 * e + k)])] = g.col(k);
  });
}

void VolumeProjection::volumes(const Body& body, const Points& positions) {
  const Index ne = body.num_elements();
  volume_.resize(ne);
  for_each_index(ne, [&](Index e) {
    Matrix34 unused;
    const auto x = [&](int k) { return Eigen::Vector3d(positions.row(body.tets(e, k)).transpose()); };
    volume_[e] = volume_gradient(x(0), x(1), x(2), x(3), unused);
  });
}

void VolumeProjection::weighted_volumes(const Body& body, const Points& positions) {
  volumes(body, positions);
  weights(body);
  volume_.array() *= weight_.array();
}

// (G M⁻¹ Gᵀ) λ without forming the matrix: per element Λ_e = ¼ Σ_k λ_{n_k};
// y = M⁻¹ Σ_e Λ_e ∂V_e/∂x (node sums in the incidence order); then
// s_e = Σ_k ∂V_e/∂x_k · y_{n_k} and (Aλ)_i = ¼ Σ_{e∋i} s_e.
void VolumeProjection::element_lambdas(const Body& body, const Eigen::VectorXd& lambda) {
  const Index ne = body.num_elements();
  element_lambda_.resize(ne);
  for_each_index(ne, [&](Index e) {
    double s = 0.0;
    for (int k = 0; k < 4; ++k) s += lambda[body.tets(e, k)];
    element_lambda_[e] = 0.25 * s;
  });
}

void VolumeProjection::transpose_product(const Body& body, const Eigen::VectorXd& lambda, Points& out) {
  element_lambdas(body, lambda);
  out.resize(body.num_nodes(), 3);
  gather_scaled_to_nodes(body.incidence, corner_gradient_, element_lambda_,
                         [&](Index n, const Eigen::Vector3d& sum) { out.row(n) = sum.transpose(); });
}

void VolumeProjection::move(const Eigen::VectorXd& lambda) {
  directions(lambda);
}

void VolumeProjection::add_pressure_forces(const Body& body, const Points& x, Points& forces) {
  if (pressure_.size() != body.num_nodes()) return;
  // G at x replaces the prepared one (the same where x is its positions).
  prepared_.valid = prepared_.valid && prepared_.positions.rows() == x.rows() && prepared_.positions == x;
  gradients(body, x);
  transpose_product(body, pressure_, transposed_);
  forces -= transposed_;
}

void VolumeProjection::carry(const Body& body, const Eigen::VectorXd& lambda, double scale) {
  const Index nn = body.num_nodes();
  if (pressure_.size() != nn) pressure_ = Eigen::VectorXd::Zero(nn);
  for (Index n = 0; n < nn; ++n)
    if (node_material_[n] >= kMinMaterialShare * std::max(node_whole_[n], full_node_))
      pressure_[n] += scale * lambda[n];
}

void VolumeProjection::directions(const Eigen::VectorXd& lambda) {
  const Neighbourhoods& h = neighbourhoods_;
  const auto nn = static_cast<Index>(h.offsets.size() - 1);
  direction_.resize(nn, 3);
  for_each_index(nn, [&](Index j) {
    Eigen::Vector3d y = Eigen::Vector3d::Zero();
    for (Index k = h.offsets[at(j)]; k < h.offsets[at(j) + 1]; ++k) y += lambda[h.nodes[at(k)]] * columns_[at(k)];
    if (sliding(j)) y = sliding_->free[at(j)] * y;
    direction_.row(j) = (inverse_mass_[j] * y).transpose();
  });
}

// y = M⁻¹ P Gᵀλ as move(), then (Aλ)_i = Σ_{j∈N(i)} G_ij · y_j: two passes
// over the nodes.
void VolumeProjection::apply(const Body& body, const Eigen::VectorXd& lambda, Eigen::VectorXd& out) {
  const Neighbourhoods& h = neighbourhoods_;
  directions(lambda);
  out.resize(body.num_nodes());
  for_each_index(body.num_nodes(), [&](Index i) {
    double s = 0.0;
    if (active_[at(i)])
      for (Index k = h.offsets[at(i)]; k < h.offsets[at(i) + 1]; ++k)
        s += rows_[at(k)].dot(direction_.row(h.nodes[at(k)]).transpose());
    out[i] = s;
  });
}

bool VolumeProjection::Prepared::same(const Body& body, const Points& at_positions,
                                      const std::vector<std::uint8_t>& fixed_nodes) const {
  return valid && same_bits(positions, at_positions) && same_bits(masses, body.masses) &&
         same_bits(fractions, body.solid_fractions) && same_bits(Fp, body.Fp) && same_bits(fixed, fixed_nodes);
}

bool VolumeProjection::update_neighbourhoods(const Body& body) {
  Neighbourhoods& h = neighbourhoods_;
  if (same_bits(h.tets, body.tets)) return false;
  const Index nn = body.num_nodes();
  const NodeIncidence& incidence = body.incidence;
  h.tets = body.tets;
  h.offsets.assign(at(nn) + 1, 0);
  h.nodes.clear();
  h.slots.assign(4 * incidence.corners.size(), -1);
  for (Index i = 0; i < nn; ++i) {
    const std::size_t first = h.nodes.size();
    for (Index c = incidence.offsets[at(i)]; c < incidence.offsets[at(i) + 1]; ++c) {
      const Index e = incidence.corners[at(c)] / 4;
      for (int k = 0; k < 4; ++k) {
        const Index j = body.tets(e, k);
        std::size_t slot = first;
        while (slot < h.nodes.size() && h.nodes[slot] != j) ++slot;
        if (slot == h.nodes.size()) h.nodes.push_back(j);
        h.slots[4 * at(c) + static_cast<std::size_t>(k)] = static_cast<Index>(slot - first);
      }
    }
    h.offsets[at(i) + 1] = static_cast<Index>(h.nodes.size());
  }
  return true;
}

void VolumeProjection::prepare(const Body& body, const Points& at_positions, const std::vector<std::uint8_t>& fixed) {
  // Everything below is a function of these (and of the rest volumes,
  // which change only with the mesh, and the sliding nodes, which only a
  // restore has and which it never reuses).
  if (update_neighbourhoods(body)) prepared_.valid = false;
  if (sliding_ == nullptr && prepared_.same(body, at_positions, fixed)) {
    rest_ = prepared_.rest;
    return;
  }
  prepare_anew(body, at_positions, fixed);
  prepared_.valid = sliding_ == nullptr;
  if (prepared_.valid) {
    copy_in_parallel(at_positions, prepared_.positions);
    copy_in_parallel(body.masses, prepared_.masses);
    copy_in_parallel(body.solid_fractions, prepared_.fractions);
    copy_in_parallel(body.Fp, prepared_.Fp);
    copy_in_parallel(fixed, prepared_.fixed);
    copy_in_parallel(rest_, prepared_.rest);
  }
}

void VolumeProjection::prepare_anew(const Body& body, const Points& at_positions,
                                    const std::vector<std::uint8_t>& fixed) {
  prepare_constraints(body, at_positions, fixed);
  prepare_rows(body);
}

void VolumeProjection::prepare_constraints(const Body& body, const Points& at_positions,
                                           const std::vector<std::uint8_t>& fixed) {
  const Index ne = body.num_elements(), nn = body.num_nodes();
  gradients(body, at_positions);
  inverse_mass_.resize(nn);
  for_each_index(nn, [&](Index n) {
    const bool is_fixed = at(n) < fixed.size() && fixed[at(n)];
    inverse_mass_[n] = !is_fixed && body.masses[n] > 0.0 ? 1.0 / body.masses[n] : 0.0;
  });
  // An element whose nodes are all fixed cannot change its volume: it is
  // left out of the constraints (its error would make them inconsistent).
  // An inverted or crushed element (V_e below a tenth of its rest volume
  // where G is taken) is left to the elasticity: pulling it back through
  // or from near zero volume in one step would throw its nodes across the
  // mesh.
  movable_.assign(at(ne), 0);
  rest_.resize(ne);
  whole_.resize(ne);
  for_each_index(ne, [&](Index e) {
    const Matrix34& g = gradient_[at(e)];
    const Eigen::Vector3d x0 = at_positions.row(body.tets(e, 0)).transpose();
    const double V = (Eigen::Vector3d(at_positions.row(body.tets(e, 1)).transpose()) - x0).dot(g.col(1));
    bool movable = false;
    for (int k = 0; k < 4; ++k) movable = movable || inverse_mass_[body.tets(e, k)] > 0.0;
    movable = movable && V > kCrushed * weight_[e] * body.rest_volumes[e] * body.Fp[at(e)].determinant();
    movable_[at(e)] = movable ? 1 : 0;
    whole_[e] = body.rest_volumes[e] * body.Fp[at(e)].determinant();
    rest_[e] = movable ? whole_[e] : 0.0;
  });
  quarter_node_sums(body.incidence, rest_, node_rest_);  // the tolerance's scale: whole elements
  rest_.array() *= weight_.array();
  // The material's share of each node's elements, movable or not (a node
  // whose elements are crushed still holds them).
  quarter_node_sums(body.incidence, whole_, node_whole_);
  full_node_ = nn > 0 ? node_whole_.maxCoeff() : 0.0;
  whole_.array() *= weight_.array();
  quarter_node_sums(body.incidence, whole_, node_material_);
}

void VolumeProjection::prepare_rows(const Body& body) {
  const Index nn = body.num_nodes();
  // A_ii = Σ_j |G_ij|² / m_j with G_ij = ¼ Σ_{e∋i,j} ∂V_e/∂x_j, gathered per
  // node over its elements' corners: the Jacobi preconditioner. A node is
  // constrained where its row is not zero up to round-off (Σ_e |¼ ∂V_e/∂x_j|²
  // / m_j is the scale).
  active_.assign(at(nn), 0);
  diagonal_.resize(nn);
  const Neighbourhoods& h = neighbourhoods_;
  rows_.resize(h.nodes.size());
  columns_.resize(h.nodes.size());
  for_each_index(nn, [&](Index i) {
    const Index first = h.offsets[at(i)], used = h.offsets[at(i) + 1] - first;
    double scale = 0.0, a = 0.0;
    // Node i's entries gathered apart from the arrays they read (on the
    // stack where they fit), then stored: G_ij (row i) and G_ji (i's own
    // gradient in the elements it shares with j).
    const auto gather = [&](auto& row, auto& column) {
      for (Index k = 0; k < used; ++k) {
        row[at(k)].setZero();
        column[at(k)].setZero();
      }
      for (Index c = body.incidence.offsets[at(i)]; c < body.incidence.offsets[at(i) + 1]; ++c) {
        const Index corner = body.incidence.corners[at(c)], e = corner / 4;
        const Eigen::Vector3d own = 0.25 * gradient_[at(e)].col(corner % 4);
        for (int k = 0; k < 4; ++k) {
          const Index j = body.tets(e, k);
          const Eigen::Vector3d g = 0.25 * gradient_[at(e)].col(k);
          scale += (sliding(j) ? (sliding_->free[at(j)] * g).squaredNorm() : g.squaredNorm()) * inverse_mass_[j];
          const auto slot = at(h.slots[4 * at(c) + static_cast<std::size_t>(k)]);
          row[slot] += g;
          column[slot] += own;
        }
      }
      for (Index k = 0; k < used; ++k) {  // |P_j G_ij|² / m_j
        const Index j = h.nodes[at(first + k)];
        const Eigen::Vector3d g = sliding(j) ? Eigen::Vector3d(sliding_->free[at(j)] * row[at(k)]) : row[at(k)];
        a += g.squaredNorm() * inverse_mass_[j];
      }
      std::copy(row.begin(), row.begin() + used, rows_.begin() + first);
      std::copy(column.begin(), column.begin() + used, columns_.begin() + first);
    };
    if (used <= 64) {
      std::array<Eigen::Vector3d, 64> row, column;
      gather(row, column);
    } else {
      std::vector<Eigen::Vector3d> row(at(used)), column(at(used));
      gather(row, column);
    }
    const bool on = a > 1e-10 * scale && node_rest_[i] > 0.0;
    active_[at(i)] = on ? 1 : 0;
    diagonal_[i] = on ? a : 1.0;
  });
}

int VolumeProjection::solve(const Body& body, const Eigen::VectorXd& rhs, double target, Eigen::VectorXd& lambda) {
  const Index nn = body.num_nodes();
  for (Index n = 0; n < nn; ++n)
    if (!active_[at(n)]) lambda[n] = 0.0;
  if (lambda.isZero(0.0)) {
    r_ = rhs;  // A 0 = 0: the product is not needed
  } else {
    apply(body, lambda, Ap_);
    r_ = rhs - Ap_;
  }
  for (Index n = 0; n < nn; ++n)
    if (!active_[at(n)]) r_[n] = 0.0;
  // Stops when every node's residual is below target × V̄_i, or where the
  // residual stops falling (ε-small pivots of a singular system); the best
  // iterate wins.
  z_ = r_.cwiseQuotient(diagonal_);
  p_ = z_;
  double rz = r_.dot(z_);
  double residual = max_relative(r_, node_rest_, nullptr), best = residual;
  best_ = lambda;
  int iteration = 0;
  while (residual > target && iteration < settings_.max_cg_iterations && residual < 1e3 * best) {
    apply(body, p_, Ap_);
    const double pAp = p_.dot(Ap_);
    if (!(pAp > 0.0)) break;
    const double alpha = rz / pAp;
    // The updates entry by entry in parallel (each entry's operations as
    // the vector expressions round them), the dot products as before.
    for_each_index(
        nn,
        [&](Index n) {
          lambda[n] += alpha * p_[n];
          r_[n] -= alpha * Ap_[n];
          z_[n] = r_[n] / diagonal_[n];
        },
        2048);
    const double rz_next = r_.dot(z_);
    const double beta = rz_next / rz;
    for_each_index(
        nn, [&](Index n) { p_[n] = z_[n] + beta * p_[n]; }, 2048);
    rz = rz_next;
    ++iteration;
    residual = max_relative(r_, node_rest_, nullptr);
    if (residual < best) {
      best = residual;
      best_ = lambda;
    }
  }
  lambda = best_;
  last_residual_ = best;
  return iteration;
}

double VolumeProjection::surface_target_scale(const Body& body) {
  const Index ne = body.num_elements();
  if (body.surface_triangles.rows() == 0 || !(body.rest_material_volume > 0.0) ||
      body.solid_fractions.size() != ne)
    return 1.0;
  // V_s(x) − Σ φ_e V_e(x): what the surface encloses beyond the material
  // the elements hold (its triangles are straight across element faces,
  // where the elements' map bends); it changes slowly with the shape.
  volumes(body, body.positions);
  // Each element's terms in parallel, then summed in element order.
  rest_term_.resize(ne);
  for_each_index(ne, [&](Index e) {
    volume_[e] = body.solid_fractions[e] * volume_[e];
    rest_term_[e] = body.solid_fractions[e] * body.rest_volumes[e] * body.Fp[at(e)].determinant();
  });
  CompensatedSum material, rest;
  for (Index e = 0; e < ne; ++e) {
    material.add(volume_[e]);
    rest.add(rest_term_[e]);
  }
  // The surface itself is measured every kSurfaceEvery projections (and
  // after every reset(), so a resumed run measures where the first did).
  if (surface_age_ == 0 || surface_age_ >= kSurfaceEvery)
    surface_age_ = 0, discrepancy_ = surface_integrals(body.surface()).volume - material.value();
  ++surface_age_;
  const double scale = (body.rest_material_volume - discrepancy_) / rest.value();
  return std::isfinite(scale) ? std::clamp(scale, 0.9, 1.1) : 1.0;
}

VolumeProjectionStats VolumeProjection::project(Body& body, const Points& start, const std::vector<std::uint8_t>& fixed,
                                               double dt, double span) {
  VolumeProjectionStats stats;
  const Index ne = body.num_elements(), nn = body.num_nodes();
  if (ne == 0 || !(dt > 0.0)) return stats;
  if (any_inverted(body, start)) {
    // An inverted element's volume is no constraint to hold: the
    // elasticity turns the body right side out first (as the self-collision
    // stage waits).
    stats.waited = 1;
    return stats;
  }
  const double scale = span > 0.0 ? surface_target_scale(body) : 1.0;
  prepare(body, start, fixed);
  if (scale != 1.0) rest_ *= scale;
  lambda_ = Eigen::VectorXd::Zero(nn);
  if (span > 0.0) {
    // What the nodes had lost or gained before the step (contacts, the
    // surface against itself, a re-mesh, elements turning back from
    // inversion) is no motion of this step: it is corrected in the
    // positions alone. Only the error the step's motion made becomes
    // velocity and carried pressure, so a drift never turns into speed
    // (Δx/Δt at a tiny Δt) or winds the pressure up.
    weighted_volumes(body, start);
    for_each_index(ne, [&](Index e) { volume_[e] = movable_[at(e)] ? volume_[e] - rest_[e] : 0.0; });
    quarter_node_sums(body.incidence, volume_, error_);
    const double drift = max_relative(error_, node_rest_, &active_);
    if (drift > settings_.tolerance) {
      // At most kMaxDrift of a node's volume per step: a large drift (an
      // element just turned back from inversion) is recovered over steps.
      for (Index n = 0; n < nn; ++n)
        error_[n] = std::clamp(error_[n], -kMaxDrift * node_rest_[n], kMaxDrift * node_rest_[n]);
      // Inexact: a tenth of the drift is left for the iterations below.
      stats.cg_iterations += solve(body, error_, std::max(0.25 * settings_.tolerance, 0.1 * drift), lambda_);
      if (lambda_.allFinite()) {
        move(lambda_);
        body.positions -= direction_;
      }
    }
  }
  Eigen::VectorXd total = Eigen::VectorXd::Zero(nn);
  double last_error = 0.0;
  bool chord = true, restarted = false;
  for (int newton = 0;; ++newton) {
    weighted_volumes(body, body.positions);
    for_each_index(ne, [&](Index e) { volume_[e] = movable_[at(e)] ? volume_[e] - rest_[e] : 0.0; });
    quarter_node_sums(body.incidence, volume_, error_);
    const double error = max_relative(error_, node_rest_, &active_);
    if (newton == 0) stats.error_before = error;
    if (newton > 0 && !restarted && !(error < last_error || error <= settings_.tolerance)) {
      // The last correction did not help: it is undone. A chord iteration
      // (G at xⁿ) stalls when the step moved the nodes far; Newton's
      // method takes over from the best point (G there). A Newton
      // iteration that does not help means an inconsistent or ill-posed
      // system: the projection stops where it was best.
      body.positions += direction_;
      body.velocities += direction_ / dt;
      total -= lambda_;
      if (chord && newton < settings_.max_newton_iterations) {
        chord = false;
        restarted = true;
        prepare(body, body.positions, fixed);
        if (scale != 1.0) rest_ *= scale;
        continue;
      }
      stats.error = last_error;
      break;
    }
    restarted = false;
    stats.error = last_error = error;
    if (error <= settings_.tolerance || newton == settings_.max_newton_iterations) break;
    stats.newton_iterations = newton + 1;
    if (chord && newton == kChordIterations) {
      chord = false;
      // Still far after the chord iterations (a large step): Newton's
      // method from here, G at the current positions (the impulses then
      // exert a torque about xⁿ of the order of the correction).
      prepare(body, body.positions, fixed);
      if (scale != 1.0) rest_ *= scale;
    }
    // A δ = V(x) − V̄ over the constrained nodes, then x ← x − M⁻¹ Gᵀ δ and
    // v ← v − M⁻¹ Gᵀ δ / Δt.
    lambda_.setZero();
    // Inexact Newton: each solve only as accurate as the iteration needs
    // (a tenth of the error it starts from), the last to a quarter of the
    // tolerance.
    stats.cg_iterations += solve(body, error_, std::max(0.25 * settings_.tolerance, 0.1 * error), lambda_);
    if (!lambda_.allFinite()) break;
    move(lambda_);
    body.positions -= direction_;
    body.velocities -= direction_ / dt;
    total += lambda_;
  }
  // The impulse −Gᵀλ / Δt, as a force over the integrator's span, joins
  // the pressure force that later steps apply.
  if (stats.newton_iterations > 0 && span > 0.0) carry(body, total, 1.0 / (dt * span));
  return stats;
}

VolumeProjectionStats VolumeProjection::restore(Body& body, const std::vector<std::uint8_t>& fixed,
                                               const SlidingNodes& sliding, double from) {
  VolumeProjectionStats stats;
  const Index ne = body.num_elements(), nn = body.num_nodes();
  if (ne == 0 || any_inverted(body, body.positions)) return stats;
  sliding_ = &sliding;
  const double scale = surface_target_scale(body);
  // Newton's method on the positions (G at each iterate), each solve to a
  // quarter of the tolerance; as the drift at a projection's start, at most
  // kMaxDrift of a node's volume a call. An iteration that does not reduce
  // the error is undone. The error after a move is measured with the
  // constraints as last prepared (the elements that may move, the nodes
  // constrained: a move of a few tolerances changes neither in practice);
  // G is taken anew only if another iteration follows.
  const auto prepare_here = [&] {
    prepare(body, body.positions, fixed);
    if (scale != 1.0) rest_ *= scale;
  };
  const auto measure = [&](const std::vector<std::uint8_t>* over) {
    weighted_volumes(body, body.positions);
    for_each_index(ne, [&](Index e) { volume_[e] = movable_[at(e)] ? volume_[e] - rest_[e] : 0.0; });
    quarter_node_sums(body.incidence, volume_, error_);
    return max_relative(error_, node_rest_, over);
  };
  // Most calls find every node within `from` and move nothing. That needs
  // only the first half of a preparation (the elements that may move, the
  // nodes' rest volumes), measured over every node with a rest volume: a
  // superset of the constrained nodes (active_), so a bound on their error.
  // G's rows, the costly half, are gathered only when it is over `from`;
  // the preparation is then prepare_here()'s, to the bit. (The armadillo
  // grate, frame 72: 145 of 146 restores moved nothing.)
  static_cast<void>(update_neighbourhoods(body));
  prepared_.valid = false;  // as prepare() leaves it with sliding nodes
  prepare_constraints(body, body.positions, fixed);
  if (scale != 1.0) rest_ *= scale;
  if (const double bound = measure(nullptr); !(bound > from)) {
    stats.error_before = stats.error = bound;
    sliding_ = nullptr;
    return stats;
  }
  prepare_rows(body);
  double last = std::numeric_limits<double>::infinity();
  for (int iteration = 0; iteration <= kRestoreIterations; ++iteration) {
    // The first error_ is the bound's (the same positions and constraints):
    // only its maximum over the constrained nodes is new.
    const double error = iteration == 0 ? max_relative(error_, node_rest_, &active_) : measure(&active_);
    if (iteration == 0) {
      stats.error_before = stats.error = error;
      if (!(error > from)) break;  // left to the next step's drift correction
    }
    if (!(error < last)) {
      if (iteration > 0) body.positions += direction_;
      break;
    }
    stats.error = last = error;
    if (error <= settings_.tolerance || iteration == kRestoreIterations) break;
    if (iteration > 0) {
      prepare_here();
      measure(&active_);  // error_ with this G's constraints
    }
    for (Index n = 0; n < nn; ++n)
      error_[n] = std::clamp(error_[n], -kMaxDrift * node_rest_[n], kMaxDrift * node_rest_[n]);
    lambda_ = iteration == 0 && restore_start_.size() == nn ? restore_start_ : Eigen::VectorXd::Zero(nn);
    stats.cg_iterations += solve(body, error_, 0.25 * settings_.tolerance, lambda_);
    stats.newton_iterations = iteration + 1;
    if (!lambda_.allFinite()) break;
    if (iteration == 0) restore_start_ = lambda_;
    move(lambda_);
    body.positions -= direction_;
  }
  sliding_ = nullptr;
  return stats;
}

CollisionStats resolve_positions_keeping_volume(Body& body, SurfaceCollisions& collisions, VolumeProjection& projection,
                                                const std::vector<Obstacle>& obstacles, double t,
                                                const std::vector<std::uint8_t>& fixed, VolumeProjectionStats& stats,
                                                double& restore_seconds) {
  std::vector<ElementContact> contacts;
  CollisionStats out = collisions.resolve_positions(body, obstacles, t, fixed, 4, &contacts);
  if (contacts.empty()) return out;
  const auto start = std::chrono::steady_clock::now();
  const VolumeProjectionStats restored =
      projection.restore(body, fixed, SlidingNodes::from_contacts(body, contacts), kRestoreFrom * projection.tolerance());
  restore_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (restored.newton_iterations == 0) return out;  // nothing moved
  stats.cg_iterations += restored.cg_iterations;
  stats.error = std::max(stats.error, restored.error);
  const CollisionStats again = collisions.resolve_positions(body, obstacles, t, fixed);
  out.resolved += again.resolved;
  out.passes += again.passes;
  out.deepest = std::min(out.deepest, again.deepest);
  return out;
}

VolumeProjectionStats VolumeProjection::project_velocities(Body& body, const std::vector<std::uint8_t>& fixed,
                                                          double dt, double span, Points& forces) {
  VolumeProjectionStats stats;
  const Index ne = body.num_elements(), nn = body.num_nodes();
  if (ne == 0 || !(dt > 0.0)) return stats;
  if (any_inverted(body, body.positions)) {
    stats.waited = 1;
    return stats;
  }
  prepare(body, body.positions, fixed);
  // The volume rates dV_i/dt = ¼ Σ_{e∋i} Σ_k ∂V_e/∂x_k · v_k, as a volume
  // change over one step, so that the tolerance means what it means above.
  element_sum_.resize(ne);
  for_each_index(ne, [&](Index e) {
    double s = 0.0;
    for (int k = 0; k < 4; ++k) s += gradient_[at(e)].col(k).dot(body.velocities.row(body.tets(e, k)).transpose());
    element_sum_[e] = movable_[at(e)] ? dt * s : 0.0;
  });
  quarter_node_sums(body.incidence, element_sum_, error_);
  for (Index n = 0; n < nn; ++n)
    if (!active_[at(n)]) error_[n] = 0.0;
  stats.error_before = stats.error = max_relative(error_, node_rest_, nullptr);
  if (stats.error <= settings_.tolerance) return stats;
  stats.newton_iterations = 1;
  lambda_ = Eigen::VectorXd::Zero(nn);
  stats.cg_iterations = solve(body, error_, 0.25 * settings_.tolerance, lambda_);
  if (!lambda_.allFinite()) return stats;
  transpose_product(body, lambda_, transposed_);
  for (Index n = 0; n < nn; ++n) body.velocities.row(n) -= (inverse_mass_[n] / dt) * transposed_.row(n);
  carry(body, lambda_, 1.0 / (dt * span));
  forces -= transposed_ / (dt * span);
  stats.error = last_residual_;
  return stats;
}

double max_nodal_volume_error(const Body& body, const Points& x) {
  const Index ne = body.num_elements();
  Eigen::VectorXd difference(ne), whole(ne);
  for_each_index(ne, [&](Index e) {
    Matrix34 g;
    const auto p = [&](int k) { return Eigen::Vector3d(x.row(body.tets(e, k)).transpose()); };
    whole[e] = body.rest_volumes[e] * body.Fp[at(e)].determinant();
    difference[e] = volume_gradient(p(0), p(1), p(2), p(3), g) - whole[e];
  });
  Eigen::VectorXd error, node_whole;
  quarter_node_sums(body.incidence, difference, error);
  quarter_node_sums(body.incidence, whole, node_whole);
  return max_relative(error, node_whole, nullptr);
}

}  // namespace goo
