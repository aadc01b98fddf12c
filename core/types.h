#pragma once
// Vocabulary types shared by every module.
#include <Eigen/Core>
#include <cstdint>

namespace goo {

/// Node, element, vertex and triangle ids: 32-bit signed (architecture.md).
using Index = std::int32_t;

/// #P×3 points, one per row, metres.
using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #T×3 vertex ids of triangles, one per row.
using Triangles = Eigen::Matrix<Index, Eigen::Dynamic, 3, Eigen::RowMajor>;

}  // namespace goo
