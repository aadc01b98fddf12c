#pragma once
// Self-collisions of a body's embedded surface over one step (W&T sec. 4;
// Bridson, Fedkiw & Anderson 2002): proximity repulsion, continuous
// collision detection of vertex–triangle and edge–edge pairs with
// inelastic, frictional impulses, and rigid impact zones as the fail-safe,
// so that no step makes the surface pass through itself
// (docs/embedded-surface.md, "Self-collisions").
//
// The surface moves with the nodes: x_s = W x. An impulse J on a pair of
// surface points reaches the nodes as the quantity Wᵀ J (each node i gets
// its share c_i J and moves by c_i J / m_i), so the total momentum does not
// change (Σ c_i = 0 for the two sides of a pair).
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/body.h"
#include "core/contact/box_pairs.h"
#include "core/contact/calm_stars.h"
#include "core/contact/ccd.h"

namespace goo {

struct SelfCollisionStats {
  std::int64_t candidates = 0;  ///< pairs measured by the narrow phase, all rounds together
  Index repulsions = 0;         ///< impulses on pairs that started closer than the thickness
  Index impacts = 0;            ///< impulses on pairs that would have come closer during the step
  int rounds = 0;               ///< detection rounds with impulses
  int zone_rounds = 0;          ///< fail-safe rounds (rigid impact zones)
  Index zone_nodes = 0;         ///< nodes moved rigidly by the fail-safe
  Index touching_at_start = 0;  ///< pairs at distance 0 when the step began (left alone)
  Index list_builds = 0;        ///< broad phases run (a candidate list is kept while it holds)
  Index list_extensions = 0;    ///< lists kept by widening the margins of the few vertices past theirs
  std::int64_t listed = 0;      ///< pairs on the list at each step's first detection, summed over steps
  Index waited = 0;             ///< steps left alone: an element was inverted

  SelfCollisionStats& operator+=(const SelfCollisionStats& o) {
    candidates += o.candidates, repulsions += o.repulsions, impacts += o.impacts, rounds += o.rounds;
    zone_rounds += o.zone_rounds, zone_nodes += o.zone_nodes, touching_at_start += o.touching_at_start;
    list_builds += o.list_builds, list_extensions += o.list_extensions, listed += o.listed, waited += o.waited;
    return *this;
  }
};

struct SelfCollisionParameters {
  double thickness = 0.0;  ///< m: pairs are kept at least this far apart (those that start closer, apart from half their gap)
  double friction = 0.0;   ///< Coulomb coefficient between sheets of the surface
  int max_rounds = 8;      ///< impulse rounds before the fail-safe
  /// The share of the full repulsion and separation targets this step
  /// applies, in (0, 1]. resolve_step sets it to min(1, Δt / reference_step),
  /// so the velocity those targets give (target / Δt) stays below
  /// thickness / (10 reference_step) however short the step.
  double target_scale = 1.0;
  /// s: the step at which the targets reach their full size (the body's
  /// stable step); 0: never scaled.
  double reference_step = 0.0;
};

/// Several bodies' surfaces resolved as one (collisions between bodies,
/// docs/embedded-surface.md): the "body" given to SelfCollisions is then
/// their concatenation, and each surface vertex and element names its own.
/// Pairs across bodies always count; pairs within a body only if that
/// body's self-collisions are on.
struct CollisionGroups {
  std::vector<std::int32_t> vertex_group;   ///< per surface vertex, its body
  std::vector<std::int32_t> element_group;  ///< per element, its body
  std::vector<std::uint8_t> self_pairs;     ///< per body: pairs within it resolved
  std::vector<double> self_friction;        ///< per body: Coulomb coefficient within it
  double between_friction = 0.0;            ///< Coulomb coefficient between two bodies
};

class SelfCollisions {
 public:
  /// Resolves several bodies at once from now on (nullopt: one body).
  /// A body with an element inverted then waits alone: its own pairs are
  /// left for the step, its pairs with other bodies are not.
  void set_groups(std::optional<CollisionGroups> groups);

