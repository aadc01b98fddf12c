#include "core/constraints.h"

#include <algorithm>

#include "core/body.h"

namespace goo {

Index enforce_ground(Body& body, const HalfSpace& g, const std::vector<std::uint8_t>& fixed) {
  Index contacts = 0;
  for (Index n = 0; n < body.num_nodes(); ++n) {
    if (!fixed.empty() && fixed[static_cast<std::size_t>(n)]) continue;
    const double depth = g.offset - g.normal.dot(body.positions.row(n).transpose());
    if (depth < 0.0) continue;
    ++contacts;
    body.positions.row(n) += depth * g.normal.transpose();
    Eigen::Vector3d v = body.velocities.row(n);
    const double vn = g.normal.dot(v);
    if (vn < 0.0) {
      v -= vn * g.normal;  // remove the inward normal velocity
      Eigen::Vector3d vt = v - g.normal.dot(v) * g.normal;
      const double speed = vt.norm();
      const double reduction = g.friction * -vn;  // Coulomb: |Δv_t| ≤ μ |Δv_n|
      if (speed > 0.0) v -= std::min(reduction, speed) / speed * vt;
      body.velocities.row(n) = v.transpose();
    }
  }
  return contacts;
}

}  // namespace goo
