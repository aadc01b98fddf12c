#pragma once
// Exact orientation predicates (CGAL's filtered kernel; the one translation
// unit of goo::meshing that includes CGAL). Each returns −1, 0 or +1, exact
// for any finite double input.
#include <Eigen/Core>

namespace goo::exact {

/// Sign of (b − a) × (c − a) in the xy plane: +1 if a, b, c turn
/// counter-clockwise seen from +z.
int orient_xy(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// The same in the yz and zx planes: the exact signs of the x and y
/// components of (b − a) × (c − a).
int orient_yz(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);
int orient_zx(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// Sign of (d − a) · ((b − a) × (c − a)): +1 if d is on the side of the plane
/// the normal (b − a) × (c − a) points to.
int orient_3d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, const Eigen::Vector3d& d);

}  // namespace goo::exact
