#include "solvers/embedded_tension.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>

#include "core/parallel.h"

namespace goo {
namespace {

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

}  // namespace

SurfaceNodes SurfaceNodes::of(const Body& body) {
  SurfaceNodes s;
  const Triangles& tri = body.surface_triangles;
  const Embedding& em = body.embedding;
  s.nodes.resize(tri.rows(), 12);
  s.weights.resize(tri.rows(), 12);
  for (Index t = 0; t < tri.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Index v = tri(t, k);
      for (int j = 0; j < 4; ++j) {
        s.nodes(t, 4 * k + j) = body.tets(em.parent[at(v)], j);
        s.weights(t, 4 * k + j) = em.bary(v, j);
      }
    }
  return s;
}

Matrix9d triangle_area_hessian(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double length = n.norm();
  Matrix9d H = Matrix9d::Zero();
  if (!(length > 0.0)) return H;
  const Eigen::Vector3d u = n / length;
  Eigen::Matrix<double, 3, 9> Jn;
  Jn << cross_matrix(c - b), cross_matrix(a - c), cross_matrix(b - a);
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - u * u.transpose();
  H = Jn.transpose() * P * Jn / length;
  // n̂ · ∂²n: with e1 = b − a, e2 = c − a the bilinear form is
  // n̂ · (δe1 × δe2' + δe1' × δe2) = δe2ᵀ N δe1' − δe1ᵀ N δe2', N = [n̂]ₓ.
  const Eigen::Matrix3d N = cross_matrix(u);
  Eigen::Matrix<double, 6, 9> D = Eigen::Matrix<double, 6, 9>::Zero();
  for (int i = 0; i < 3; ++i) {
    D(i, i) = -1.0, D(i, 3 + i) = 1.0;          // e1 = b − a
    D(3 + i, i) = -1.0, D(3 + i, 6 + i) = 1.0;  // e2 = c − a
  }
  Eigen::Matrix<double, 6, 6> K = Eigen::Matrix<double, 6, 6>::Zero();
  K.block<3, 3>(0, 3) = -N;
  K.block<3, 3>(3, 0) = N;
  H += D.transpose() * K * D;
  return 0.5 * H;
}

bool EmbeddedTension::active(const Body& body) {
  return body.material.surface_tension > 0.0 && body.embedding.num_vertices() > 0 && body.surface_triangles.rows() > 0;
}

void EmbeddedTension::ensure_topology(const Body& body) {
  if (!(topology_of_.rows() == body.surface_triangles.rows() && topology_of_ == body.surface_triangles)) {
    topology_ = SurfaceTopology::build(body.surface_triangles, body.embedding.num_vertices());
    topology_of_ = body.surface_triangles;
  }
  if (!(neighbours_of_.rows() == body.tets.rows() && neighbours_of_ == body.tets)) {
    neighbours_ = face_neighbours(body.tets);
    neighbours_of_ = body.tets;
  }
}

void EmbeddedTension::add_forces(const Body& body, const Points& x, SurfaceTensionForm form, Points& forces) {
  ensure_topology(body);
  const TriangleMesh surface{body.embedding.surface_positions(body.tets, x), body.surface_triangles};
  Points f;
  surface_tension_forces(surface, topology_, body.material.surface_tension, form, f);
  const Embedding& em = body.embedding;
  for (Index v = 0; v < em.num_vertices(); ++v)
    for (int k = 0; k < 4; ++k) forces.row(body.tets(em.parent[at(v)], k)) += em.bary(v, k) * f.row(v);
}

double EmbeddedTension::energy(const Body& body, const Points& x) {
  const Points xs = body.embedding.surface_positions(body.tets, x);
  const Triangles& tri = body.surface_triangles;
  double twice_area = 0.0;  // in triangle order: deterministic
  for (Index t = 0; t < tri.rows(); ++t) {
    const Eigen::Vector3d a = xs.row(tri(t, 0));
    twice_area += (xs.row(tri(t, 1)).transpose() - a).cross(xs.row(tri(t, 2)).transpose() - a).norm();
  }
  return 0.5 * body.material.surface_tension * twice_area;
}

void EmbeddedTension::triangle_hessians(const Body& body, const Points& x, bool project, std::vector<Matrix9d>& out) {
  const Points xs = body.embedding.surface_positions(body.tets, x);
  const Triangles& tri = body.surface_triangles;
  const double sigma = body.material.surface_tension;
  const auto nt = static_cast<Index>(tri.rows());
  out.resize(at(nt));
  tbb::parallel_for(tbb::blocked_range<Index>(0, nt, kParallelGrain), [&](const tbb::blocked_range<Index>& r) {
    for (Index t = r.begin(); t != r.end(); ++t) {
      Matrix9d H = sigma * triangle_area_hessian(xs.row(tri(t, 0)).transpose(), xs.row(tri(t, 1)).transpose(),
                                                 xs.row(tri(t, 2)).transpose());
      if (project) {
        const Eigen::SelfAdjointEigenSolver<Matrix9d> eig(H);
        H = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
      }
      out[at(t)] = H;
    }
  });
}

void EmbeddedTension::smooth(Body& body, double lambda) {
  if (!(lambda > 0.0)) return;
  ensure_topology(body);
  Points xs = body.embedding.surface_positions(body.tets, body.positions);
  smooth_surface(xs, topology_, lambda);
  reembed(body.embedding, body.tets, neighbours_, body.positions, xs);
}

}  // namespace goo
