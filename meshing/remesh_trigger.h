#pragma once
// When to re-mesh (W&T sec. 5 and 8): an element's shape-matrix condition
// number has tripled since its creation, or a surface vertex has drifted out
// of its parent (a barycentric coordinate below −0.2).
#include <Eigen/Core>

#include "core/body.h"

namespace goo {

struct RemeshThresholds {
  double condition_growth = 3.0;  ///< κ(Ds) / κ(Dm) that triggers
  double min_barycentric = -0.2;  ///< a surface vertex's coordinate that triggers
};

/// Why a re-mesh is due, or not.
struct RemeshCheck {
  bool due = false;
  Index element = -1;         ///< first element past its condition bound (or inverted)
  Index vertex = -1;          ///< first surface vertex past the barycentric bound
  double worst_growth = 0.0;  ///< max κ(Ds)/κ(Dm) (∞ for an inverted element)
};

/// κ(Ds) = σ_max / σ_min of the current edge matrix; ∞ if flat or inverted.
double condition_number(const Eigen::Matrix3d& Ds);

/// Checks every element at positions x and every row of `bary` (#V×4).
RemeshCheck check_remesh(const Body& body, const Points& x,
                         const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& bary,
                         const RemeshThresholds& thresholds = {});

}  // namespace goo
