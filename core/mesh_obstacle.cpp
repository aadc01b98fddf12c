// The triangle-mesh obstacle: the only translation unit of core that
// includes CGAL (architecture.md: CGAL headers compile slowly).
#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include "core/obstacles.h"
#include "core/surface_check.h"

namespace goo {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Primitive = CGAL::AABB_face_graph_triangle_primitive<Mesh>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
using Inside = CGAL::Side_of_triangle_mesh<Mesh, Kernel>;

class MeshShape final : public Shape {
 public:
  explicit MeshShape(const TriangleMesh& surface) : surface_(surface) {
    std::vector<Mesh::Vertex_index> v;
    v.reserve(static_cast<std::size_t>(surface.num_vertices()));
    for (Index i = 0; i < surface.num_vertices(); ++i)
      v.push_back(mesh_.add_vertex(Point(surface.vertices(i, 0), surface.vertices(i, 1), surface.vertices(i, 2))));
    for (Index t = 0; t < surface.num_triangles(); ++t)
      mesh_.add_face(v[static_cast<std::size_t>(surface.triangles(t, 0))],
                     v[static_cast<std::size_t>(surface.triangles(t, 1))],
                     v[static_cast<std::size_t>(surface.triangles(t, 2))]);
    tree_.insert(faces(mesh_).first, faces(mesh_).second, mesh_);
    tree_.build();
    tree_.accelerate_distance_queries();
    // Side_of_triangle_mesh shares the tree; queries are const from here on,
    // so they may run in parallel.
    inside_ = std::make_unique<Inside>(tree_);
    const auto box = tree_.bbox();
    bounds_ = {Eigen::Vector3d(box.xmin(), box.ymin(), box.zmin()), Eigen::Vector3d(box.xmax(), box.ymax(), box.zmax())};
  }

  SignedDistance signed_distance(const Eigen::Vector3d& p) const override {
    const Point q(p.x(), p.y(), p.z());
    const auto [closest, face] = tree_.closest_point_and_primitive(q);
    const Eigen::Vector3d c(closest.x(), closest.y(), closest.z());
    const CGAL::Bounded_side side = (*inside_)(q);
    const double d = (p - c).norm();
    Eigen::Vector3d n;
    if (d > 1e-12 * (bounds_.diagonal().norm() + 1.0)) {
      n = (side == CGAL::ON_BOUNDED_SIDE ? c - p : p - c) / d;
    } else {
      // On the surface: the face's normal.
      const auto h = mesh_.halfedge(face);
      const Point& a = mesh_.point(mesh_.source(h));
      const Point& b = mesh_.point(mesh_.target(h));
      const Point& e = mesh_.point(mesh_.target(mesh_.next(h)));
      const Eigen::Vector3d ab(b.x() - a.x(), b.y() - a.y(), b.z() - a.z());
      const Eigen::Vector3d ae(e.x() - a.x(), e.y() - a.y(), e.z() - a.z());
      n = ab.cross(ae).normalized();
    }
    if (side == CGAL::ON_BOUNDARY) return {0.0, n};
    return {side == CGAL::ON_BOUNDED_SIDE ? -d : d, n};
  }

  Eigen::AlignedBox3d bounds() const override { return bounds_; }
  TriangleMesh boundary() const override { return surface_; }

 private:
  TriangleMesh surface_;
  Mesh mesh_;
  Tree tree_;
  std::unique_ptr<Inside> inside_;
  Eigen::AlignedBox3d bounds_;
};

}  // namespace

std::shared_ptr<const Shape> make_mesh_shape(const TriangleMesh& mesh, const std::string& source) {
  TriangleMesh checked = mesh;
  validate_surface(checked, source);  // closed, manifold, outward (flipped if inside-out)
  return std::make_shared<MeshShape>(checked);
}

}  // namespace goo
