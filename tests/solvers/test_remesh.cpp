#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <iterator>
#include <limits>
#include <random>

#include "core/elastic_forces.h"
#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "meshing/convex_clip.h"
#include "meshing/lattice_mesh.h"
#include "meshing/surface_upkeep.h"
#include "meshing/transfer.h"
#include "solvers/newmark.h"
#include "solvers/remesh.h"
#include "tests/common/test_common.h"

namespace goo {
namespace {

Material jelly() {
  Material m;
  m.density = 1100.0;
  m.youngs_modulus = 2e4;
  m.poisson_ratio = 0.35;
  m.model = ElasticModel::neo_hookean;
  return m;
}

/// Cauchy stress σ = P Feᵀ / det Fe: what an isotropic material's state is.
Eigen::Matrix3d cauchy(const Material& material, const Eigen::Matrix3d& Fe) {
  const IsotropicEnergy energy(material);
  return first_piola(energy, svd3(Fe)) * Fe.transpose() / Fe.determinant();
}

/// The stretch of the test bodies: rotated, unequal along three axes.
Eigen::Matrix3d stretch_and_rotation() {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  return R * Eigen::Vector3d(1.2, 0.9, 1.05).asDiagonal();
}

/// A sphere meshed at spacing h, then moved by x ↦ A x + t (a uniform
/// elastic state Fe = A) with velocities v = B x + c.
MeshedBody moved_sphere(double h, const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  MeshedBody mb = mesh_body(make_sphere(0.5, 20), jelly(), h);
  const Eigen::RowVector3d t(0.3, -0.2, 0.1), c(0.5, 1.0, -2.0);
  mb.body.positions = (mb.body.rest_positions * A.transpose()).rowwise() + t;
  mb.body.velocities = (mb.body.positions * B.transpose()).rowwise() + c;
  return mb;
}

TEST(Remesh, ReproducesAnAffineVelocityFieldIncludingExtrapolatedNodes) {
  const Eigen::Matrix3d B = (Eigen::Matrix3d() << 0.1, -0.4, 0.2, 0.4, 0.05, -0.3, -0.2, 0.3, -0.1).finished();
  const MeshedBody old = moved_sphere(0.1, stretch_and_rotation(), B);
  RemeshReport report;
  // A coarser new mesh reaches beyond the old one: extrapolated nodes.
  const MeshedBody mb = remesh(old.body, old.surface(), 0.17, &report);
  EXPECT_GT(report.extrapolated_nodes, 0);
  const Points expected = (mb.body.positions * B.transpose()).rowwise() + Eigen::RowVector3d(0.5, 1.0, -2.0);
  EXPECT_TRUE(test::matrices_near(mb.body.velocities, expected, 1e-12 * expected.cwiseAbs().maxCoeff()));
}

/// Distance from p to the tetrahedron x (0 inside), by its four faces.
double tet_distance(const std::array<Eigen::Vector3d, 4>& x, const Eigen::Vector3d& p) {
  Eigen::Matrix3d Ds;
  for (int k = 0; k < 3; ++k) Ds.col(k) = x[static_cast<std::size_t>(k + 1)] - x[0];
  const Eigen::Vector3d b = Ds.inverse() * (p - x[0]);
  if (b.minCoeff() >= 0.0 && b.sum() <= 1.0) return 0.0;
  double d = std::numeric_limits<double>::infinity();
  for (const auto& f : kTetFaces)
    d = std::min(d, point_triangle_distance(p, x[static_cast<std::size_t>(f[0])], x[static_cast<std::size_t>(f[1])],
                                            x[static_cast<std::size_t>(f[2])]));
  return d;
}

TEST(Remesh, EachExtrapolatedNodeTakesANearestUsableOldElement) {
  // A sphere jittered by a fifth of its spacing, one surface node pushed
  // in far enough to invert or flatten its elements (which no node may be
  // extrapolated from), onto a coarser lattice that reaches beyond it.
  const double h = 0.1;
  MeshedBody old = moved_sphere(h, stretch_and_rotation(), Eigen::Matrix3d::Zero());
  std::mt19937 rng(20261208);
  std::uniform_real_distribution<double> jitter(-0.2 * h, 0.2 * h);
  for (Index n = 0; n < old.body.num_nodes(); ++n)
    for (int c = 0; c < 3; ++c) old.body.positions(n, c) += jitter(rng);
  Index top = 0;
  for (Index n = 1; n < old.body.num_nodes(); ++n)
    if (old.body.positions(n, 2) > old.body.positions(top, 2)) top = n;
  old.body.positions(top, 2) -= 3.0 * h;
  const Tets& tets = old.body.tets;
  const Points& x = old.body.positions;
  auto corners = [&](Index e) {
    std::array<Eigen::Vector3d, 4> out;
    for (int k = 0; k < 4; ++k) out[static_cast<std::size_t>(k)] = x.row(tets(e, k)).transpose();
    return out;
  };
  // Usable as the transfer has it: positively oriented, not flat against its box.
  std::vector<Index> usable;
  for (Index e = 0; e < old.body.num_elements(); ++e) {
    const auto c = corners(e);
    const Eigen::Vector3d lo = c[0].cwiseMin(c[1]).cwiseMin(c[2]).cwiseMin(c[3]);
    const Eigen::Vector3d hi = c[0].cwiseMax(c[1]).cwiseMax(c[2]).cwiseMax(c[3]);
    const double scale = (hi - lo).maxCoeff();
    if ((c[1] - c[0]).dot((c[2] - c[0]).cross(c[3] - c[0])) > 1e-12 * scale * scale * scale) usable.push_back(e);
  }
  ASSERT_LT(usable.size(), static_cast<std::size_t>(old.body.num_elements()));  // some inverted or flat
  const LatticeMesh lm = build_lattice_mesh(old.surface(), 0.17);
  const NodeSources sources = locate_in_old_mesh(tets, x, lm);
  ASSERT_GT(sources.extrapolated, 20);
  Index checked = 0;
  for (Index n = 0; n < lm.mesh.num_nodes(); ++n) {
    const Eigen::Vector3d p = lm.mesh.positions.row(n).transpose();
    const Index chosen = sources.element[static_cast<std::size_t>(n)];
    ASSERT_TRUE(std::binary_search(usable.begin(), usable.end(), chosen)) << "node " << n;
    if (sources.bary.row(n).minCoeff() >= -1e-9) continue;  // interpolated
    double nearest = std::numeric_limits<double>::infinity();
    for (const Index e : usable) nearest = std::min(nearest, tet_distance(corners(e), p));
    // Ties and round-off aside, no usable element is nearer than the one taken.
    EXPECT_LE(tet_distance(corners(chosen), p), nearest + 1e-12) << "node " << n;
    ++checked;
  }
  EXPECT_GE(checked, sources.extrapolated);

  // An element turned inside out beside the new nodes bounds no distance:
  // the one usable element, a lattice spacing and more away, is the source
  // of every node.
  Tets two(2, 4);
  two << 0, 1, 2, 3, 4, 6, 5, 7;  // the second inverted
  Points y(8, 3);
  y << 0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1,  //
      0.4, 0, 0, 0.5, 0, 0, 0.4, 0.1, 0, 0.4, 0, 0.1;
  TriangleMesh ball = make_sphere(0.15, 12);
  ball.vertices.rowwise() += Eigen::RowVector3d(0.45, 0.05, 0.05);
  const LatticeMesh beside = build_lattice_mesh(ball, 0.1);
  const NodeSources from_one = locate_in_old_mesh(two, y, beside);
  EXPECT_EQ(from_one.extrapolated, beside.mesh.num_nodes());
  for (const Index e : from_one.element) ASSERT_EQ(e, 0);
}

TEST(Remesh, KeepsAUniformlyStretchedAndRotatedBodysStress) {
  const Eigen::Matrix3d A = stretch_and_rotation();
  const MeshedBody old = moved_sphere(0.1, A, Eigen::Matrix3d::Zero());
  const MeshedBody mb = remesh(old.body, old.surface(), 0.13);
  const Eigen::Matrix3d expected = cauchy(jelly(), A);
  ASSERT_GT(expected.norm(), 1e3);
  // Rest shape = current shape (F = I); the state lives in Fp = Fe⁻¹.
  EXPECT_TRUE(mb.body.positions == mb.body.rest_positions);
  for (Index e = 0; e < mb.body.num_elements(); ++e) {
    const Eigen::Matrix3d Fe = deformation_gradient(mb.body, mb.body.positions, e) * mb.body.Fp[static_cast<std::size_t>(e)].inverse();
    ASSERT_LT((cauchy(jelly(), Fe) - expected).norm(), 1e-10 * expected.norm()) << "element " << e;
  }
  // And the elastic forces on the new nodes are those of that stress:
  // interior nodes feel none, the net force is zero.
  ElasticForces forces;
  Body body = mb.body;
  Points f;
  forces.evaluate(body, body.positions, 0.0, f);
  EXPECT_LT(f.colwise().sum().norm(), 1e-9 * expected.norm() * 0.13 * 0.13);
}

// Elements with the same stretch but different rotations (Fe_e = s R_e, a
// stress-free reference turned arbitrarily): their left stretches agree, so
// the new elements carry exactly that stress. Averaging raw Fe would blend
// the rotations and shrink the state.
TEST(Remesh, AveragesLeftStretchesNotRotations) {
  MeshedBody old = mesh_body(make_sphere(0.5, 20), jelly(), 0.1);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double s = 1.1;
  for (auto& Fp : old.body.Fp) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(2.0 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).toRotationMatrix();
    Fp = (s * R).inverse();
  }
  // The stress-free volume this state implies (det Fp = s⁻³).
  old.body.rest_material_volume /= s * s * s;
  const MeshedBody mb = remesh(old.body, old.surface(), 0.13);
  const Eigen::Matrix3d expected = cauchy(jelly(), s * Eigen::Matrix3d::Identity());
  for (Index e = 0; e < mb.body.num_elements(); ++e) {
    const Eigen::Matrix3d Fe = mb.body.Fp[static_cast<std::size_t>(e)].inverse();
    ASSERT_LT((cauchy(jelly(), Fe) - expected).norm(), 1e-10 * expected.norm()) << "element " << e;
  }
}

TEST(Remesh, DoesNotMoveTheSurfaceAndConservesMassCentreAndMomentum) {
  const Eigen::Matrix3d B = (Eigen::Matrix3d() << 0.0, -0.4, 0.2, 0.4, 0.0, -0.3, -0.2, 0.3, 0.0).finished();
  const MeshedBody old = moved_sphere(0.1, stretch_and_rotation(), B);
  const TriangleMesh surface = old.surface();
  RemeshReport report;
  const MeshedBody mb = remesh(old.body, surface, 0.12, &report);
  const double size = bounding_box(surface.vertices).diagonal().norm();
  EXPECT_TRUE(test::matrices_near(mb.surface().vertices, surface.vertices, 1e-14 * size));
  // A uniform state: the exact masses of the new mesh already carry the old
  // totals (the correction is round-off).
  EXPECT_LT(report.mass_error, 1e-12);
  EXPECT_LT(report.centre_error, 1e-12);
  EXPECT_LT(report.momentum_error, 1e-12);
  const double M = old.body.masses.sum();
  EXPECT_NEAR(mb.body.masses.sum(), M, 1e-13 * M);
  const Eigen::Vector3d c_old = old.body.positions.transpose() * old.body.masses / M;
  const Eigen::Vector3d c_new = mb.body.positions.transpose() * mb.body.masses / M;
  EXPECT_LT((c_new - c_old).norm(), 1e-13 * size);
  EXPECT_LT((linear_momentum(mb.body) - linear_momentum(old.body)).norm(), 1e-13 * linear_momentum(old.body).norm() + 1e-13 * M);
}

/// Two boxes one body, a third of the spacing apart across x, tilted: the
/// elements across the gap hold material of both.
TriangleMesh boxes_across_a_gap(double h) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
  TriangleMesh a = make_box({0.5, 0.4, 0.3}, 3), b = a;
  a.vertices = (a.vertices * R.transpose()).rowwise() + Eigen::RowVector3d(0.013, -0.021, 0.007);
  b.vertices = (b.vertices * R.transpose()).rowwise() +
               (R * Eigen::Vector3d(0.5 + h / 3.0, 0.0, 0.0) + Eigen::Vector3d(0.013, -0.021, 0.007)).transpose();
  return test::joined(a, b);
}

