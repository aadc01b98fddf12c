#pragma once
// Surface tension of a body's embedded surface as its nodes feel it (W&T
// sec. 7; algorithms.md, "Surface tension" and "Embedding"). With W the
// embedding operator (x_s = W x):
//   energy    σ A(W x)
//   gradient  Wᵀ σ ∂A/∂x_s            (the node forces are its negative)
//   Hessian   Wᵀ σ ∂²A/∂x_s² W        (per triangle, 9×9 mapped to ≤ 12 nodes)
// and the umbrella smoothing that goes with it, followed by re-embedding.
#include <vector>

#include "core/body.h"
#include "core/elasticity.h"
#include "core/surface_tension.h"
#include "core/surface_topology.h"

namespace goo {

/// Per triangle, the 12 nodes its corners are embedded in (corner k's
/// parent nodes at 4k … 4k+3; a node may repeat) and their weights.
struct SurfaceNodes {
  Eigen::Matrix<Index, Eigen::Dynamic, 12, Eigen::RowMajor> nodes;
  Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor> weights;

  static SurfaceNodes of(const Body& body);
  [[nodiscard]] Index num_triangles() const { return static_cast<Index>(nodes.rows()); }
};

/// ∂²A/∂(a, b, c)² of a triangle's area A = ½|n|, n = (b − a) × (c − a):
///   ½ [ J_nᵀ (I − n̂n̂ᵀ) J_n / |n|  +  Dᵀ [[0, −[n̂]ₓ], [[n̂]ₓ, 0]] D ]
/// with J_n = ∂n/∂(a, b, c) = [[c − b]ₓ, [a − c]ₓ, [b − a]ₓ] and D the map
/// (a, b, c) ↦ (b − a, c − a); the second term is n̂ · ∂²n. Zero for a
/// degenerate triangle (|n| = 0, where A is not differentiable).
Matrix9d triangle_area_hessian(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

class EmbeddedTension {
 public:
  /// Whether the body feels tension: σ > 0 and a surface.
  [[nodiscard]] static bool active(const Body& body);

  /// Adds the node forces −Wᵀ σ ∂A/∂x_s (or W&T's eqs. 6–7 mapped with Wᵀ,
  /// form = paper) at node positions x; in vertex order: deterministic.
  void add_forces(const Body& body, const Points& x, SurfaceTensionForm form, Points& forces);
  /// σ A(W x), J.
  [[nodiscard]] static double energy(const Body& body, const Points& x);
  /// Per triangle, σ ∂²A/∂x_s² at x (9×9); projected to positive
  /// semi-definite (negative eigenvalues clamped) when asked. Parallel.
  static void triangle_hessians(const Body& body, const Points& x, bool project, std::vector<Matrix9d>& out);
  /// One umbrella smoothing step of strength λ on the surface at the body's
  /// positions, then every vertex re-embedded in the mesh.
  void smooth(Body& body, double lambda);

 private:
  /// The surface's topology and the mesh's face adjacency, rebuilt when they change.
  void ensure_topology(const Body& body);

  Triangles topology_of_;  // the triangles the topology was built for
  SurfaceTopology topology_;
  Tets neighbours_of_;  // the tets the adjacency was built for
  Tets neighbours_;
};

}  // namespace goo
