#pragma once
// Kinematic constraints of a body: pinned nodes, nodes moved along a
// prescribed path, and what its embedded surface collides with (the floor
// is an obstacle, a half-space; core/obstacles.h).
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

/// The region n·x ≥ offset (n unit) with a Coulomb friction coefficient: a
/// scene's floor, which the simulation turns into a half-space obstacle.
struct HalfSpace {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  double friction = 0.0;
};

struct Constraints {
  std::vector<Index> pinned;
  std::vector<PrescribedMotion> prescribed;
  /// Obstacles the embedded surface collides with (bodies with a surface).
  std::vector<Obstacle> obstacles;
  /// Self-collisions of the embedded surface, when on.
  std::optional<SelfCollisionParameters> self_collisions;
};

}  // namespace goo
