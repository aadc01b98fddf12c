#pragma once
// A pinhole camera for pictures of a run, and one that frames a box.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace goo::render {

struct Camera {
  Eigen::Vector3d eye = Eigen::Vector3d(1.0, -1.0, 1.0);
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double fov_degrees = 35.0;  ///< vertical
  double near = 0.01, far = 100.0;

  /// World → eye (OpenGL's convention: the camera looks down −z).
  [[nodiscard]] Eigen::Matrix4d view() const;
  /// Eye → clip for a picture of this width / height.
  [[nodiscard]] Eigen::Matrix4d projection(double aspect) const;
};

/// A camera looking at `box` from the direction given by `azimuth_degrees`
/// (about +z, 0 = from −y) and `elevation_degrees` (above the horizon),
/// far enough that the box's bounding sphere fits the picture of this
/// aspect with a margin, with near and far planes around it.
Camera frame_box(const Eigen::AlignedBox3d& box, double azimuth_degrees, double elevation_degrees, double aspect,
                 double fov_degrees = 35.0);

/// The same camera turned about the vertical axis through its target.
Camera orbit(const Camera& camera, double degrees);

}  // namespace goo::render
