// The Kalman measurement update in Cholesky form, a template on the sizes of its matrices
// (estimator_sizes.hpp). Private to the core.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "estimators/cholesky.hpp"
#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/common/angles.hpp"

namespace networked_estimation
{
namespace detail
{

/// A Kalman update's C P C' + R is not positive definite.
[[noreturn]] void throwNotPositiveDefinite(double trace);

/// Kalman measurement update in Cholesky form: with S = C P C' + R = L L' and W = L^{-1} C P,
///   P+ = P - W'W              (= P - P C' S^{-1} C P, exactly symmetric by construction)
///   x+ = x + W' L^{-1}(y - C x) (= x + K (y - C x), K = P C' S^{-1}; K is never formed)
/// Cancellation guard: when the update removes more than six digits of trace (a long gap of
/// losses on an unstable plant) or leaves a negative diagonal, P+ is recomputed in Joseph form
///   P+ = (I - K C) P (I - K C)' + K R K',
/// which stays positive semidefinite where the subtraction would lose it. The guard costs O(n) on
/// the ordinary path.
///
/// A row of C that is zero, with a unit row and column of R and a zero y, changes nothing: its row
/// of L is a unit row, its rows of W and of the whitened innovation are exact zeros. The fixed-size
/// path uses this to keep C at its compile-time size when some sensors are missing.
/// N states, Rows rows of C (either may be kDynamic).
template <int N, int Rows>
class KalmanUpdate
{
public:
  using MatN = Mat<N, N>;
  using VecN = Mat<N, 1>;
  using MatC = Mat<Rows, N>;
  using MatR = Mat<Rows, Rows>;
  using VecR = Mat<Rows, 1>;

  /// Factorises S for the prior covariance P. Throws DivergenceError when S is not positive
  /// definite (only possible when P has overflowed). C and R must outlive the update's use.
  void factor(const MatN& P, const MatC& C, const MatR& R)
  {
    C_ = &C;
    R_ = &R;
    W_.noalias() = C * P;  // C P
    S_ = R;
    S_.noalias() += W_ * C.transpose();
    if (!chol_.compute(S_))
      throwNotPositiveDefinite(P.trace());
    chol_.solveLower(W_);  // W = L^{-1} C P
  }
  /// How many updates fell back to the Joseph form.
  long josephFallbacks() const { return joseph_; }
  /// E <- L^{-1} E (whitened innovations).
  template <class Derived>
  void whiten(Eigen::MatrixBase<Derived>& E) const
  {
    chol_.solveLower(E);
  }
  /// The rows of C (as given to factor()) that measure an angle: their innovations are wrapped
  /// into (-pi, pi] (docs/algorithms.md 2.7). Null or empty: none. Must outlive the update's use.
  void setAngularRows(const std::vector<int>* rows) { angles_ = rows; }
  /// Wraps the angular rows of innovations y - C x (a vector, or one column per innovation).
  template <class Derived>
  void wrapInnovations(Eigen::MatrixBase<Derived>& E) const
  {
    if (angles_ && !angles_->empty())
      wrapEntries(E, *angles_);
  }
  /// x += W' L^{-1}(y - C x) for the C of factor(); returns the whitened innovation L^{-1}(y - C x)
  /// (the angular rows of y - C x wrapped first).
  template <class VecY>
  const VecR& updateMean(const VecY& y, VecN& x)
  {
    e_ = y;
    e_.noalias() -= (*C_) * x;
    wrapInnovations(e_);
    chol_.solveLower(e_);
    x.noalias() += W_.transpose() * e_;
    return e_;
  }
  /// L^{-1} C v for the C of factor() (aoe: the whitened effect of the command).
  const VecR& whitenedImage(const VecN& v)
  {
    v_.noalias() = (*C_) * v;
    chol_.solveLower(v_);
    return v_;
  }
  /// P <- P - W'W on the lower triangle, then mirrored (P must be the P given to factor()).
  void downdate(MatN& P) const
  {
    const double prior_trace = P.trace();
    prior_ = P;
    // A plain product (coefficient-based for small sizes, GEMM for large ones) is cheaper than
    // selfadjointView().rankUpdate at the sizes of most filters; mirroring makes P exactly symmetric.
    P.noalias() -= W_.transpose() * W_;
    mirrorLower(P);
    if (P.diagonal().minCoeff() < 0.0 || prior_trace > 1e6 * P.trace())
      joseph(P);
  }
  const MatC& W() const { return W_; }

private:
  void joseph(MatN& P) const
  {
    ++joseph_;
    const Eigen::Index n = prior_.rows();
    // K' = S^{-1} C P = L^{-T} W
    MatC Kt = W_;
    chol_.solveUpper(Kt);
    MatN IKC = MatN::Identity(n, n);
    IKC.noalias() -= Kt.transpose() * (*C_);
    P.noalias() = IKC * prior_ * IKC.transpose();
    P.noalias() += Kt.transpose() * (*R_) * Kt;
    symmetrise(P);
  }

  MatR S_;
  MatC W_;
  Cholesky<MatR> chol_;
  VecR e_, v_;
  const MatC* C_ = nullptr;
  const MatR* R_ = nullptr;
  const std::vector<int>* angles_ = nullptr;
  mutable MatN prior_;
  mutable long joseph_ = 0;
};

}  // namespace detail
}  // namespace networked_estimation
