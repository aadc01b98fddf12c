#include "meshing/exact_predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

namespace goo::exact {
namespace {
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
Kernel::Point_2 xy(const Eigen::Vector3d& p) {
  return {p.x(), p.y()};
}
Kernel::Point_3 xyz(const Eigen::Vector3d& p) {
  return {p.x(), p.y(), p.z()};
}
}  // namespace

int orient_xy(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return static_cast<int>(CGAL::orientation(xy(a), xy(b), xy(c)));
}

int orient_yz(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return static_cast<int>(
      CGAL::orientation(Kernel::Point_2(a.y(), a.z()), Kernel::Point_2(b.y(), b.z()), Kernel::Point_2(c.y(), c.z())));
}

int orient_zx(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  return static_cast<int>(
      CGAL::orientation(Kernel::Point_2(a.z(), a.x()), Kernel::Point_2(b.z(), b.x()), Kernel::Point_2(c.z(), c.x())));
}

int orient_3d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
  // CGAL: POSITIVE when d, a, b, c ... form a positively oriented tetrahedron,
  // i.e. det[b − a, c − a, d − a] > 0: d on the side the normal points to.
  return static_cast<int>(CGAL::orientation(xyz(a), xyz(b), xyz(c), xyz(d)));
}

}  // namespace goo::exact
