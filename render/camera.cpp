#include "render/camera.h"

#include <algorithm>
#include <cmath>

namespace goo::render {
namespace {
constexpr double kPi = 3.14159265358979323846;
double radians(double degrees) { return degrees * kPi / 180.0; }
}  // namespace

Eigen::Matrix4d Camera::view() const {
  const Eigen::Vector3d f = (target - eye).normalized();
  const Eigen::Vector3d s = f.cross(up).normalized();
  const Eigen::Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m;
}

Eigen::Matrix4d Camera::projection(double aspect) const {
  const double t = 1.0 / std::tan(0.5 * radians(fov_degrees));
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = t / aspect;
  m(1, 1) = t;
  m(2, 2) = -(far + near) / (far - near);
  m(2, 3) = -2.0 * far * near / (far - near);
  m(3, 2) = -1.0;
  return m;
}

Camera frame_box(const Eigen::AlignedBox3d& box, double azimuth_degrees, double elevation_degrees, double aspect,
                 double fov_degrees) {
  Camera c;
  c.fov_degrees = fov_degrees;
  c.target = box.center();
  const double radius = std::max(0.5 * box.diagonal().norm(), 1e-6);
  // The sphere fits the narrower of the two fields of view, with 8% margin.
  const double half_vertical = 0.5 * radians(fov_degrees);
  const double half_horizontal = std::atan(std::tan(half_vertical) * aspect);
  const double distance = 1.08 * radius / std::sin(std::min(half_vertical, half_horizontal));
  const double a = radians(azimuth_degrees), e = radians(elevation_degrees);
  const Eigen::Vector3d direction(std::sin(a) * std::cos(e), -std::cos(a) * std::cos(e), std::sin(e));
  c.eye = c.target + distance * direction;
  c.up = Eigen::Vector3d::UnitZ();
  c.near = std::max(distance - 4.0 * radius, 1e-3 * distance);
  c.far = distance + 40.0 * radius;  // the floor reaches beyond the box
  return c;
}

Camera orbit(const Camera& camera, double degrees) {
  Camera c = camera;
  const Eigen::AngleAxisd turn(radians(degrees), Eigen::Vector3d::UnitZ());
  c.eye = camera.target + turn * (camera.eye - camera.target);
  c.up = turn * camera.up;
  return c;
}

}  // namespace goo::render
