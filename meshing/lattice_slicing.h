#pragma once
// A tetrahedron cut into its parts in each lattice tetrahedron by slicing
// along the lattice's planes. Every face of a BCC lattice tetrahedron lies
// on a plane u_a ± u_b = k (u = (x − o) / h, integer k, a ≠ b), and no such
// plane crosses one: the lattice tetrahedra are the cells of the
// arrangement of these six families of planes. Slicing a convex polyhedron
// by every plane of each family in turn leaves pieces that each lie in one
// lattice tetrahedron, with no search for candidates and no pair of
// tetrahedra clipped against each other.
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/types.h"
#include "meshing/bcc_lattice.h"
#include "meshing/convex_clip.h"

namespace goo {

/// The overlaps of the positively oriented tetrahedron x with the block's
/// tetrahedra the slow way, as LatticeSlicer::overlaps gives them: every
/// lattice tetrahedron near x's box clipped against x (tet_overlap_volume),
/// volumes > 0 kept, keys increasing. Nothing for x not finite.
void overlaps_by_clipping(const BccLattice& lattice, const std::array<Eigen::Vector3d, 4>& x, double tolerance,
                          std::vector<std::pair<BccLattice::Key, double>>& out);

/// A convex polygon's part in one lattice tetrahedron.
struct PolygonPart {
  BccLattice::Key key;
  Polygon polygon;  ///< world coordinates, the input's orientation
};

/// The slicing, with its scratch space (reused from call to call: keep one
/// per thread).
class LatticeSlicer {
 public:
  /// A convex polygon, for the polygons' slicing: a clipped triangle's part
  /// of the slabs of every family has at most 3 + 2 × 6 vertices.
  struct Face {
    static constexpr int kCapacity = 16;
    std::array<Eigen::Vector3d, kCapacity> v;
    int size = 0;
  };
  /// A convex polyhedron as the graph of its vertices and edges, each vertex
  /// with exactly three neighbours (Powell & Abel 2015's representation): a
  /// cut by a plane keeps every vertex at three, since a new vertex on a cut
  /// edge has that edge's kept end and its two neighbours along the cap.
  /// `next[i]` lists vertex i's neighbours counter-clockwise seen from
  /// outside, so a face is walked by leaving each vertex along the edge
  /// before the one it was reached by; `back[i][m]` is where i is in the
  /// list of its neighbour next[i][m], so the walk needs no search. A piece
  /// is a tetrahedron (4 faces) cut by at most two planes of each family
  /// (one cap each): at most 16 faces, and a graph with three edges a vertex
  /// and F faces has 2F − 4 vertices, so at most 28 (where a plane passes
  /// through a vertex, the copies it leaves at the same point count the
  /// same way).
  struct Piece {
    static constexpr int kVertices = 32;
    std::array<Eigen::Vector3d, kVertices> v;
    std::array<std::array<std::uint8_t, 3>, kVertices> next, back;
    int num_vertices = 0;
  };

  /// The volume of the positively oriented tetrahedron x in each lattice
  /// tetrahedron it overlaps, as (key, volume in m³) with volume > 0, keys
  /// increasing and each once (a tetrahedron of the block only; parts
  /// outside the block are dropped). Vertices within `tolerance` (in units
  /// of the spacing) of a plane count as on it, so a face lying on a lattice
  /// plane cuts nothing off. Exact up to round-off.
  /// If a cut ever leaves a piece the graph cannot hold (round-off making
  /// a plane meet a piece's edges in more than one loop), the tetrahedron's
  /// overlaps are taken by overlaps_by_clipping instead, and counted.
  void overlaps(const BccLattice& lattice, const std::array<Eigen::Vector3d, 4>& x, double tolerance,
                std::vector<std::pair<BccLattice::Key, double>>& out);
  /// Tetrahedra whose overlaps were taken by clipping since construction.
  [[nodiscard]] std::size_t fallbacks() const { return fallbacks_; }

  /// The parts of the convex polygon `polygon` (world coordinates, at most
  /// 7 vertices: a clipped triangle's part in a tetrahedron is at most a
  /// heptagon) in each lattice tetrahedron of the block, in a fixed order
  /// (slicing order), parts of no area or outside the block dropped.
  /// Vertices within `tolerance` (in units of the spacing) of a plane count
  /// as on it.
  void polygon_parts(const BccLattice& lattice, const Polygon& polygon, double tolerance,
                     std::vector<PolygonPart>& out);

 private:
  void reserve(std::size_t more);
  void reserve_polygons(std::size_t count);
  std::vector<Piece> pool_;
  std::size_t pool_count_ = 0;
  std::vector<std::size_t> current_, next_;
  std::vector<Face> polygons_;
  std::size_t fallbacks_ = 0;
};

}  // namespace goo
