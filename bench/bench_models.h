#pragma once
// What the meshing benchmarks share: the real models, the spacing that
// gives a tet count, and the deformed, moving body a re-mesh meets.
#include <Eigen/Geometry>
#include <cmath>

#include "core/surface_check.h"
#include "core/surface_geometry.h"
#include "solvers/remesh.h"

namespace goo::bench {

/// Spacing giving about `tets` lattice tetrahedra inside the solid (12 per
/// cell volume h³ of solid; the surface layer adds more).
inline double spacing_for(const TriangleMesh& mesh, double tets) {
  return std::cbrt(12.0 * analyze_surface(mesh).volume / tets);
}

/// Deforms a body smoothly (a twist and a shear of a few percent, no
/// longer lattice-aligned) and sets it moving: each node by where it is.
inline void deform(Body& body) {
  Points& x = body.positions;
  const Eigen::AlignedBox3d box = bounding_box(x);
  const double size = box.diagonal().norm();
  for (Index n = 0; n < x.rows(); ++n) {
    const Eigen::Vector3d p = (x.row(n).transpose() - box.center()) / size;  // |p| ≤ ½
    const double angle = 0.3 * p.z();
    const Eigen::Vector3d q(std::cos(angle) * p.x() - std::sin(angle) * p.y() + 0.05 * p.z(),
                            std::sin(angle) * p.x() + std::cos(angle) * p.y(), 1.02 * p.z());
    x.row(n) = (box.center() + size * q).transpose();
    body.velocities.row(n) = Eigen::RowVector3d(-p.y(), p.x(), 0.1);
  }
}

/// A body meshed around the model, then deformed (deform), moving and
/// stressed: what a re-mesh meets.
inline MeshedBody deformed_body(const TriangleMesh& mesh, double h) {
  Material material;
  material.density = 1000.0;
  MeshedBody mb = mesh_body(mesh, material, h);
  deform(mb.body);
  return mb;
}

}  // namespace goo::bench