  /// Changes the node displacements `d` (#N×3) of a step that starts at node
  /// positions `x0` (#N×3), so that the body's surface, moving linearly from
  /// W x0 to W (x0 + d), does not pass through itself. Nodes flagged in
  /// `fixed` keep their displacement. Deterministic for any thread count.
  SelfCollisionStats resolve(const Body& body, const Points& x0, Points& d, const std::vector<std::uint8_t>& fixed,
                             const SelfCollisionParameters& parameters);

  /// The same for a step of length dt that took the body from node
  /// positions x0 to its current positions: the nodes whose displacement
  /// changes move there, and their velocities change by the same amount
  /// over dt (the impulses' velocity change). Nothing changes, to the bit,
  /// when no impulse was needed. With a reference_step, a step shorter
  /// than it scales the repulsion and separation targets down in proportion.
  SelfCollisionStats resolve_step(Body& body, const Points& x0, double dt, const std::vector<std::uint8_t>& fixed,
                                  const SelfCollisionParameters& parameters);

  /// What the checks after a round's impulses look at again: everything,
  /// or only what the impulses moved (the list's clusters holding a moved
  /// vertex; the surface vertices, elements and calm stars of the moved
  /// nodes), or the latter when at most one node in kFewMoved moved (the
  /// default: with more, a pass over all costs less). The same results,
  /// bit for bit, every way (tests compare them).
  enum class Recheck { everything, what_moved, what_moved_when_few };
  void set_recheck(Recheck recheck) { recheck_ = recheck; }

