#include "meshing/exact_predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <cmath>

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
  // Shewchuk's static filter (orient2d, 1997): in double, with c as the
  // pivot, the sign is certain once |det| exceeds (3 + 16ε) ε (|l| + |r|)
  // (ε = 2⁻⁵³; it bounds the rounding of the differences, the products and
  // the subtraction). Products near underflow, overflow and NaN fail the
  // test and go to CGAL's exact predicate, as does everything close to 0.
  constexpr double kEpsilon = 0x1p-53;
  constexpr double kBound = (3.0 + 16.0 * kEpsilon) * kEpsilon;
  const double l = (a.x() - c.x()) * (b.y() - c.y());
  const double r = (a.y() - c.y()) * (b.x() - c.x());
  const double det = l - r;
  const double sum = std::abs(l) + std::abs(r);
  if (sum > 1e-200) {
    const double bound = kBound * sum;
    if (det > bound) return 1;
    if (-det > bound) return -1;
  }
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
  // Shewchuk's static filter (orient3d, 1997): with d as the pivot,
  // det[a − d, b − d, c − d] = −det[b − a, c − a, d − a] is certain in sign
  // once |det| exceeds (7 + 56ε) ε times its permanent (ε = 2⁻⁵³). Anything
  // closer to 0, and products near underflow, overflow or NaN, go to CGAL.
  constexpr double kEpsilon = 0x1p-53;
  constexpr double kBound = (7.0 + 56.0 * kEpsilon) * kEpsilon;
  const double adx = a.x() - d.x(), bdx = b.x() - d.x(), cdx = c.x() - d.x();
  const double ady = a.y() - d.y(), bdy = b.y() - d.y(), cdy = c.y() - d.y();
  const double adz = a.z() - d.z(), bdz = b.z() - d.z(), cdz = c.z() - d.z();
  const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
  const double cdxady = cdx * ady, adxcdy = adx * cdy;
  const double adxbdy = adx * bdy, bdxady = bdx * ady;
  const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
  const double permanent = (std::abs(bdxcdy) + std::abs(cdxbdy)) * std::abs(adz) +
                           (std::abs(cdxady) + std::abs(adxcdy)) * std::abs(bdz) +
                           (std::abs(adxbdy) + std::abs(bdxady)) * std::abs(cdz);
  if (permanent > 1e-200 && permanent < 1e200) {
    const double bound = kBound * permanent;
    if (det > bound) return -1;
    if (-det > bound) return 1;
  }
  // CGAL: POSITIVE when d, a, b, c ... form a positively oriented tetrahedron,
  // i.e. det[b − a, c − a, d − a] > 0: d on the side the normal points to.
  return static_cast<int>(CGAL::orientation(xyz(a), xyz(b), xyz(c), xyz(d)));
}

}  // namespace goo::exact