/// The nodes of the elements holding the surface vertices [first, last).
std::vector<Index> nodes_holding(const Body& body, Index first, Index last) {
  std::vector<Index> out;
  for (Index v = first; v < last; ++v)
    for (int k = 0; k < 4; ++k) out.push_back(body.tets(body.embedding.parent[at(v)], k));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Index shared(const std::vector<Index>& a, const std::vector<Index>& b) {
  std::vector<Index> both;
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(both));
  return static_cast<Index>(both.size());
}

// With the material's parts separated, the two boxes share no node (the
// plain lattice mesh joins them through the elements across the gap); the
// copies carry exactly the solid's mass and reproduce the surface; and a
// re-mesh of the moved body keeps them apart and conserves its totals.
TEST(Remesh, SeparatedPartsShareNoNodeAndConserveMass) {
  const double h = 0.1;
  const TriangleMesh surface = boxes_across_a_gap(h);
  const Index half = surface.num_vertices() / 2;
  Material material = jelly();
  material.min_mass_fraction = 0.0;  // the exact masses alone
  const MeshedBody plain = mesh_body(surface, material, h);
  SeparationReport report;
  const MeshedBody separated = mesh_body(surface, material, h, true, &report);
  EXPECT_GT(shared(nodes_holding(plain.body, 0, half), nodes_holding(plain.body, half, 2 * half)), 0);
  EXPECT_EQ(shared(nodes_holding(separated.body, 0, half), nodes_holding(separated.body, half, 2 * half)), 0);
  EXPECT_GT(report.split_elements, 10) << "degenerate " << report.degenerate_elements;
  EXPECT_EQ(report.node_copies, separated.body.num_nodes() - plain.body.num_nodes());
  EXPECT_GT(report.node_copies, 0);
  const double size = bounding_box(surface.vertices).diagonal().norm();
  EXPECT_TRUE(test::matrices_near(separated.surface().vertices, surface.vertices, 1e-14 * size));
  const double M = material.density * surface_integrals(surface).volume;
  EXPECT_NEAR(separated.body.masses.sum(), M, 1e-10 * M);
  EXPECT_NEAR(separated.body.rest_material_volume, plain.body.rest_material_volume,
              1e-12 * plain.body.rest_material_volume);
  // Moved by a uniform stretch and rotation, with an affine velocity.
  MeshedBody old = separated;
  const Eigen::Matrix3d A = stretch_and_rotation();
  const Eigen::Matrix3d B = (Eigen::Matrix3d() << 0.0, -0.4, 0.2, 0.4, 0.0, -0.3, -0.2, 0.3, 0.0).finished();
  old.body.positions = old.body.rest_positions * A.transpose();
  old.body.velocities = old.body.positions * B.transpose();
  const TriangleMesh moved = old.surface();
  RemeshReport remeshed;
  const MeshedBody mb = remesh(old.body, moved, h, &remeshed, nullptr, nullptr, true);
  EXPECT_GT(remeshed.separation.split_elements, 10);
  EXPECT_EQ(shared(nodes_holding(mb.body, 0, half), nodes_holding(mb.body, half, 2 * half)), 0);
  EXPECT_TRUE(test::matrices_near(mb.surface().vertices, moved.vertices, 1e-14 * size));
  const double M_old = old.body.masses.sum();
  EXPECT_NEAR(mb.body.masses.sum(), M_old, 1e-13 * M_old);
  EXPECT_LT((linear_momentum(mb.body) - linear_momentum(old.body)).norm(), 1e-12 * linear_momentum(old.body).norm());
  const Eigen::Vector3d c_old = old.body.positions.transpose() * old.body.masses / M_old;
  const Eigen::Vector3d c_new = mb.body.positions.transpose() * mb.body.masses / M_old;
  EXPECT_LT((c_new - c_old).norm(), 1e-12 * size);
}