 private:
  struct Pair {
    std::uint8_t kind;              // ccd::PairKind
    std::array<Index, 4> vertices;  // surface vertices: vertex, triangle; or edge, edge
    double distance;                // at the list's build
  };
  struct Impact {
    std::size_t pair;
    double toi;    // the share of the step at which it comes within its reporting distance
    double start;  // its distance at the step's start
  };
  /// Returns whether the surface's topology changed (the edges are rebuilt).
  bool update_edges(const Triangles& triangles);
  /// The candidate pairs: a list built with each vertex's box grown by its
  /// margin, of the pairs that can come within the thickness while every
  /// vertex stays within its margin of where it was at the build (after the
  /// surface's mean translation); kept while that holds.
  /// Returns whether the list was built anew.
  /// With `changed` (ascending), only those vertices' displacements ds
  /// may differ from the last call's, within the same step.
  bool find_candidates(const Body& body, const Points& x0, const Points& d, const Points& xs0, const Points& ds,
                       double thickness, SelfCollisionStats& stats, const std::vector<Index>* changed = nullptr);
  /// The primitive pairs of triangles A and B the list holds (A's own
  /// vertices against B and B's against A, their own edges against each
  /// other; boxes of the build overlapping), measured at `xs`.
  void expand(const Body& body, Index A, Index B, const Points& xs, double thickness, std::vector<Pair>& out) const;
  /// Lists the pairs of the star groups that stop being safe this step
  /// (CalmStars) for the rest of the list's life. With `moved` (per node),
  /// only stars with a moved node are measured again. Returns whether any
  /// pair was added (the element pairs add_local_pairs appended are dropped).
  /// With `moved_elements` too (the elements with a moved node), only those
  /// are looked at.
  bool list_unsafe_groups(const Body& body, const Points& x0, const Points& d, const std::vector<std::uint8_t>* moved,
                          double thickness, const std::vector<Index>* moved_elements = nullptr);
  /// Whether the pair keeps its place on the list (its body's own pairs
  /// resolved, and within reach of the thickness); `distance` is its gap now.
  bool keep_pair(ccd::PairKind kind, const std::array<Index, 4>& v, const Points& xs0, double thickness,
                 double& distance) const;
  /// The largest motion of a pair's vertex relative to its first one, from
  /// the list's build to the step's start plus over the step (m).
  [[nodiscard]] double relative_motion(const Points& xs0, const Points& ds, const std::array<Index, 4>& v) const;
  /// Whether all four vertices lie in one element.
  [[nodiscard]] static bool one_element(const Body& body, const std::array<Index, 4>& v) {
    const auto& parent = body.embedding.parent;
    const Index e = parent[static_cast<std::size_t>(v[0])];
    return parent[static_cast<std::size_t>(v[1])] == e && parent[static_cast<std::size_t>(v[2])] == e &&
           parent[static_cast<std::size_t>(v[3])] == e;
  }
  /// Per element, whether it stays positively oriented while the nodes move
  /// from x0 to x0 + d.
  /// With `moved` (per node), only elements with a moved node (with
  /// `moved_elements`, those listed: all of them).
  void update_orientations(const Body& body, const Points& x0, const Points& d,
                           const std::vector<std::uint8_t>* moved = nullptr,
                           const std::vector<Index>* moved_elements = nullptr);
  /// Builds the index of each element's surface vertices if the embedding
  /// changed; false (no index) if the body has no node incidence.
  bool index_elements(const Body& body);
  /// Appends the pairs within each element that does not stay positively
  /// oriented (and has none listed yet): the list leaves them out. Measured
  /// at the step's start xs0, with the surface moving by ds over the step.
  void add_local_pairs(const Body& body, const Points& xs0, const Points& ds, double thickness);
  /// Whether the list still holds all the pairs that can come within the
  /// reporting distance: each vertex within its margin of its cluster's
  /// motion, and every two clusters within their allowance, at the step's
  /// start xs0 and end xs0 + ds. Sets drift_ (every vertex's) and
  /// cluster_motion_. With `changed` (ascending), after a check that held
  /// for the same xs0 and the same list, only those vertices' ds may have
  /// changed: only their clusters are measured again (the others' motions,
  /// drifts and allowances are as the last check found them), with the
  /// same result and the same bits as a check of all.
  enum class ListCheck { holds, vertices_past_margins, clusters_parted };
  ListCheck list_holds(const Points& xs0, const Points& ds, const std::vector<Index>* changed = nullptr);
  /// list_holds with `changed`, after a check that held.
  ListCheck list_holds_again(const Points& xs0, const Points& ds, const std::vector<Index>& changed);
  /// Whether clusters a < b's mean motions (cluster_motion_) are within
  /// their allowance of each other at the step's start and end.
  [[nodiscard]] bool clusters_within(Index a, Index b) const;
  /// Sets vertex v's drift (drift_) from its cluster's mean motions; whether
  /// it is within its margin.
  bool measure_drift(const Points& xs0, const Points& ds, Index v);
  /// Keeps a list whose clusters hold but a few of whose vertices drifted
  /// past their margins: widens those margins, grows their primitives'
  /// boxes and lists the pairs the wider boxes reach, as a build with those
  /// margins would. Returns false (nothing listed; a build follows) when
  /// the vertices are too many or a wider margin breaks a far allowance.
  bool extend_list(const Body& body, const Points& ds, double thickness, SelfCollisionStats& stats);
  /// The allowance of clusters a < b: their slacks, or what keeps any two
  /// primitives of theirs beyond the reporting distance when their hulls
  /// lie far apart (set_frames).
  [[nodiscard]] double allowance(Index a, Index b, double thickness) const;
  /// Splits the surface at xs0 into clusters: cluster_, clusters_, cluster_size_.
  void make_clusters(const Points& xs0);
  /// The list's margins, slacks and allowances for a build at xs0, the
  /// surface moving by ds over this step (the triangles those of update_edges).
  void set_frames(const Points& xs0, const Points& ds, double edge_length, double thickness);
  /// Whether all four vertices lie in one cluster of the list.
  [[nodiscard]] bool same_cluster(const std::array<Index, 4>& v) const {
    const Index c = cluster_[static_cast<std::size_t>(v[0])];
    return cluster_[static_cast<std::size_t>(v[1])] == c && cluster_[static_cast<std::size_t>(v[2])] == c &&
           cluster_[static_cast<std::size_t>(v[3])] == c;
  }
  /// Forgets the pairs add_local_pairs appended.
  void drop_local_pairs();
  /// Impacts among the candidates: pairs that come within the thickness
  /// (or half their starting gap) while approaching. With `zone`, pairs whose
  /// nodes all lie in one rigid zone are skipped (their distances cannot
  /// shrink). With `only`, pairs none of whose vertices it flags are skipped.
  /// With `changed` (ascending), only those vertices' displacements may
  /// differ from the last detection's: the others' bookkeeping is left as
  /// it is (it would not change), and with `only` too the pairs measured
  /// are found through the list's index (select_pairs) rather than a pass
  /// over the whole list.
  std::vector<Impact> detect(const Body& body, const Points& xs0, const Points& ds, double thickness,
                             const std::vector<Index>* zone, const std::vector<std::uint8_t>* only,
                             const std::vector<Index>* changed, SelfCollisionStats& stats);
  /// The list's pairs holding one of the `changed` vertices, ascending, into
  /// selected_ (the pairs past the index, appended since it was built,
  /// all). Returns false when they are so many that a pass over the list
  /// costs less.
  bool select_pairs(const std::vector<Index>& changed);

