#pragma once
// Surfaces the lattice tests mesh: the hard cases (a cube on lattice corner
// planes, one on cell-centre planes, a tilted sheet a hundredth of the
// spacing thick) and the real models when scripts/fetch-assets has run.
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/primitives.h"
#include "core/surface_geometry.h"
#include "io/surface_mesh_io.h"
#include "tests/common/test_common.h"

namespace goo::test {

struct Case {
  std::string name;
  TriangleMesh surface;
  double h;
};

inline std::vector<Case> lattice_cases() {
  std::vector<Case> out;
  out.push_back({"sphere", make_sphere(1.0, 24), 0.2});
  TriangleMesh cube = make_box(Eigen::Vector3d::Ones(), 4);
  cube.vertices.rowwise() += Eigen::RowVector3d::Constant(0.5);  // faces on planes of lattice corners
  out.push_back({"aligned_cube", cube, 0.25});
  TriangleMesh centred = make_box(Eigen::Vector3d::Ones(), 3);
  centred.vertices.rowwise() += Eigen::RowVector3d(0.625, 0.625, 0.625);  // faces on planes of cell centres
  out.push_back({"centre_aligned_cube", centred, 0.25});
  // A sheet a hundredth of the spacing thick, tilted: no lattice node inside.
  TriangleMesh sheet = make_box({1.0, 0.8, 0.002}, 3);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
  sheet.vertices = (sheet.vertices * R.transpose()).rowwise() + Eigen::RowVector3d(0.013, -0.021, 0.007);
  out.push_back({"thin_sheet", sheet, 0.2});
  for (const char* file : {"bunny00.off", "armadillo.off"}) {
    const auto path = test::asset(file);
    if (!std::filesystem::exists(path)) continue;
    TriangleMesh model = io::read_surface_mesh(path);
    // A spacing for about 10⁴ elements (12 per cell volume h³).
    const double h = std::cbrt(12.0 * surface_integrals(model).volume / 1e4);
    out.push_back({file, std::move(model), h});
  }
  return out;
}

}  // namespace goo::test
