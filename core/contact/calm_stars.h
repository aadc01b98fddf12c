#pragma once
// Node stars through which the embedded surface cannot pass through itself
// over a step (docs/embedded-surface.md, "Pairs in a calm star").
//
// The nodes move linearly over the step, so the lattice maps rest space to
// the world by a piecewise-linear f_t. On the star of a node n (its tets),
// convex in rest space, write f_t(X) = Ā(t) X + c + g(X) with Ā the mean of
// the star's gradients F_T(t) and g's gradient F_T − Ā, at most L in norm.
// Two surface primitives with rest vertices X_i and Y_j, all in the star,
// sit in the world at Σ u_i f(X_i) and Σ v_j f(Y_j); their gap is at least
//   σ_min(Ā) |P − Q| − L max_ij |X_i − Y_j|  ≥  σ d − L D
// with d their rest distance and D their largest rest vertex distance. So
// while κ = L / σ_min(Ā) stays below d / D all step, the pair cannot touch:
// it needs no measuring. A pair's ratio ρ = D / d is fixed by the rest
// surface; pairs of a star group are either at most kRatio, or found once
// per surface ("near" pairs, with their own ratio).
#include <array>
#include <cstdint>
#include <vector>

#include "core/body.h"
#include "core/contact/box_pairs.h"

namespace goo {

/// κ = L / s over a step for a star whose tets have gradients F0[k] at its
/// start and F1[k] at its end (F linear in t): L the largest ‖F_T − Ā‖_F at
/// either end (‖·‖ is convex, so it bounds every time), s a lower bound of
/// σ_min(Ā(t)) on [0, 1]: σ_min is 1-Lipschitz in Ā, which moves by
/// Δ = ‖Ā1 − Ā0‖_F, so s = min(σ0, σ1, (σ0 + σ1 − Δ) / 2). Infinite when s ≤ 0.
/// With a test κ × multiplier < threshold (multiplier > 0): a κ from lower
/// bounds of σ0 and σ1 (no SVD) when that passes it, a value at least the
/// SVD's; otherwise the SVD's. Either way the test's answer is the SVD's.
double star_spread(const std::vector<Eigen::Matrix3d>& F0, const std::vector<Eigen::Matrix3d>& F1,
                   double multiplier = 0.0, double threshold = 0.0);

class CalmStars {
 public:
  /// Pairs farther apart in rest space than (diam_A + diam_B) / (kRatio − 1)
  /// have D / d ≤ kRatio (D ≤ d + diam_A + diam_B); closer ones are found.
  static constexpr double kRatio = 4.0;

  /// Per mesh (kept while tets and rest positions are unchanged): the nodes
  /// whose star is a closed, convex ball of positively oriented rest tets.
  /// Returns whether the mesh changed.
  bool update_mesh(const Body& body);
  /// Per surface (kept while triangles and embedding are unchanged): the
  /// rest positions of the surface vertices and the triangle pairs with a
  /// primitive pair of ratio above kRatio, with their largest ratio.
  void update_surface(const Body& body, const std::vector<Index>& element_of);

  /// Each triangle's star group at a list build: among the nodes whose star
  /// holds all its corners (at barycentric coordinates ≥ 0), the one nearest
  /// its rest centroid with κ × kRatio below three quarters this step; −1
  /// if none. Starts every group with nothing returned.
  std::vector<Index> assign_groups(const Body& body, const Points& x0, const Points& d);

  /// The triangle pairs of groups that stop being safe this step, with the
  /// nodes at x0 moving by d, each returned once until the next
  /// assign_groups: a group whose κ × kRatio reaches 1 gives all its pairs
  /// whose `boxes` (per triangle) overlap; below that, only its near pairs
  /// whose κ × ratio reaches 1 (the others cannot touch). With `moved` (per
  /// node), only stars with a moved node are measured again.
  /// With `moved_elements` too (the elements with a moved node, each once),
  /// only those elements' stars are looked at: the same result.
  std::vector<std::array<Index, 2>> newly_unsafe(const Body& body, const Points& x0, const Points& d,
                                                 const std::vector<std::uint8_t>* moved, const std::vector<Box3>& boxes,
                                                 const std::vector<Index>* moved_elements = nullptr);

