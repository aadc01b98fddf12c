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
  /// A convex polyhedron: its vertices once each, and its faces as lists of
  /// vertex indices, counter-clockwise seen from outside. A piece is the
  /// intersection of a tetrahedron (4 faces) and one slab of each family
  /// sliced so far (2 faces each): at most 16 faces, so at most 28 vertices
  /// (2F − 4) and 15 vertices a face.
  struct Piece {
    static constexpr int kVertices = 32, kFaces = 16, kFaceVertices = 16;
    std::array<Eigen::Vector3d, kVertices> v;
    std::array<std::array<std::uint8_t, kFaceVertices>, kFaces> face;
    std::array<std::uint8_t, kFaces> face_size;
    int num_vertices = 0, num_faces = 0;
  };

  /// A split's edge crossings by edge (lo × Piece::kVertices + hi), found
  /// again from an edge's second face: valid where stamped with the
  /// split's generation (no clearing between splits).
  struct Crossings {
    std::array<std::uint32_t, Piece::kVertices * Piece::kVertices> stamp{};
    std::array<std::uint8_t, Piece::kVertices * Piece::kVertices> index{};
    std::uint32_t generation = 0;
    /// A new split: every stamp stale (cleared only when the count wraps).
    void next() {
      if (++generation == 0) {
        stamp.fill(0);
        generation = 1;
      }
    }
  };

  /// The volume of the positively oriented tetrahedron x in each lattice
  /// tetrahedron it overlaps, as (key, volume in m³) with volume > 0, keys
  /// increasing and each once (a tetrahedron of the block only; parts
  /// outside the block are dropped). Vertices within `tolerance` (in units
  /// of the spacing) of a plane count as on it, so a face lying on a lattice
  /// plane cuts nothing off. Exact up to round-off.
  void overlaps(const BccLattice& lattice, const std::array<Eigen::Vector3d, 4>& x, double tolerance,
                std::vector<std::pair<BccLattice::Key, double>>& out);

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
  std::vector<Piece> pool_;
  std::size_t pool_count_ = 0;
  std::vector<std::size_t> current_, next_;
  std::vector<Face> polygons_;
  Crossings crossings_;
};

}  // namespace goo
