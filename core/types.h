#pragma once
// Vocabulary types shared by every module.
#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products
#include <Eigen/LU>        // inverse() and determinant() of the small fixed-size matrices
#include <cstdint>

namespace goo {

/// Node, element, vertex and triangle ids: 32-bit signed (architecture.md).
using Index = std::int32_t;

/// #P×3 points, one per row, metres.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #T×3 vertex ids of triangles, one per row.
using Triangles = Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor>;

}  // namespace goo

namespace goo {

/// #E×4 node ids of tetrahedra, one per row, positively oriented:
/// det[x1−x0, x2−x0, x3−x0] > 0.
using Tets = Eigen::Matrix<Index, Eigen::Dynamic, 4, Eigen::RowMajor>;

}  // namespace goo
