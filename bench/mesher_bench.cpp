// goo's mesh generation and re-mesh against CGAL's Mesh_3 on a real model,
// at a target tet count: the in-process half of the mesher comparison
// (scripts/bench runs TetGen and gmsh as commands beside it).
//
//   goo_mesher_bench goo  MODEL TARGET_TETS REPETITIONS
//   goo_mesher_bench cgal MODEL TARGET_TETS REPETITIONS
//
// Prints one JSON object: the tets made, every repetition's seconds, and
// the worst dihedral angles of the mesh. CGAL's size parameter is first
// calibrated (untimed) until its tet count is within 15% of the target.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_3.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/make_mesh_3.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include "bench/bench_models.h"
#include "core/error.h"
#include "io/surface_mesh_io.h"
#include "meshing/lattice_mesh.h"

namespace {

using Clock = std::chrono::steady_clock;

double seconds_of(const std::function<void()>& f) {
  const auto start = Clock::now();
  f();
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// The smallest and largest dihedral angles (degrees) over all tetrahedra.
struct Dihedrals {
  double min = 180.0, max = 0.0;
  void add(const Eigen::Vector3d p[4]) {
    // The dihedral angle at edge (i, j) is between the faces that share it.
    static constexpr int kEdges[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2},
                                         {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
    for (const auto& e : kEdges) {
      const Eigen::Vector3d axis = (p[e[1]] - p[e[0]]).normalized();
      Eigen::Vector3d u = p[e[2]] - p[e[0]], w = p[e[3]] - p[e[0]];
      u -= u.dot(axis) * axis;
      w -= w.dot(axis) * axis;
      const double angle = std::atan2(u.cross(w).norm(), u.dot(w)) * 180.0 / std::numbers::pi;
      min = std::min(min, angle);
      max = std::max(max, angle);
    }
  }
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void print(const std::string& mesher, const std::string& model, double target, long tets,
           const std::vector<double>& seconds, const Dihedrals& d, const std::string& extra = "") {
  std::cout << fmt::format(
      R"({{"mesher": "{}", "model": "{}", "target_tets": {}, "tets": {}, "seconds": [{:.6g}], "median_seconds": {:.6g}, "tets_per_second": {:.6g}, "min_dihedral_degrees": {:.4g}, "max_dihedral_degrees": {:.4g}{}}})",
      mesher, model, target, tets, fmt::join(seconds, ", "), median(seconds),
      static_cast<double>(tets) / median(seconds), d.min, d.max, extra)
            << "\n";
}

int run_goo(const goo::TriangleMesh& mesh, const std::string& model, double target, int reps) {
  const double h = goo::bench::spacing_for(mesh, target);
  // Mesh generation as W&T sec. 5 counts it: lattice tets kept around the
  // surface, and the surface embedded in them.
  std::vector<double> generate, first_mesh, remesh;
  long tets = 0;
  for (int r = 0; r < reps; ++r)
    generate.push_back(seconds_of([&] {
      const goo::LatticeMesh lm = goo::build_lattice_mesh(mesh, h);
      const goo::Embedding em = goo::embed(lm, mesh.vertices);
      tets = lm.mesh.num_elements();
    }));
  // A body's first mesh: the above plus exact sub-element masses.
  for (int r = 0; r < reps; ++r)
    first_mesh.push_back(seconds_of([&] { const goo::MeshedBody mb = goo::mesh_body(mesh, goo::Material{}, h); }));
  // A whole re-mesh of a deformed, moving body: new mesh, state transfer,
  // exact masses, conservation, re-embedding.
  const goo::MeshedBody deformed = goo::bench::deformed_body(mesh, h);
  const goo::TriangleMesh surface = deformed.surface();
  for (int r = 0; r < reps; ++r)
    remesh.push_back(seconds_of([&] { const goo::MeshedBody next = goo::remesh(deformed.body, surface, h); }));
  const goo::LatticeMesh lm = goo::build_lattice_mesh(mesh, h);
  Dihedrals d;
  for (goo::Index e = 0; e < lm.mesh.num_elements(); ++e) {
    Eigen::Vector3d p[4];
    for (int k = 0; k < 4; ++k) p[k] = lm.mesh.positions.row(lm.mesh.tets(e, k)).transpose();
    d.add(p);
  }
  print("goo", model, target, tets, generate, d,
        fmt::format(R"(, "spacing": {:.6g}, "mesh_body_median_seconds": {:.6g}, "remesh_seconds": [{:.6g}], "remesh_median_seconds": {:.6g})",
                    h, median(first_mesh), fmt::join(remesh, ", "), median(remesh)));
  return 0;
}

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Polyhedron = CGAL::Surface_mesh<K::Point_3>;
using Domain = CGAL::Polyhedral_mesh_domain_3<Polyhedron, K>;
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;

int run_cgal(const goo::TriangleMesh& mesh, const std::string& model, double target, int reps) {
  Polyhedron polyhedron;
  std::vector<Polyhedron::Vertex_index> vertices;
  for (goo::Index v = 0; v < mesh.num_vertices(); ++v)
    vertices.push_back(polyhedron.add_vertex(K::Point_3(mesh.vertices(v, 0), mesh.vertices(v, 1), mesh.vertices(v, 2))));
  for (goo::Index t = 0; t < mesh.num_triangles(); ++t)
    polyhedron.add_face(vertices[static_cast<std::size_t>(mesh.triangles(t, 0))],
                        vertices[static_cast<std::size_t>(mesh.triangles(t, 1))],
                        vertices[static_cast<std::size_t>(mesh.triangles(t, 2))]);
  // One size s for facets and cells (the surface may be coarsened to it),
  // approximation 0.1 s, CGAL's usual angle and shape bounds; defaults
  // otherwise (perturbation and exudation on), as a user would call it.
  const double volume = goo::analyze_surface(mesh).volume;
  double size = std::cbrt(8.5 * volume / target);  // a regular tet of edge s has volume s³/8.5
  auto make = [&](double s) {
    const Domain domain(polyhedron);
    namespace p = CGAL::parameters;
    const Criteria criteria(p::facet_angle = 25, p::facet_size = s, p::facet_distance = 0.1 * s,
                            p::cell_radius_edge_ratio = 3, p::cell_size = s);
    return CGAL::make_mesh_3<C3t3>(domain, criteria);
  };
  long tets = 0;
  for (int attempt = 0; attempt < 6; ++attempt) {
    tets = static_cast<long>(make(size).number_of_cells_in_complex());
    const double ratio = static_cast<double>(tets) / target;
    if (std::abs(ratio - 1.0) < 0.15) break;
    size *= std::cbrt(ratio);
  }
  std::vector<double> seconds;
  C3t3 c3t3;
  for (int r = 0; r < reps; ++r) seconds.push_back(seconds_of([&] { c3t3 = make(size); }));
  tets = static_cast<long>(c3t3.number_of_cells_in_complex());
  Dihedrals d;
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    Eigen::Vector3d p[4];
    for (int k = 0; k < 4; ++k) {
      const auto& q = c->vertex(k)->point().point();
      p[k] = Eigen::Vector3d(q.x(), q.y(), q.z());
    }
    d.add(p);
  }
  print("cgal_mesh3", model, target, tets, seconds, d, fmt::format(R"(, "size": {:.6g})", size));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: goo_mesher_bench goo|cgal MODEL TARGET_TETS REPETITIONS\n";
    return 2;
  }
  try {
    const std::string which = argv[1], path = argv[2];
    const double target = std::stod(argv[3]);
    const int reps = std::stoi(argv[4]);
    const goo::TriangleMesh mesh = goo::io::read_surface_mesh(path);
    const std::string model = std::filesystem::path(path).stem().string();
    if (which == "goo") return run_goo(mesh, model, target, reps);
    if (which == "cgal") return run_cgal(mesh, model, target, reps);
    std::cerr << "goo_mesher_bench: unknown mesher '" << which << "' (goo or cgal)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "goo_mesher_bench: " << e.what() << "\n";
    return 2;
  }
}
