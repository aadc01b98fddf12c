#pragma once
// Rigid obstacles a body collides with (W&T sec. 4): a floor, a press, a
// strainer. Each is a shape in its own frame, placed by a rigid motion
// (static, or keyframed), with a Coulomb friction coefficient.
#include <memory>
#include <string>
#include <vector>

#include "core/triangle_mesh.h"
#include "core/types.h"

namespace goo {

/// Signed distance to an obstacle's surface (negative inside the obstacle)
/// and the outward unit normal at the closest point: closest = x − d n.
struct SignedDistance {
  double distance = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

/// A solid shape in its own frame.
class Shape {
 public:
  virtual ~Shape() = default;
  [[nodiscard]] virtual SignedDistance signed_distance(const Eigen::Vector3d& p) const = 0;
  /// Bounds of the solid (unbounded directions ±∞).
  [[nodiscard]] virtual Eigen::AlignedBox3d bounds() const = 0;
  /// Its boundary as closed, outward triangles in its own frame, for
  /// pictures (curved shapes tessellated finely enough to look round); empty
  /// for an unbounded solid (a half-space).
  [[nodiscard]] virtual TriangleMesh boundary() const = 0;
  /// Whether the solid is a half-space, n·p ≤ offset in its own frame (n
  /// normalised), and then which: collision tests bound its distance over a
  /// whole element at once (core/collisions.cpp).
  [[nodiscard]] virtual bool half_space(Eigen::Vector3d& /*normal*/, double& /*offset*/) const { return false; }
};

/// The solid n·p ≤ offset (n is normalised): a floor has n = +z, offset = its height.
std::shared_ptr<const Shape> make_half_space(const Eigen::Vector3d& normal, double offset);
/// The box |p_k| ≤ half_extents_k.
std::shared_ptr<const Shape> make_box_shape(const Eigen::Vector3d& half_extents);
/// The ball |p| ≤ radius.
std::shared_ptr<const Shape> make_sphere_shape(double radius);
/// The cylinder x² + y² ≤ radius², |z| ≤ half_height.
std::shared_ptr<const Shape> make_cylinder_shape(double radius, double half_height);
/// The solid bounded by a closed, outward-oriented triangle mesh: closest
/// points through an AABB tree, inside by an exact-predicate ray test (a
/// point on the surface is at distance 0). `source` names it in errors.
std::shared_ptr<const Shape> make_mesh_shape(const TriangleMesh& mesh, const std::string& source);

/// A rigid motion from keyframes: translation interpolated linearly,
/// rotation by slerp (constant angular velocity within a segment); held
/// before the first and after the last key. No keys: the identity, static.
class RigidMotion {
 public:
  struct Key {
    double time = 0.0;
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  };

  RigidMotion() = default;
  /// goo::Error if times are not strictly increasing or not finite.
  explicit RigidMotion(std::vector<Key> keys);

  [[nodiscard]] bool is_static() const { return keys_.size() < 2; }
  [[nodiscard]] const std::vector<Key>& keys() const { return keys_; }
  /// Frame → world at time t.
  [[nodiscard]] Eigen::Isometry3d transform(double t) const;
  /// Velocity of the frame's translation and its angular velocity (world) at time t.
  [[nodiscard]] Eigen::Vector3d linear_velocity(double t) const;
  [[nodiscard]] Eigen::Vector3d angular_velocity(double t) const;

 private:
  /// The segment containing t (index of its first key), or −1 if held.
  [[nodiscard]] int segment(double t) const;
  std::vector<Key> keys_;
};

/// An obstacle's shape placed at one instant: its transform computed once,
/// for the many queries of a collision pass.
struct PlacedShape {
  const Shape* shape = nullptr;
  Eigen::Isometry3d to_world = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d to_local = Eigen::Isometry3d::Identity();
  /// Signed distance and outward normal at the world point x.
  [[nodiscard]] SignedDistance query(const Eigen::Vector3d& x) const;
  /// For a half-space, its plane in the world: the solid n·x ≤ offset.
  bool planar = false;
  Eigen::Vector3d plane_normal = Eigen::Vector3d::UnitZ();
  double plane_offset = 0.0;
};

struct Obstacle {
  std::string name;
  std::shared_ptr<const Shape> shape;
  RigidMotion motion;
  double friction = 0.0;  ///< Coulomb coefficient μ ≥ 0

  /// Signed distance and outward normal at the world point x, time t.
  [[nodiscard]] SignedDistance query(const Eigen::Vector3d& x, double t) const;
  /// The shape where it is at time t (query(x, t) is at(t).query(x)).
  [[nodiscard]] PlacedShape at(double t) const;
  /// Velocity of the obstacle's material at the world point x, time t.
  [[nodiscard]] Eigen::Vector3d velocity(const Eigen::Vector3d& x, double t) const;
  /// World bounds at time t (unbounded for a half-space).
  [[nodiscard]] Eigen::AlignedBox3d bounds(double t) const;
};

}  // namespace goo