// Where nothing is split (one sphere), separating changes nothing: the same
// body, bit for bit.
TEST(Remesh, SeparatingAnUnsplitBodyChangesNothing) {
  const MeshedBody plain = mesh_body(make_sphere(0.5, 20), jelly(), 0.1);
  SeparationReport report;
  const MeshedBody separated = mesh_body(make_sphere(0.5, 20), jelly(), 0.1, true, &report);
  EXPECT_EQ(report.split_elements, 0);
  EXPECT_EQ(report.node_copies, 0);
  EXPECT_EQ(separated.body.tets, plain.body.tets);
  EXPECT_EQ(separated.body.positions, plain.body.positions);
  EXPECT_EQ(separated.body.masses, plain.body.masses);
  EXPECT_EQ(separated.body.embedding.parent, plain.body.embedding.parent);
  EXPECT_EQ(separated.body.embedding.bary, plain.body.embedding.bary);
}

// A non-uniform state: averaging makes the new density differ from the old
// one by a discretisation error; the correction restores the totals exactly.
TEST(Remesh, ConservationCorrectionRestoresTheTotalsOfANonUniformState) {
  MeshedBody old = moved_sphere(0.1, stretch_and_rotation(), Eigen::Matrix3d::Zero());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (Index n = 0; n < old.body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) {
      old.body.positions(n, k) += 0.01 * u(rng);
      old.body.velocities(n, k) = u(rng);
    }
  const TriangleMesh surface = old.surface();
  RemeshReport report;
  const MeshedBody mb = remesh(old.body, surface, 0.1, &report);
  // The averaged state misses the stress-free volume (so the mass) by a real
  // discretisation error, which the rest-volume factor removes; what is left
  // for the affine mass correction is the centre of mass.
  EXPECT_GT(report.rest_volume_error, 1e-9);
  EXPECT_LT(report.rest_volume_error, 0.05);
  EXPECT_LT(report.mass_error, 1e-12);
  EXPECT_GT(report.centre_error, 1e-9);
  const double M = old.body.masses.sum();
  EXPECT_NEAR(mb.body.masses.sum(), M, 1e-13 * M);
  EXPECT_GT(mb.body.masses.minCoeff(), 0.0);
  const Eigen::Vector3d c_old = old.body.positions.transpose() * old.body.masses / M;
  const Eigen::Vector3d c_new = mb.body.positions.transpose() * mb.body.masses / M;
  EXPECT_LT((c_new - c_old).norm(), 1e-13);
  EXPECT_LT((linear_momentum(mb.body) - linear_momentum(old.body)).norm(), 1e-12 * M);
}

