#include "core/surface_geometry.h"

#include <array>

namespace goo {

Eigen::AlignedBox3d bounding_box(const Points& vertices) {
  Eigen::AlignedBox3d box;
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) box.extend(vertices.row(i).transpose());
  return box;
}

namespace {
Eigen::Vector3d reference_point(const TriangleMesh& mesh) {
  const Eigen::AlignedBox3d box = bounding_box(mesh.vertices);
  if (box.isEmpty()) return Eigen::Vector3d::Zero();
  return box.center();
}
}  // namespace

SurfaceIntegrals surface_integrals(const TriangleMesh& mesh) {
  const Eigen::Vector3d r = reference_point(mesh);
  CompensatedSum area;
  CompensatedSum six_volume;
  std::array<CompensatedSum, 3> twentyfour_moment;  // Σ 6V_t · 4(c_t − r)
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    auto [a, b, c] = mesh.corners(t);
    a -= r;
    b -= r;
    c -= r;
    area.add(0.5 * (b - a).cross(c - a).norm());
    const double det = a.dot(b.cross(c));
    six_volume.add(det);
    const Eigen::Vector3d m = det * (a + b + c);
    for (int k = 0; k < 3; ++k) twentyfour_moment[static_cast<std::size_t>(k)].add(m[k]);
  }
  SurfaceIntegrals out;
  out.area = area.value();
  out.volume = six_volume.value() / 6.0;
  out.centroid = r;
  if (six_volume.value() != 0.0) {
    for (int k = 0; k < 3; ++k)
      out.centroid[k] += twentyfour_moment[static_cast<std::size_t>(k)].value() / (4.0 * six_volume.value());
  }
  return out;
}

double enclosed_volume_by_z_flux(const TriangleMesh& mesh) {
  const double rz = reference_point(mesh).z();
  CompensatedSum volume;
  for (Index t = 0; t < mesh.num_triangles(); ++t) {
    const auto [a, b, c] = mesh.corners(t);
    // 2 A n_z = ((b − a) × (c − a))_z ; the mean of z − r_z over a triangle is
    // its value at the centroid because z is linear.
    const double two_area_nz = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    const double mean_z = (a.z() + b.z() + c.z()) / 3.0 - rz;
    volume.add(0.5 * two_area_nz * mean_z);
  }
  return volume.value();
}

}  // namespace goo
