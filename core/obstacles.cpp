#include "core/obstacles.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/primitives.h"

namespace goo {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Segments around a sphere or cylinder drawn in pictures: edges turn by
// 360°/64 = 5.6°, below what shading shows as facets at a picture's size.
constexpr int kRoundSegments = 64;

Eigen::AlignedBox3d unbounded() {
  return {Eigen::Vector3d::Constant(-kInf), Eigen::Vector3d::Constant(kInf)};
}

class HalfSpaceShape final : public Shape {
 public:
  HalfSpaceShape(const Eigen::Vector3d& n, double offset) : n_(n.normalized()), offset_(offset) {}
  SignedDistance signed_distance(const Eigen::Vector3d& p) const override { return {n_.dot(p) - offset_, n_}; }
  Eigen::AlignedBox3d bounds() const override { return unbounded(); }
  TriangleMesh boundary() const override { return {}; }
  bool half_space(Eigen::Vector3d& normal, double& offset) const override {
    normal = n_;
    offset = offset_;
    return true;
  }

 private:
  Eigen::Vector3d n_;
  double offset_;
};

class BoxShape final : public Shape {
 public:
  explicit BoxShape(const Eigen::Vector3d& half) : half_(half) {}
  SignedDistance signed_distance(const Eigen::Vector3d& p) const override {
    const Eigen::Vector3d q = p.cwiseAbs() - half_;
    const Eigen::Vector3d sign = p.unaryExpr([](double v) { return v < 0.0 ? -1.0 : 1.0; });
    const Eigen::Vector3d out = q.cwiseMax(0.0);
    if (out.squaredNorm() > 0.0) {
      const double d = out.norm();
      return {d, sign.cwiseProduct(out) / d};
    }
    // Inside (or on): the nearest face.
    Eigen::Index k = 0;
    const double d = q.maxCoeff(&k);
    return {d, sign[k] * Eigen::Vector3d::Unit(k)};
  }
  Eigen::AlignedBox3d bounds() const override { return {-half_, half_}; }
  TriangleMesh boundary() const override { return make_box(2.0 * half_, 1); }

 private:
  Eigen::Vector3d half_;
};

class SphereShape final : public Shape {
 public:
  explicit SphereShape(double radius) : radius_(radius) {}
  SignedDistance signed_distance(const Eigen::Vector3d& p) const override {
    const double r = p.norm();
    return {r - radius_, r > 0.0 ? Eigen::Vector3d(p / r) : Eigen::Vector3d::UnitZ()};
  }
  Eigen::AlignedBox3d bounds() const override {
    return {Eigen::Vector3d::Constant(-radius_), Eigen::Vector3d::Constant(radius_)};
  }
  TriangleMesh boundary() const override { return make_sphere(radius_, kRoundSegments); }

 private:
  double radius_;
};

class CylinderShape final : public Shape {
 public:
  CylinderShape(double radius, double half_height) : radius_(radius), half_height_(half_height) {}
  SignedDistance signed_distance(const Eigen::Vector3d& p) const override {
    // √(x² + y²), not std::hypot: glibc's guards against overflow cost
    // several times as much (4% of the armadillo grate's profile went to
    // it), and coordinates here are metres.
    const double r = std::sqrt(p.x() * p.x() + p.y() * p.y());
    const Eigen::Vector3d radial = r > 0.0 ? Eigen::Vector3d(p.x() / r, p.y() / r, 0.0) : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d axial(0.0, 0.0, p.z() < 0.0 ? -1.0 : 1.0);
    const double dr = r - radius_, dz = std::abs(p.z()) - half_height_;
    if (dr > 0.0 || dz > 0.0) {
      const double a = std::max(dr, 0.0), b = std::max(dz, 0.0);
      const double d = std::sqrt(a * a + b * b);
      return {d, (a * radial + b * axial) / d};
    }
    return dr > dz ? SignedDistance{dr, radial} : SignedDistance{dz, axial};
  }
  Eigen::AlignedBox3d bounds() const override {
    return {Eigen::Vector3d(-radius_, -radius_, -half_height_), Eigen::Vector3d(radius_, radius_, half_height_)};
  }
  TriangleMesh boundary() const override { return make_cylinder(radius_, 2.0 * half_height_, kRoundSegments); }

 private:
  double radius_, half_height_;
};

void require_positive(double value, const char* what) {
  if (!(value > 0.0) || !std::isfinite(value))
    throw Error(fmt::format("obstacle {} must be positive and finite, got {}", what, value));
}

}  // namespace

std::shared_ptr<const Shape> make_half_space(const Eigen::Vector3d& normal, double offset) {
  if (!normal.allFinite() || normal.norm() == 0.0 || !std::isfinite(offset))
    throw Error("half-space obstacle needs a finite, non-zero normal and a finite offset");
  return std::make_shared<HalfSpaceShape>(normal, offset);
}

std::shared_ptr<const Shape> make_box_shape(const Eigen::Vector3d& half_extents) {
  for (int k = 0; k < 3; ++k) require_positive(half_extents[k], "box half extent");
  return std::make_shared<BoxShape>(half_extents);
}

