// Rows, columns and blocks of a matrix picked by a list of indices (Eigen 3.4 has an index-list
// syntax for this; Eigen 3.3, ROS Noetic's, does not, so the package spells it out here).
#pragma once

#include <Eigen/Core>

#include <vector>

namespace networked_estimation
{

/// M(rows[0..], :), as a plain matrix of M's scalar type.
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, Eigen::Dynamic> selectRows(const Eigen::MatrixBase<Derived>& M,
                                                                                   const std::vector<int>& rows)
{
  Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, Eigen::Dynamic> out(rows.size(), M.cols());
  for (std::size_t i = 0; i < rows.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = M.row(rows[i]);
  return out;
}

/// M(:, cols[0..]).
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, Eigen::Dynamic> selectCols(const Eigen::MatrixBase<Derived>& M,
                                                                                   const std::vector<int>& cols)
{
  Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, Eigen::Dynamic> out(M.rows(), cols.size());
  for (std::size_t j = 0; j < cols.size(); ++j)
    out.col(static_cast<Eigen::Index>(j)) = M.col(cols[j]);
  return out;
}

/// M(rows[0..], cols[0..]).
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, Eigen::Dynamic> selectBlock(const Eigen::MatrixBase<Derived>& M,
                                                                                    const std::vector<int>& rows,
                                                                                    const std::vector<int>& cols)
{
  Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, Eigen::Dynamic> out(rows.size(), cols.size());
  for (std::size_t i = 0; i < rows.size(); ++i)
    for (std::size_t j = 0; j < cols.size(); ++j)
      out(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = M(rows[i], cols[j]);
  return out;
}

/// v(idx[0..]) of a vector.
template <typename Derived>
Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, 1> selectEntries(const Eigen::MatrixBase<Derived>& v,
                                                                         const std::vector<int>& idx)
{
  Eigen::Matrix<typename Derived::Scalar, Eigen::Dynamic, 1> out(idx.size());
  for (std::size_t i = 0; i < idx.size(); ++i)
    out(static_cast<Eigen::Index>(i)) = v(idx[i]);
  return out;
}

}  // namespace networked_estimation
