// Small numerics of the estimators: symmetric P (mirrorLower, symmetrise), a command's input
// (applyInput) and the Cholesky factorisation the updates solve with. Private to the core.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <type_traits>

#include "estimators/estimator_sizes.hpp"

namespace networked_estimation
{
namespace detail
{

/// Copies the lower triangle into the upper one: P becomes exactly symmetric.
template <class Derived>
inline void mirrorLower(Eigen::MatrixBase<Derived>& P)
{
  P.template triangularView<Eigen::StrictlyUpper>() = P.transpose();
}

/// P <- (P + P') / 2.
template <class Derived>
inline void symmetrise(Eigen::MatrixBase<Derived>& P)
{
  const Eigen::Index n = P.rows();
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index i = j + 1; i < n; ++i)
    {
      const double v = 0.5 * (P(i, j) + P(j, i));
      P(i, j) = v;
      P(j, i) = v;
    }
}

/// out <- M u for an input u of dynamic size p (M's rows may be fixed): column by column, so that
/// each term is a fixed-size axpy (a product with a dynamic inner size would loop over it per
/// coefficient, or take the general GEMV).
template <class Out, class Derived>
inline void applyInput(Eigen::PlainObjectBase<Out>& out, const Eigen::MatrixBase<Derived>& M, const Eigen::VectorXd& u)
{
  out.setZero(M.rows());
  for (Eigen::Index j = 0; j < u.size(); ++j)
    out.noalias() += M.col(j) * u[j];
}

/// Cholesky factorisation S = L L' of a symmetric matrix (lower triangle read), and solves with L.
/// Plain loops up to 8 x 8 (the sizes of most filters, where Eigen's blocked LLT and triangular
/// solvers cost more than the arithmetic, and fixed sizes unroll), Eigen's LLT beyond (only
/// reachable with dynamic sizes).
template <class MatrixType>
class Cholesky
{
  static constexpr int kMaxRows = MatrixType::MaxRowsAtCompileTime;
  static constexpr bool kSmallOnly = kMaxRows != Eigen::Dynamic && kMaxRows <= 8;

public:
  /// Returns false when S is not positive definite (a pivot <= 0, as Eigen's LLT decides).
  bool compute(const MatrixType& S) { return compute(S, S.rows()); }

  /// compute(S) for an S whose rows and columns from `active` on are those of the identity (the
  /// padding of the fixed-size path): their part of the factor is the identity too, exactly as
  /// compute(S) would find it, so only the leading active x active block is factorised.
  bool compute(const MatrixType& S, Eigen::Index active)
  {
    if constexpr (!kSmallOnly)
    {
      small_ = S.rows() <= 8;
      if (!small_)
      {
        llt_.compute(S);
        return llt_.info() == Eigen::Success;
      }
    }
    L_ = S;
    const Eigen::Index n = active;
    inv_.resize(L_.rows());
    for (Eigen::Index j = n; j < L_.rows(); ++j)
      inv_[j] = 1.0;
    for (Eigen::Index j = 0; j < n; ++j)
    {
      double d = L_(j, j);
      for (Eigen::Index k = 0; k < j; ++k)
        d -= L_(j, k) * L_(j, k);
      if (d <= 0.0)
        return false;
      d = std::sqrt(d);
      L_(j, j) = d;
      inv_[j] = 1.0 / d;  // the solves multiply: one division per pivot, not one per use
      for (Eigen::Index i = j + 1; i < n; ++i)
      {
        double v = L_(i, j);
        for (Eigen::Index k = 0; k < j; ++k)
          v -= L_(i, k) * L_(j, k);
        L_(i, j) = v * inv_[j];
      }
    }
    return true;
  }

  /// B <- L^{-1} B.
  template <class Derived>
  void solveLower(Eigen::MatrixBase<Derived>& B) const
  {
    if constexpr (!kSmallOnly)
    {
      if (!small_)
      {
        llt_.matrixL().solveInPlace(B);
        return;
      }
    }
    const Eigen::Index m = L_.rows();
    for (Eigen::Index j = 0; j < B.cols(); ++j)
      for (Eigen::Index i = 0; i < m; ++i)
      {
        double v = B(i, j);
        for (Eigen::Index k = 0; k < i; ++k)
          v -= L_(i, k) * B(k, j);
        B(i, j) = v * inv_[i];
      }
  }

  /// B <- L^{-T} B.
  template <class Derived>
  void solveUpper(Eigen::MatrixBase<Derived>& B) const
  {
    if constexpr (!kSmallOnly)
    {
      if (!small_)
      {
        llt_.matrixU().solveInPlace(B);
        return;
      }
    }
    const Eigen::Index m = L_.rows();
    for (Eigen::Index j = 0; j < B.cols(); ++j)
      for (Eigen::Index i = m - 1; i >= 0; --i)
      {
        double v = B(i, j);
        for (Eigen::Index k = i + 1; k < m; ++k)
          v -= L_(k, i) * B(k, j);
        B(i, j) = v * inv_[i];
      }
  }

private:
  MatrixType L_;                                                        ///< L in the lower triangle (small factors)
  Mat<MatrixType::RowsAtCompileTime, 1> inv_;                           ///< 1 / L(i, i)
  std::conditional_t<kSmallOnly, bool, Eigen::LLT<MatrixType>> llt_{};  ///< larger factors
  bool small_ = true;
};

}  // namespace detail
}  // namespace networked_estimation