std::shared_ptr<const Shape> make_sphere_shape(double radius) {
  require_positive(radius, "sphere radius");
  return std::make_shared<SphereShape>(radius);
}

std::shared_ptr<const Shape> make_cylinder_shape(double radius, double half_height) {
  require_positive(radius, "cylinder radius");
  require_positive(half_height, "cylinder half height");
  return std::make_shared<CylinderShape>(radius, half_height);
}

RigidMotion::RigidMotion(std::vector<Key> keys) : keys_(std::move(keys)) {
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    const Key& k = keys_[i];
    if (!std::isfinite(k.time) || !k.translation.allFinite() || !k.rotation.coeffs().allFinite() ||
        k.rotation.norm() == 0.0)
      throw Error(fmt::format("motion key {} is not finite", i));
    if (i > 0 && !(k.time > keys_[i - 1].time))
      throw Error(fmt::format("motion key {}: times must increase strictly ({} after {})", i, k.time,
                              keys_[i - 1].time));
    keys_[i].rotation.normalize();
  }
}

int RigidMotion::segment(double t) const {
  if (keys_.size() < 2 || t <= keys_.front().time || t >= keys_.back().time) return -1;
  const auto it = std::upper_bound(keys_.begin(), keys_.end(), t, [](double x, const Key& k) { return x < k.time; });
  return static_cast<int>(it - keys_.begin()) - 1;
}

Eigen::Isometry3d RigidMotion::transform(double t) const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (keys_.empty()) return T;
  const int s = segment(t);
  if (s < 0) {
    const Key& k = t <= keys_.front().time ? keys_.front() : keys_.back();
    T.linear() = k.rotation.toRotationMatrix();
    T.translation() = k.translation;
    return T;
  }
  const Key& a = keys_[static_cast<std::size_t>(s)];
  const Key& b = keys_[static_cast<std::size_t>(s) + 1];
  const double u = (t - a.time) / (b.time - a.time);
  T.linear() = a.rotation.slerp(u, b.rotation).toRotationMatrix();
  T.translation() = (1.0 - u) * a.translation + u * b.translation;
  return T;
}

Eigen::Vector3d RigidMotion::linear_velocity(double t) const {
  const int s = segment(t);
  if (s < 0) return Eigen::Vector3d::Zero();
  const Key& a = keys_[static_cast<std::size_t>(s)];
  const Key& b = keys_[static_cast<std::size_t>(s) + 1];
  return (b.translation - a.translation) / (b.time - a.time);
}

Eigen::Vector3d RigidMotion::angular_velocity(double t) const {
  const int s = segment(t);
  if (s < 0) return Eigen::Vector3d::Zero();
  const Key& a = keys_[static_cast<std::size_t>(s)];
  const Key& b = keys_[static_cast<std::size_t>(s) + 1];
  // slerp(a, b, u) = (b a⁻¹)^u a along the shorter arc: a world-frame
  // rotation about a fixed axis at a constant rate.
  Eigen::Quaterniond relative = b.rotation * a.rotation.inverse();
  if (relative.w() < 0.0) relative.coeffs() *= -1.0;
  const Eigen::AngleAxisd aa(relative);
  return aa.axis() * (aa.angle() / (b.time - a.time));
}

SignedDistance PlacedShape::query(const Eigen::Vector3d& x) const {
  SignedDistance sd = shape->signed_distance(to_local * x);
  sd.normal = to_world.linear() * sd.normal;
  return sd;
}

PlacedShape Obstacle::at(double t) const {
  PlacedShape out;
  out.shape = shape.get();
  out.to_world = motion.transform(t);
  out.to_local = out.to_world.inverse();
  Eigen::Vector3d n;
  double offset = 0.0;
  if (shape->half_space(n, offset)) {
    // n·(R⁻¹(x − t)) ≤ offset ⇔ (R n)·x ≤ offset + (R n)·t.
    out.planar = true;
    out.plane_normal = out.to_world.linear() * n;
    out.plane_offset = offset + out.plane_normal.dot(out.to_world.translation());
  }
  return out;
}

SignedDistance Obstacle::query(const Eigen::Vector3d& x, double t) const { return at(t).query(x); }

Eigen::Vector3d Obstacle::velocity(const Eigen::Vector3d& x, double t) const {
  if (motion.is_static()) return Eigen::Vector3d::Zero();
  const Eigen::Isometry3d T = motion.transform(t);
  return motion.linear_velocity(t) + motion.angular_velocity(t).cross(x - T.translation());
}

Eigen::AlignedBox3d Obstacle::bounds(double t) const {
  const Eigen::AlignedBox3d local = shape->bounds();
  if (!local.min().allFinite() || !local.max().allFinite()) return unbounded();
  const Eigen::Isometry3d T = motion.transform(t);
  Eigen::AlignedBox3d out;
  for (int c = 0; c < 8; ++c) out.extend(T * local.corner(static_cast<Eigen::AlignedBox3d::CornerType>(c)));
  return out;
}

}  // namespace goo
