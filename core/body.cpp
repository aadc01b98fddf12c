#include "core/body.h"

#include <Eigen/SVD>
#include <algorithm>
#include <array>

#include "core/log.h"
#include "core/parallel.h"
#include "core/surface_geometry.h"

namespace goo {

NodeIncidence NodeIncidence::build(const Tets& tets, Index num_nodes) {
  NodeIncidence inc;
  inc.offsets.assign(static_cast<std::size_t>(num_nodes) + 1, 0);
  for (Index e = 0; e < tets.rows(); ++e)
    for (int k = 0; k < 4; ++k) ++inc.offsets[static_cast<std::size_t>(tets(e, k)) + 1];
  for (std::size_t n = 0; n < static_cast<std::size_t>(num_nodes); ++n) inc.offsets[n + 1] += inc.offsets[n];
  inc.corners.resize(static_cast<std::size_t>(4 * tets.rows()));
  inc.slots.resize(inc.corners.size());
  std::vector<Index> fill(inc.offsets.begin(), inc.offsets.end() - 1);
  // Elements in increasing order, so each node's corners are sorted.
  for (Index e = 0; e < tets.rows(); ++e)
    for (int k = 0; k < 4; ++k) {
      const Index slot = fill[static_cast<std::size_t>(tets(e, k))]++;
      inc.corners[static_cast<std::size_t>(slot)] = 4 * e + k;
      inc.slots[static_cast<std::size_t>(4 * e + k)] = slot;
    }
  return inc;
}

Body make_body(TetMesh mesh, const Material& material, std::string_view source) {
  validate(material);
  if (const Index flipped = check_and_orient(mesh, source); flipped > 0) {
    log().warn("{}: reoriented {} negatively oriented tetrahedra", source, flipped);
  }
  Body body;
  body.material = material;
  body.rest_positions = mesh.positions;
  body.positions = mesh.positions;
  body.velocities = Points::Zero(mesh.num_nodes(), 3);
  body.tets = std::move(mesh.tets);
  const Index ne = body.num_elements();
  body.Dm_inv.resize(static_cast<std::size_t>(ne));
  body.rest_volumes.resize(ne);
  body.Fp.assign(static_cast<std::size_t>(ne), Eigen::Matrix3d::Identity());
  body.alpha = Eigen::VectorXd::Zero(ne);
  body.rest_condition.resize(ne);
  for (Index e = 0; e < ne; ++e) {
    const Eigen::Vector3d x0 = body.positions.row(body.tets(e, 0));
    Eigen::Matrix3d Dm;
    for (int k = 0; k < 3; ++k) Dm.col(k) = body.positions.row(body.tets(e, k + 1)).transpose() - x0;
    body.Dm_inv[static_cast<std::size_t>(e)] = Dm.inverse();
    body.rest_volumes[e] = Dm.determinant() / 6.0;
    const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(Dm).singularValues();
    body.rest_condition[e] = s[0] / s[2];
  }
  body.rest_material_volume = body.rest_volumes.sum();  // the material fills its elements
  body.incidence = NodeIncidence::build(body.tets, body.num_nodes());
  lump_masses(body);
  return body;
}

void lump_masses(Body& body) {
  const double rho = body.material.density;
  body.masses = Eigen::VectorXd::Zero(body.num_nodes());
  // Gather in incidence order: deterministic and free of write conflicts.
  for (Index n = 0; n < body.num_nodes(); ++n) {
    double m = 0.0;
    for (Index c = body.incidence.offsets[static_cast<std::size_t>(n)];
         c < body.incidence.offsets[static_cast<std::size_t>(n) + 1]; ++c) {
      const Index e = body.incidence.corners[static_cast<std::size_t>(c)] / 4;
      m += 0.25 * rho * body.rest_volumes[e] * body.Fp[static_cast<std::size_t>(e)].determinant();
    }
    body.masses[n] = m;
  }
}

Eigen::Vector3d linear_momentum(const Body& body) {
  std::array<CompensatedSum, 3> p;
  for (Index n = 0; n < body.num_nodes(); ++n)
    for (int k = 0; k < 3; ++k) p[static_cast<std::size_t>(k)].add(body.masses[n] * body.velocities(n, k));
  return {p[0].value(), p[1].value(), p[2].value()};
}

Eigen::Vector3d angular_momentum(const Body& body) {
  std::array<CompensatedSum, 3> L;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    const Eigen::Vector3d x = body.positions.row(n), v = body.velocities.row(n);
    const Eigen::Vector3d l = body.masses[n] * x.cross(v);
    for (int k = 0; k < 3; ++k) L[static_cast<std::size_t>(k)].add(l[k]);
  }
  return {L[0].value(), L[1].value(), L[2].value()};
}

double kinetic_energy(const Body& body) {
  CompensatedSum e;
  for (Index n = 0; n < body.num_nodes(); ++n) e.add(0.5 * body.masses[n] * body.velocities.row(n).squaredNorm());
  return e.value();
}

void embed_boundary(Body& body) {
  // Faces opposite corner k of a positively oriented tet, outward.
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  const Tets neighbours = face_neighbours(body.tets);
  struct Face {
    std::array<Index, 3> key;  // its nodes, sorted: the faces' order
    Index e;
    int k;
  };
  std::vector<Face> faces;
  for (Index e = 0; e < body.num_elements(); ++e)
    for (int k = 0; k < 4; ++k)
      if (neighbours(e, k) < 0) {
        std::array<Index, 3> key{body.tets(e, kFace[k][0]), body.tets(e, kFace[k][1]), body.tets(e, kFace[k][2])};
        std::sort(key.begin(), key.end());
        faces.push_back({key, e, k});
      }
  std::sort(faces.begin(), faces.end(), [](const Face& a, const Face& b) { return a.key < b.key; });
  std::vector<Index> vertex_of(at(body.num_nodes()), -1);
  std::vector<Index> nodes;
  body.surface_triangles.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t t = 0; t < faces.size(); ++t)
    for (int c = 0; c < 3; ++c) {
      const Index n = body.tets(faces[t].e, kFace[faces[t].k][c]);
      if (vertex_of[at(n)] < 0) {
        vertex_of[at(n)] = static_cast<Index>(nodes.size());
        nodes.push_back(n);
      }
      body.surface_triangles(static_cast<Eigen::Index>(t), c) = vertex_of[at(n)];
    }
  Embedding& em = body.embedding;
  em.parent.resize(nodes.size());
  em.bary = decltype(em.bary)::Zero(static_cast<Eigen::Index>(nodes.size()), 4);
  for (std::size_t v = 0; v < nodes.size(); ++v) {
    const Index corner = body.incidence.corners[at(body.incidence.offsets[at(nodes[v])])];
    em.parent[v] = corner / 4;
    em.bary(static_cast<Eigen::Index>(v), corner % 4) = 1.0;
  }
}

}  // namespace goo