  /// Whether triangles a and b lie in one group whose pairs of them have
  /// been returned since the last assign_groups (the group's in full, or
  /// (a, b) as a near pair): listed, as two triangles of no common group are.
  [[nodiscard]] bool returned(Index a, Index b) const;

  /// The near pairs of the last update_surface (triangle ids, lower first)
  /// and their ratios.
  [[nodiscard]] const std::vector<std::array<Index, 2>>& near_pairs() const { return near_; }
  [[nodiscard]] const std::vector<double>& near_ratios() const { return near_ratio_; }
  /// The near pairs' indices by ratio, largest first, then by index: the
  /// order in which a group's near pairs are returned (newly_unsafe stops
  /// at the first whose κ × ratio is safe, so every later one must be too).
  [[nodiscard]] const std::vector<Index>& near_order() const { return near_order_; }
  /// Per triangle, the eligible stars holding all its corners (−1: none;
  /// valid after update_surface): two triangles can join one group only
  /// if they have one in common.
  [[nodiscard]] const std::vector<std::array<Index, 4>>& candidate_stars() const { return candidates_; }

  /// The triangles of group n (valid after assign_groups).
  [[nodiscard]] std::vector<Index> members(Index n) const {
    return {members_.begin() + offsets_[static_cast<std::size_t>(n)],
            members_.begin() + offsets_[static_cast<std::size_t>(n) + 1]};
  }

 private:
  void gradients(const Body& body, const Points& x0, const Points& d, const std::vector<std::uint8_t>* elements);
  /// The same for the listed elements only.
  void gradients(const Body& body, const Points& x0, const Points& d, const std::vector<Index>& elements);
  std::vector<Index> star_stamp_;  // per node: the last newly_unsafe call that took its star (moved_elements)
  Index star_call_ = 0;
  /// Star n's κ this step, or a bound above it when that bound passes the
  /// caller's test κ × multiplier < threshold (the decisions are then the
  /// same as with κ; spread_of in calm_stars.cpp).
  [[nodiscard]] double spread(const Body& body, Index n, double multiplier, double threshold) const;

  Tets tets_;                // the mesh the stars below belong to
  Points rest_;              // its rest positions
  NodeIncidence incidence_;
  std::vector<std::uint8_t> eligible_;           // per node
  std::vector<Eigen::Matrix3d> rest_inverse_;    // per element, D(X)⁻¹
  std::vector<Eigen::Matrix3d> F0_, F1_;         // per element, gradients at the step's start and end

  Triangles triangles_;      // the surface below belongs to
  std::vector<Index> parents_;
  Eigen::MatrixXd bary_;
  Points surface_rest_;                          // per surface vertex, its rest position
  std::vector<std::array<Index, 4>> candidates_; // per triangle: the eligible stars holding its corners (−1: none)
  std::vector<std::uint8_t> star_has_surface_;   // per node: some triangle's candidate
  std::vector<std::array<Index, 2>> near_;       // triangle pairs with a ratio above kRatio
  std::vector<double> near_ratio_;
  std::vector<Index> near_order_;  // near_ by ratio, largest first (then by index)

  std::vector<Index> group_;                     // per triangle, this list's
  std::vector<double> kappa_;                    // per node, this step
  std::vector<std::uint8_t> full_;               // per node: all its group's pairs returned
  std::vector<Index> offsets_, members_;         // the groups' triangles
  std::vector<Index> near_offsets_, near_members_;  // the groups' near pairs (into near_), by ratio, largest first
  std::vector<Index> near_listed_;               // per node: how many of them were returned
  std::vector<Index> grouped_;                   // nodes with a group
};

}  // namespace goo