// Gravity only, no stress: re-meshing every step changes nothing but the
// mesh. The surface falls as x0 + v0 t + ½ g t² (Newmark is exact for a
// constant acceleration) in both runs.
TEST(Remesh, StressFreeBodyRemeshedEveryStepFallsLikeOneNeverRemeshed) {
  Material soft = jelly();
  soft.youngs_modulus = 50.0;  // a stability limit far above the step
  soft.min_mass_fraction = 0.1;
  const TriangleMesh start = make_torus(0.4, 0.15, 24, 12);
  NewmarkSettings settings;
  settings.max_time_step = 1e-3;
  const Eigen::RowVector3d v0(0.4, -0.1, 1.5);
  MeshedBody plain = mesh_body(start, soft, 0.09), remeshed = plain;
  plain.body.velocities.rowwise() = v0;
  remeshed.body.velocities.rowwise() = v0;
  const Eigen::Vector3d g = standard_gravity();
  NewmarkIntegrator a(settings, {}, g), b(settings, {}, g);
  const int steps = 15;
  for (int i = 0; i < steps; ++i) {
    ASSERT_DOUBLE_EQ(a.step(plain.body, 1e-3).dt, 1e-3);
    ASSERT_DOUBLE_EQ(b.step(remeshed.body, 1e-3).dt, 1e-3);
    remeshed = remesh(remeshed.body, remeshed.surface(), 0.09);
    b.invalidate();
  }
  const double t = steps * 1e-3;
  const Points expected =
      (start.vertices.rowwise() + v0 * t).rowwise() + 0.5 * t * t * g.transpose();
  const double size = 1.2;
  EXPECT_TRUE(test::matrices_near(plain.surface().vertices, expected, 1e-12 * size));
  EXPECT_TRUE(test::matrices_near(remeshed.surface().vertices, expected, 1e-12 * size));
  for (Index n = 0; n < remeshed.body.num_nodes(); ++n)
    ASSERT_LT((remeshed.body.velocities.row(n) - (v0 + t * g.transpose())).norm(), 1e-10);
}