  /// Whether the pair lies within one body (always, without groups).
  [[nodiscard]] bool within(const Pair& pair) const {
    return within(pair.vertices);
  }
  [[nodiscard]] bool within(const std::array<Index, 4>& v) const {
    return !groups_ || group(v) == groups_->vertex_group[static_cast<std::size_t>(v[3])];
  }
  /// The body of the pair's first vertex.
  [[nodiscard]] std::int32_t group(const std::array<Index, 4>& v) const {
    return groups_->vertex_group[static_cast<std::size_t>(v[0])];
  }
  /// The pair's Coulomb coefficient.
  [[nodiscard]] double friction(const Pair& pair, double own) const;

  std::optional<CollisionGroups> groups_;
  // Per element, this step: positively oriented throughout, so that the
  // pairs with all four vertices in it, moved by one invertible affine map,
  // cannot cross (the list leaves them out; add_local_pairs appends those
  // of the other elements after the list's first list_size_ pairs).
  std::vector<std::uint8_t> affine_;
  // A round's moved nodes (ascending), and for finding their elements'
  // surface vertices: each element's vertices (ascending; for the
  // embedding's parents `indexed_parents_`), a stamp per element, a bit
  // per vertex.
  static constexpr Index kFewMoved = 16;  // at most one node in this many: through the index
  std::vector<Index> moved_nodes_;
  std::vector<Index> element_vertex_offsets_, element_vertices_, indexed_parents_;
  std::vector<std::uint32_t> element_stamp_;
  std::uint32_t stamp_ = 0;
  std::vector<std::uint64_t> vertex_bits_;
  std::vector<std::uint8_t> local_;  // per element: its pairs appended this step
  std::size_t list_size_ = 0;
  std::vector<Index> list_parents_;  // each vertex's element when the list was built
  // Node stars the surface cannot cross itself through while they stay
  // calm: their groups' pairs are off the list until they do not.
  CalmStars stars_;
  std::vector<Box3> vertex_boxes_, triangle_boxes_, edge_boxes_;  // the list's build
  std::vector<std::uint8_t> waiting_;  // per group, this step: an element inverted (its own pairs wait)
  Triangles triangles_;                      // the surface the edges below belong to
  std::vector<std::array<Index, 2>> edges_;  // unique surface edges, sorted
  // Per triangle, the vertices and edges it owns (for which it is the
  // lowest triangle holding them), in corner order: each primitive pair is
  // found under the pair of its owners only.
  struct Owned {
    std::array<Index, 3> vertices{}, edges{};
    std::uint8_t num_vertices = 0, num_edges = 0;
  };
  std::vector<Owned> owned_;
  std::vector<Pair> candidates_;
  // Per surface vertex, the list's first indexed_ pairs that hold it
  // (offsets into vertex_pairs_), built when a round first needs it after
  // the list was built; pairs appended later are read past it.
  std::vector<std::size_t> vertex_pair_offsets_;
  std::vector<std::uint32_t> vertex_pairs_;
  std::size_t indexed_ = 0;
  bool index_valid_ = false;
  std::vector<std::uint64_t> pair_marked_;  // a bit per indexed pair: in selected_ (cleared after each selection)
  std::vector<std::size_t> selected_;      // the pairs a round's detection measures
  // What one detection found in each fixed run of kDetectChunk candidates
  // (collected in parallel, read in list order).
  struct Found {
    std::vector<Impact> impacts;
    std::vector<std::pair<std::size_t, double>> close;  // (candidate, distance) closer than the thickness
    std::int64_t measured = 0;
    Index touching = 0;
  };
  std::vector<Found> found_;
  std::vector<std::pair<std::size_t, double>> close_;  // the last detection's, in list order
  // Within a step, a pair measured without impact needs no measuring again
  // until its vertices' displacements have changed by its clearance
  // (ccd::time_of_impact): impulses move the nodes of a few pairs, and with
  // them thousands of surface vertices by far less than that.
  std::vector<double> clearance_;                // per candidate, this step (−∞: to be measured)
  std::vector<std::array<double, 4>> changed_at_;  // per candidate, its vertices' `changed_` when measured
  std::vector<double> changed_;  // per surface vertex, Σ over this step's detections of its displacement's change (max coordinate)
  Points ds_last_;               // the surface displacements of the last detection
  Points list_positions_;       // the surface where the candidate list was built
  std::vector<double> margin_;  // per vertex, how far it may move from its cluster's motion before the list is built again
  std::vector<double> drift_;   // per vertex, how far it has moved from its cluster's motion since (this step's start and end, the larger)
  // The list's frames (docs/embedded-surface.md, "Broad phase"): the surface
  // at the build split into clusters, cells of a coarse grid. Each vertex
  // may drift from its cluster's mean motion by its margin, two clusters'
  // mean motions from each other by their allowance.
  static constexpr Index kMaxClusters = 256;
  std::vector<Index> cluster_;        // per vertex
  std::vector<Index> cluster_size_;   // per cluster, its vertices
  std::vector<Index> cluster_offsets_, cluster_vertices_;  // each cluster's vertices, ascending (at the build)
  Index clusters_ = 0;
  static constexpr int kSlackRounds = 4;
  /// A cluster's slack covers this many times its parting over the build's
  /// step from a cluster whose surface overlaps its own, and two clusters
  /// are allowed twice that; after a list that ended with two clusters
  /// parted, kPartedFactor times up to kPartedCap mean edges (set_frames).
  static constexpr double kPartingFactor = 2.0, kPartedFactor = 8.0, kPartedCap = 0.1;
  double parting_factor_ = kPartingFactor;
  std::vector<double> allowance_;     // clusters_ × clusters_ (a < b: [a × clusters_ + b])
  std::vector<double> slack_;         // per cluster
  std::vector<double> reach_margin_;  // per vertex: its margin and its cluster's slack (the boxes' growth)
  std::vector<Box3> hull_;            // per cluster: the build's triangles with a corner in it
  std::vector<double> largest_;       // per cluster: the largest margin of a corner of those triangles
  std::vector<double> near_;          // per cluster: its slack and the largest of a cluster sharing a triangle with it
  std::array<Points, 2> cluster_motion_;  // per cluster, its mean motion since the build at the step's start and end (list_holds)
  Recheck recheck_ = Recheck::what_moved_when_few;
  bool held_ = false;                          // the last list_holds held, and nothing but ds has changed since
  std::vector<std::uint8_t> cluster_changed_;  // per cluster (list_holds with `changed`)
  std::vector<Index> changed_clusters_;
  std::vector<std::uint8_t> cluster_past_;  // per changed cluster: a vertex past its margin
  std::vector<Index> list_groups_;    // per triangle, its group at the build (overlapping_pairs pairs none within one)
  double list_edge_length_ = 0.0;     // the mean edge at the build
  int extensions_ = 0;                // extend_list's since the build
  bool list_valid_ = false;
};

}  // namespace goo
