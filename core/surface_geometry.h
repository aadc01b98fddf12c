#pragma once
// Integral properties of a closed triangle surface.
#include <Eigen/Geometry>

#include "core/triangle_mesh.h"

namespace goo {

struct SurfaceIntegrals {
  double area = 0.0;                                   ///< m²
  double volume = 0.0;                                 ///< signed enclosed volume, m³
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< centre of the enclosed volume, m
};

/// Axis-aligned bounds of the vertices (empty box for an empty mesh).
Eigen::AlignedBox3d bounding_box(const Points& vertices);

/// Area, signed volume and volume centroid by the divergence theorem
/// (Lien & Kajiya 1984): each triangle and a reference point r span a signed
/// tetrahedron of volume det[a−r, b−r, c−r]/6 and centroid (r+a+b+c)/4.
/// r is the bounding-box centre, which keeps the determinants well scaled.
/// Sums are compensated (Neumaier) and sequential, so the result is
/// deterministic and accurate to a few ulps. Requires valid indices.
SurfaceIntegrals surface_integrals(const TriangleMesh& mesh);

/// The enclosed volume a second, independent way: the flux of the field
/// (0, 0, z − r_z) through the surface, Σ_T A_T n_z (z̄_T − r_z). Equal to
/// surface_integrals().volume for a closed surface; used to cross-check it.
double enclosed_volume_by_z_flux(const TriangleMesh& mesh);

/// Neumaier's compensated sum: the error of a long sum stays O(ε) instead of
/// O(n ε).
class CompensatedSum {
 public:
  void add(double x) {
    const double t = sum_ + x;
    compensation_ += (std::abs(sum_) >= std::abs(x)) ? (sum_ - t) + x : (x - t) + sum_;
    sum_ = t;
  }
  [[nodiscard]] double value() const { return sum_ + compensation_; }

 private:
  double sum_ = 0.0;
  double compensation_ = 0.0;
};

}  // namespace goo
