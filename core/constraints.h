#pragma once
// Kinematic constraints of a body: pinned nodes, nodes moved along a
// prescribed path, and a ground half-space nodes cannot cross (a stand-in
// until collisions on the embedded surface land).
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "core/contact/self_collisions.h"
#include "core/obstacles.h"
#include "core/types.h"

namespace goo {

/// Nodes whose position is a given function of time.
struct PrescribedMotion {
  std::vector<Index> nodes;
  /// Position of `node` at time t (s), given its rest position.
  std::function<Eigen::Vector3d(Index node, const Eigen::Vector3d& rest, double t)> position;
};

/// The region n·x ≥ offset (n unit). Nodes below are pushed back onto the
/// plane; their inward normal velocity is removed and their tangential
/// velocity reduced by friction × the removed normal speed (Coulomb).
struct HalfSpace {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  double friction = 0.0;
};

struct Body;

/// Pushes the free nodes below the ground back onto it, removing their inward
/// normal velocity and reducing their tangential velocity by friction × the
/// removed normal speed (Coulomb). Returns the nodes in contact.
Index enforce_ground(Body& body, const HalfSpace& ground, const std::vector<std::uint8_t>& fixed);

struct Constraints {
  std::vector<Index> pinned;
  std::vector<PrescribedMotion> prescribed;
  std::optional<HalfSpace> ground;
  /// Obstacles the embedded surface collides with (bodies with a surface).
  std::vector<Obstacle> obstacles;
  /// Self-collisions of the embedded surface, when on.
  std::optional<SelfCollisionParameters> self_collisions;
};

}  // namespace goo
