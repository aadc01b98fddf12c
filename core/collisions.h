#pragma once
// Collisions of the embedded surface with obstacles (W&T sec. 4;
// algorithms.md, "Collisions"): per element, only its deepest penetrating
// surface vertex is resolved, by moving the element's nodes with the
// distribution weights w_i = b_i / Σ b_j² (W&T eq. 4), which move that vertex
// by exactly the correction.
#include <cstdint>
#include <vector>

#include "core/body.h"
#include "core/obstacles.h"

namespace goo {

/// A correction of the position stage: the element whose deepest vertex
/// was moved, and the obstacle's outward normal there.
struct ElementContact {
  Index element;
  Eigen::Vector3d normal;
};

struct CollisionStats {
  Index resolved = 0;     ///< element corrections applied, all passes
  int passes = 0;         ///< passes that found something to resolve
  double deepest = 0.0;   ///< most negative signed distance met (≤ 0)
};

/// Resolves collisions for one body, in parallel and deterministically:
/// elements to correct are coloured greedily in element order so that no
/// two of one colour share a node, and colours run one after another (each
/// in parallel). The tet mesh is the bounding-volume hierarchy: the
/// vertices of an element whose box, widened for vertices drifting out of
/// it, misses every obstacle are skipped.
class SurfaceCollisions {
 public:
  /// Velocity stage, on v (the body's node velocities or v½): a vertex that
  /// would be inside an obstacle at x + dt v and approaches it loses its
  /// normal velocity relative to the obstacle (Δv to the nodes with w_i).
  /// Then each node that this moved loses of its tangential velocity
  /// relative to the obstacle at most μ × the normal change it received
  /// (Coulomb, per node).
  CollisionStats resolve_velocities(const Body& body, Points& v, const std::vector<Obstacle>& obstacles, double t,
                                    double dt, const std::vector<std::uint8_t>& fixed);

  /// Position stage: the deepest penetrating vertex of each element is moved
  /// onto the obstacle's surface (Δx = −d n, nodes by w_i Δx). Repeats while
  /// corrections of neighbours leave penetrations, at most `max_passes` times.
  /// A penetration within the rounding of its signed distance (64 ε of the
  /// element's node coordinates and the obstacle's placement) counts as none.
  /// With `contacts`, every correction is appended to it (passes in turn,
  /// each in element order).
  CollisionStats resolve_positions(Body& body, const std::vector<Obstacle>& obstacles, double t,
                                   const std::vector<std::uint8_t>& fixed, int max_passes = 4,
                                   std::vector<ElementContact>* contacts = nullptr);

 private:
  struct Hit {
    Index element;
    Index vertex;
    Index obstacle;
    SignedDistance contact;
  };
  /// Element → its surface vertices (offsets_, vertices_) and their
  /// barycentric ranges (bary_low_, bary_high_, bary_mid_, bary_reach_),
  /// for the calls of detect that follow.
  void index_vertices(const Body& body);
  /// The deepest hit of every element (of those that have one, and are
  /// flagged in `only` if given), in element order.
  std::vector<Hit> detect(const Body& body, const Points& x, const Points* v, double dt,
                          const std::vector<Obstacle>& obstacles, double t,
                          const std::vector<std::uint8_t>* only = nullptr);
  /// Element colour classes of the hits: hits of one class share no node.
  std::vector<std::vector<std::size_t>> colour(const Body& body, const std::vector<Hit>& hits);

  std::vector<Index> offsets_, vertices_;  // element → its surface vertices
  std::vector<Eigen::Vector4d> bary_low_, bary_high_;  // per element, each coordinate's range over its vertices
  /// Per element, barycentric coordinates b̄ (summing to 1) amid its
  /// vertices' and how far each coordinate of a vertex lies from b̄ at most:
  /// every vertex lies within Σ_{k≠j} reach_k |y_k − y_j| of Σ b̄_k y_k.
  std::vector<Eigen::Vector4d> bary_mid_, bary_reach_;
  std::vector<Index> indexed_parent_;                   // the embedding those were made for
  Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::RowMajor> indexed_bary_;
  std::vector<std::vector<double>> node_distance_;     // per half-space obstacle, per node: signed distance
  std::vector<double> node_size_;                      // per node, its largest coordinate (absolute)
  std::vector<Eigen::Vector3d> normal_change_;          // per node, the velocity stage's normal change
  std::vector<Index> contact_obstacle_;                 // per node, the obstacle of its last contact (−1: none)
  std::vector<std::uint64_t> near_;         // per element, the obstacles near it (a bit each)
  std::vector<Eigen::Vector3d> centre_;     // per element, Σ b̄_k y_k amid its vertices (curved obstacles)
  std::vector<double> centre_distance_;     // per element and obstacle, its signed distance from centre_ (where near)
  std::vector<std::uint64_t> masks_;        // per node, colours used (two words)
  std::vector<Index> flagged_;              // a restricted detection's elements that have vertices
  std::vector<Hit> flagged_hits_;           // and the deepest hit of each (element −1: none)
  std::vector<Hit> per_element_;            // a full detection's deepest hit per element (empty between calls)
  std::vector<std::vector<Index>> flagged_runs_;  // detect's flagged elements, per run of elements
  std::vector<std::uint8_t> hit_;           // per element: hit in this detection (zero between calls)
};

}  // namespace goo
