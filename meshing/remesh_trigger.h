#pragma once
// When to re-mesh (W&T sec. 5 and 8): an element's shape-matrix condition
// number has tripled since its creation, or a surface vertex has drifted out
// of its parent (a barycentric coordinate below −0.2).
#include <Eigen/Core>

#include "core/body.h"
#include "core/settings.h"

namespace goo {


/// Why a re-mesh is due, or not.
struct RemeshCheck {
  bool due = false;
  Index element = -1;         ///< first element past its condition bound (or inverted)
  Index vertex = -1;          ///< first surface vertex past the barycentric bound
  double worst_growth = 0.0;  ///< max κ(Ds)/κ(Dm) (∞ for an inverted element)
  Index inverted = 0;         ///< elements inverted or flat (det Ds ≤ 0)
};

/// κ(Ds) = σ_max / σ_min of the current edge matrix; ∞ if flat or inverted.
double condition_number(const Eigen::Matrix3d& Ds);

/// Checks every element at positions x and every row of `bary` (#V×4).
RemeshCheck check_remesh(const Body& body, const Points& x,
                         const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& bary,
                         const RemeshThresholds& thresholds = {});

/// Whether check_remesh would find a re-mesh due, at a fraction of its cost
/// (run after every step): in parallel, and with the SVD only for elements
/// that fail the cheap bound κ₂(Ds) ≤ ‖Ds‖_F ‖Ds⁻¹‖_F.
bool remesh_due(const Body& body, const Points& x, const Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor>& bary,
                const RemeshThresholds& thresholds = {});

}  // namespace goo