// Surface upkeep at re-mesh time (W&T fig. 8): a body stretched to twice
// its length has long surface edges; they are split before meshing, which
// leaves the surface where it was, and the state is carried as usual.
TEST(Remesh, SplitsLongSurfaceEdgesFirst) {
  const Eigen::Matrix3d A = Eigen::Vector3d(2.0, 1.0, 1.0).asDiagonal();
  const MeshedBody old = moved_sphere(0.1, A, Eigen::Matrix3d::Zero());
  const TriangleMesh surface = old.surface();
  RemeshReport report;
  UpkeepSettings upkeep;
  upkeep.split_length = 0.8;
  upkeep.collapse_length = 0.01;
  const MeshedBody mb = remesh(old.body, surface, 0.1, &report, &upkeep);
  EXPECT_GT(report.upkeep.splits, 0);
  EXPECT_GT(mb.body.surface_triangles.rows(), surface.triangles.rows());
  const SurfaceIntegrals a = surface_integrals(surface), b = surface_integrals(mb.surface());
  EXPECT_NEAR(b.volume, a.volume, 1e-12 * a.volume + report.upkeep.volume_change_bound);
  EXPECT_NEAR(mb.body.masses.sum(), old.body.masses.sum(), 1e-13 * old.body.masses.sum());
  // The upkept surface is embedded numbered in space order (order_surface).
  TriangleMesh upkept = surface;
  upkeep_surface(upkept, 0.1, upkeep);
  TriangleMesh ordered = upkept;
  order_surface(ordered, 0.1);
  EXPECT_NE(ordered.triangles, upkept.triangles);
  EXPECT_EQ(mb.body.surface_triangles, ordered.triangles);
  EXPECT_TRUE(test::matrices_near(mb.surface().vertices, ordered.vertices, 1e-12));
}

TEST(Remesh, SameBitsForAnyThreadCount) {
  const Eigen::Matrix3d B = (Eigen::Matrix3d() << 0.0, -0.4, 0.2, 0.4, 0.0, -0.3, -0.2, 0.3, 0.0).finished();
  MeshedBody old = moved_sphere(0.1, stretch_and_rotation(), B);
  old.body.positions(3, 0) += 0.01;  // not uniform
  const TriangleMesh surface = old.surface();
  auto with_threads = [&](int threads) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return remesh(old.body, surface, 0.11);
  };
  const MeshedBody one = with_threads(1), two = with_threads(2);
  EXPECT_TRUE(one.body.masses == two.body.masses);
  EXPECT_TRUE(one.body.velocities == two.body.velocities);
  EXPECT_TRUE(one.body.Fp == two.body.Fp);
  EXPECT_TRUE(one.body.alpha == two.body.alpha);
}

}  // namespace
}  // namespace goo
