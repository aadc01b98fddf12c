#include "solvers/remesh.h"

#include <Eigen/Cholesky>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <cmath>

#include "core/elastic_forces.h"
#include "core/error.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/plasticity.h"
#include "core/surface_geometry.h"
#include "meshing/exact_mass.h"
#include "meshing/material_parts.h"
#include "meshing/remesh_trigger.h"
#include "meshing/transfer.h"
#include "solvers/stepping.h"

namespace goo {
namespace {

/// A body at rest on a fresh lattice mesh: rest shape from the lattice's
/// table (every element is congruent), F = Fp = I, masses left empty.
Body body_on_lattice(const LatticeMesh& lm, const Material& material) {
  validate(material);
  Body body;
  body.material = material;
  body.rest_positions = lm.mesh.positions;
  body.positions = lm.mesh.positions;
  body.velocities = Points::Zero(lm.mesh.num_nodes(), 3);
  body.tets = lm.mesh.tets;
  const Index ne = body.num_elements();
  body.Dm_inv.resize(at(ne));
  for (Index e = 0; e < ne; ++e) body.Dm_inv[at(e)] = lm.lattice.Dm_inv(lm.tet_keys[at(e)]);
  body.rest_volumes = Eigen::VectorXd::Constant(ne, lm.lattice.tet_volume());
  body.Fp.assign(at(ne), Eigen::Matrix3d::Identity());
  body.alpha = Eigen::VectorXd::Zero(ne);
  // κ(Dm) = κ(Dm⁻¹), the same for every lattice tetrahedron.
  body.rest_condition = Eigen::VectorXd::Constant(ne, ne > 0 ? condition_number(body.Dm_inv[0]) : 1.0);
  body.incidence = NodeIncidence::build(body.tets, body.num_nodes());
  return body;
}

struct Totals {
  double mass = 0.0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d momentum = Eigen::Vector3d::Zero();
};

Totals totals(const Eigen::VectorXd& m, const Points& x, const Points& v) {
  std::array<CompensatedSum, 7> s;
  for (Index n = 0; n < m.size(); ++n) {
    s[0].add(m[n]);
    for (int k = 0; k < 3; ++k) {
      s[static_cast<std::size_t>(1 + k)].add(m[n] * x(n, k));
      s[static_cast<std::size_t>(4 + k)].add(m[n] * v(n, k));
    }
  }
  Totals t;
  t.mass = s[0].value();
  t.centre = Eigen::Vector3d(s[1].value(), s[2].value(), s[3].value()) / t.mass;
  t.momentum = Eigen::Vector3d(s[4].value(), s[5].value(), s[6].value());
  return t;
}

/// φ_e = V_solid / W_e of a fresh lattice (positions = rest), in [0, 1].
Eigen::VectorXd solid_fractions(const ElementSolid& solid, const Eigen::VectorXd& rest_volumes) {
  return (solid.volume.array() / rest_volumes.array()).max(0.0).min(1.0).matrix();
}

/// The body moved onto the lattice mesh's virtual-node copies where its
/// material is split (docs/lattice.md, "Material parts"): node state
/// (positions, velocities) to every copy of a node, element state (rest
/// shape, Fp, α) to every copy of an element, each copy's solid its part's,
/// masses from those, the surface vertices to the copies of their parts.
/// body.embedding is the surface embedded in lm. Nothing changes where no
/// element is split and no node copied. Returns the number of elements
/// with two or more parts.
Index separate_parts(const LatticeMesh& lm, const TriangleMesh& surface, const SurfacePieces& pieces,
                     const ElementSolid& solid, std::span<const double> det_Fe, Body& body,
                     SeparationReport* report) {
  const MaterialParts parts = material_parts(lm, surface, pieces);
  if (report) {
    report->split_elements = parts.split_elements();
    report->degenerate_elements = parts.degenerate_elements();
  }
  if (parts.split_elements() == 0 && parts.duplicated_nodes() == 0) return 0;
  const SeparatedMesh separated = separate_parts(lm, parts);
  const LatticeMesh& copies = separated.copies;
  const Index nc = copies.mesh.num_elements(), nn = copies.mesh.num_nodes();
  if (report) report->node_copies = nn - lm.mesh.num_nodes();
  Body out;
  out.material = body.material;
  out.rest_positions = copies.mesh.positions;
  out.positions = copies.mesh.positions;
  out.velocities.resize(nn, 3);
  for (Index n = 0; n < nn; ++n) out.velocities.row(n) = body.velocities.row(separated.node[at(n)]);
  out.tets = copies.mesh.tets;
  out.Dm_inv.resize(at(nc));
  out.Fp.resize(at(nc));
  out.rest_volumes.resize(nc);
  out.alpha.resize(nc);
  out.rest_condition.resize(nc);
  ElementSolid copy_solid;
  copy_solid.volume.resize(nc);
  copy_solid.centroid.resize(nc, 3);
  std::vector<double> copy_det_Fe(at(nc));
  for (Index c = 0; c < nc; ++c) {
    const Index e = separated.element[at(c)], p = separated.part[at(c)];
    out.Dm_inv[at(c)] = body.Dm_inv[at(e)];
    out.Fp[at(c)] = body.Fp[at(e)];
    out.rest_volumes[c] = body.rest_volumes[e];
    out.alpha[c] = body.alpha[e];
    out.rest_condition[c] = body.rest_condition[e];
    copy_det_Fe[at(c)] = det_Fe.empty() ? 1.0 : det_Fe[at(e)];
    // An element of one part keeps the exact masses' clipped solid (the
    // same bits as without copies); the parts of a split one their own.
    if (parts.num_parts(e) == 1) {
      copy_solid.volume[c] = solid.volume[e];
      copy_solid.centroid.row(c) = solid.centroid.row(e);
    } else {
      copy_solid.volume[c] = std::max(parts.part_volume[p], 0.0);
      copy_solid.centroid.row(c) = parts.part_centroid.row(p);
    }
  }
  out.solid_fractions = solid_fractions(copy_solid, out.rest_volumes);
  out.masses = exact_node_masses(copies, copy_solid, body.material.density,
                                 det_Fe.empty() ? std::span<const double>{} : std::span<const double>(copy_det_Fe),
                                 body.material.min_mass_fraction);
  // The copies of one node share its mass more evenly: each gets at least
  // an equal share, the group rescaled to its sum (so total mass and centre
  // of mass stay exact: the copies sit at one place). A copy outside its
  // part's material otherwise weighs as little as the mass floor, and the
  // contact stages' impulses on such light nodes crossed the armadillo's
  // surface and blew the bunny press up (docs/lattice.md, "Material parts").
  {
    std::vector<Index> first(at(lm.mesh.num_nodes()) + 1, 0);
    for (const Index n : separated.node) ++first[at(n) + 1];
    for (std::size_t n = 0; n + 1 < first.size(); ++n) first[n + 1] += first[n];
    // Copies are numbered by node: node n's are first[n] .. first[n + 1] − 1.
    for (std::size_t n = 0; n + 1 < first.size(); ++n) {
      const Index begin = first[n], end = first[n + 1];
      if (end - begin < 2) continue;
      double sum = 0.0, raised = 0.0;
      for (Index c = begin; c < end; ++c) sum += out.masses[c];
      const double share = sum / static_cast<double>(end - begin);
      for (Index c = begin; c < end; ++c) raised += std::max(out.masses[c], share);
      for (Index c = begin; c < end; ++c) out.masses[c] = std::max(out.masses[c], share) * (sum / raised);
    }
  }
  out.rest_material_volume = body.rest_material_volume;
  out.incidence = NodeIncidence::build(out.tets, nn);
  out.surface_triangles = body.surface_triangles;
  // The surface onto the copies of its parts (from the plain lattice mesh's
  // embedding, which the body carries in).
  const Embedding& plain = body.embedding;
  const std::vector<Index> copy_of_vertex = vertex_copies(lm, separated, parts, surface, plain.parent);
  out.embedding.parent.resize(plain.parent.size());
  out.embedding.bary = plain.bary;
  for (Index v = 0; v < surface.num_vertices(); ++v) {
    const Index c = copy_of_vertex[at(v)];
    if (c < 0) throw Error(fmt::format("re-mesh: surface vertex {} lies in no copy of an element", v));
    out.embedding.parent[at(v)] = c;
    if (separated.element[at(c)] != plain.parent[at(v)])
      out.embedding.bary.row(v) =
          lm.lattice.barycentric(copies.tet_keys[at(c)], surface.vertices.row(v).transpose()).transpose();
  }
  body = std::move(out);
  return parts.split_elements();
}

}  // namespace

MeshedBody mesh_body(const TriangleMesh& surface, const Material& material, double h, bool separate,
                     SeparationReport* report) {
  MeshedBody out{Body{}, build_lattice_mesh(surface, h)};
  out.body = body_on_lattice(out.lattice_mesh, material);
  const SurfacePieces pieces = slice_surface(out.lattice_mesh, surface);
  const ElementSolid solid = element_solid(out.lattice_mesh, pieces);
  out.body.rest_material_volume = solid.volume.sum();
  out.body.solid_fractions = solid_fractions(solid, out.body.rest_volumes);
  out.body.masses = exact_node_masses(out.lattice_mesh, solid, material.density, {}, material.min_mass_fraction);
  out.body.surface_triangles = surface.triangles;
  out.body.embedding = embed(out.lattice_mesh, surface.vertices);
  if (separate) separate_parts(out.lattice_mesh, surface, pieces, solid, {}, out.body, report);
  return out;
}

namespace {

/// The old body's velocities (interpolated in its deformed elements), its
/// elastic state (Fe = F Fp⁻¹ averaged as left stretches, scaled so that the
/// material's stress-free volume is kept) and the exact masses of that
/// state, on the new mesh `body` around `surface`. Returns where each new
/// node was found in the old mesh.
NodeSources transfer_state(const Body& old, const TriangleMesh& surface, const LatticeMesh& lm, Body& body,
                           RemeshReport* report, RemeshTimes& times, StageTimer& timer, SurfacePieces& pieces,
                           ElementSolid& solid, std::vector<double>& det_Fe) {
  const NodeSources sources = locate_in_old_mesh(old.tets, old.positions, lm);
  body.velocities = interpolate(sources, old.tets, old.velocities);
  std::vector<Eigen::Matrix3d> old_Fe(at(old.num_elements()));
  tbb::parallel_for(tbb::blocked_range<Index>(0, old.num_elements(), kParallelGrain),
                    [&](const tbb::blocked_range<Index>& r) {
                      for (Index e = r.begin(); e != r.end(); ++e)
                        old_Fe[at(e)] = deformation_gradient(old, old.positions, e) * old.Fp[at(e)].inverse();
                    });
  const ElementOverlaps overlaps = element_overlaps(old.tets, old.positions, lm);
  const ElasticState state =
      transfer_elastic_state(overlaps, sources, old_Fe, old.alpha, lm, kPlasticMinSingularValue);
  times.transfer = timer.lap();
  // The material's stress-free volume Σ V_solid / det Fe is invariant (plastic
  // flow is isochoric); the averaged state misses it by a discretisation
  // error, which would act as a pressure and, re-mesh after re-mesh, drive
  // the body to the wrong volume. One factor on every Fe restores it:
  // Fe ← r^(−1/3) Fe, r = V_rest / Σ V_solid / det Fe.
  pieces = slice_surface(lm, surface);
  solid = element_solid(lm, pieces);
  double rest_volume = 0.0;
  for (Index e = 0; e < body.num_elements(); ++e) rest_volume += solid.volume[e] / state.Fe[at(e)].determinant();
  const double r = old.rest_material_volume > 0.0 && rest_volume > 0.0 ? old.rest_material_volume / rest_volume : 1.0;
  const double fe_scale = std::cbrt(1.0 / r);
  body.rest_material_volume = old.rest_material_volume > 0.0 ? old.rest_material_volume : rest_volume;
  if (report) report->rest_volume_error = std::abs(r - 1.0);
  det_Fe.assign(at(body.num_elements()), 1.0);
  for (Index e = 0; e < body.num_elements(); ++e) {
    // F = I on the new mesh, so Fe = Fp⁻¹: Fp = Fe⁻¹ (det Fp = 1 / det Fe).
    const Eigen::Matrix3d Fe = fe_scale * state.Fe[at(e)];
    body.Fp[at(e)] = Fe.inverse();
    det_Fe[at(e)] = Fe.determinant();
  }
  body.alpha = state.alpha;
  body.solid_fractions = solid_fractions(solid, body.rest_volumes);
  // Exact masses of the transferred state, clamped.
  body.masses = exact_node_masses(lm, solid, old.material.density, det_Fe, old.material.min_mass_fraction);
  times.masses = timer.lap();
  return sources;
}

/// Conservation: m_i ← m_i (a + g·(x_i − c)) restores total mass and centre
/// of mass (a = M_old / M_new; g solves Σ m (x − c)(x − c)ᵀ g = M_old (c_old − c_new));
/// a uniform Δv restores linear momentum. The report gets the errors before.
void restore_totals(const Body& old, const TriangleMesh& surface, const NodeSources& sources, Body& body,
                    RemeshReport* report) {
  const Totals before = totals(old.masses, old.positions, old.velocities);
  const Totals now = totals(body.masses, body.positions, body.velocities);
  const double size = bounding_box(surface.vertices).diagonal().norm();
  const double speed = old.velocities.rowwise().norm().maxCoeff();
  if (report) {
    report->old_elements = old.num_elements();
    report->new_elements = body.num_elements();
    report->new_nodes = body.num_nodes();
    report->extrapolated_nodes = sources.extrapolated;
    report->mass_error = std::abs(now.mass - before.mass) / before.mass;
    report->centre_error = (now.centre - before.centre).norm() / size;
    report->momentum_error = speed > 0.0 ? (now.momentum - before.momentum).norm() / (before.mass * speed) : 0.0;
  }
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d d = body.positions.row(n).transpose() - now.centre;
    second += body.masses[n] * d * d.transpose();
  }
  const double a = before.mass / now.mass;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(second);
  const Eigen::Vector3d g = ldlt.info() == Eigen::Success && ldlt.isPositive()
                                ? Eigen::Vector3d(ldlt.solve(before.mass * (before.centre - now.centre)))
                                : Eigen::Vector3d::Zero();
  bool plausible = std::isfinite(a) && g.allFinite();
  Eigen::VectorXd scale(body.num_nodes());
  for (Index n = 0; n < body.num_nodes(); ++n) {
    scale[n] = a + g.dot(body.positions.row(n).transpose() - now.centre);
    plausible = plausible && scale[n] > 0.5 && scale[n] < 2.0;
  }
  if (!plausible && std::isfinite(a) && a > 0.0) {
    // The affine correction would distort the masses (a flat body has almost
    // no second moment across itself): scale them uniformly instead, which
    // still restores total mass and momentum; the centre of mass keeps the
    // transfer's error (report->centre_error).
    log().debug("re-mesh: affine mass correction implausible; scaling masses uniformly by {}", a);
    scale.setConstant(a);
    plausible = true;
  }
  if (plausible) {
    body.masses = body.masses.cwiseProduct(scale);
    const Totals corrected = totals(body.masses, body.positions, body.velocities);
    const Eigen::RowVector3d dv = ((before.momentum - corrected.momentum) / corrected.mass).transpose();
    body.velocities.rowwise() += dv;
  } else {
    log().warn("re-mesh: the transferred masses cannot be corrected (mass ratio {}); kept as they are", a);
  }
}

}  // namespace

MeshedBody remesh(const Body& old, const TriangleMesh& current, double h, RemeshReport* report,
                  const UpkeepSettings* upkeep, const TriangleMesh* others, bool separate) {
  StageTimer timer;
  RemeshTimes times;
  TriangleMesh upkept;
  if (upkeep) {
    upkept = current;
    const UpkeepReport done = upkeep_surface(upkept, h, *upkeep, others);
    if (report) report->upkeep = done;
    // A surface the upkeep changed is numbered in space order again (its
    // splits appended vertices and triangles at the end); one it left
    // alone keeps its numbering.
    if (done.splits + done.collapses + done.flips > 0) order_surface(upkept, h);
  }
  times.upkeep = timer.lap();
  const TriangleMesh& surface = upkeep ? upkept : current;
  MeshedBody out{Body{}, build_lattice_mesh(surface, h)};
  const LatticeMesh& lm = out.lattice_mesh;
  Body& body = out.body;
  body = body_on_lattice(lm, old.material);
  times.lattice = timer.lap();
  SurfacePieces pieces;
  ElementSolid solid;
  std::vector<double> det_Fe;
  const NodeSources sources = transfer_state(old, surface, lm, body, report, times, timer, pieces, solid, det_Fe);
  body.surface_triangles = surface.triangles;
  body.embedding = embed(lm, surface.vertices);
  if (separate) {
    separate_parts(lm, surface, pieces, solid, det_Fe, body, report ? &report->separation : nullptr);
    times.separation = timer.lap();
  }
  restore_totals(old, surface, sources, body, report);
  times.conservation = timer.lap();
  if (report) report->times = times;
  return out;
}

}  // namespace goo
