// Private building blocks shared by the estimators: sensor selection, the Kalman measurement
// update in Cholesky form, and the base class holding the model and the estimate.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{
namespace detail
{

/// Copies the lower triangle into the upper one: P becomes exactly symmetric.
inline void mirrorLower(Eigen::MatrixXd& P)
{
  P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
}

/// P <- (P + P') / 2.
inline void symmetrise(Eigen::MatrixXd& P)
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

/// B <- L^{-1} B for the Cholesky factor L of `llt`. Plain forward substitution for small factors
/// (the sizes of most filters, where Eigen's blocked solver costs more than the arithmetic),
/// Eigen's solver beyond.
template <class Derived>
inline void solveLower(const Eigen::LLT<Eigen::MatrixXd>& llt, Eigen::MatrixBase<Derived>& B)
{
  const Eigen::MatrixXd& L = llt.matrixLLT();  // L in the lower triangle
  const Eigen::Index m = L.rows();
  if (m > 8)
  {
    llt.matrixL().solveInPlace(B);
    return;
  }
  for (Eigen::Index j = 0; j < B.cols(); ++j)
    for (Eigen::Index i = 0; i < m; ++i)
    {
      double v = B(i, j);
      for (Eigen::Index k = 0; k < i; ++k)
        v -= L(i, k) * B(k, j);
      B(i, j) = v / L(i, i);
    }
}

/// Which sensors of a sample are fused, and the stacked rows (C, R, y) of those sensors.
/// When every sensor arrived the model's own matrices are used (no copy).
class ArrivalSelector
{
public:
  explicit ArrivalSelector(const Model& model);

  /// Validates the sample's sizes and decides the arrived sensors; sensor s arrives iff
  /// (gamma or ignore_gamma) and its block is finite. Returns the number of arrived rows.
  /// Throws InputError for a wrong size, an infinite cell or a partly missing block.
  int select(const Sample& sample, bool ignore_gamma);

  /// Checks u's size (empty = zero input). Throws InputError.
  void checkInput(const Sample& sample) const;

  bool all() const { return all_; }
  int rows() const { return rows_; }
  const std::vector<int>& arrivedRows() const { return idx_; }
  const Eigen::MatrixXd& C() const { return all_ ? model_.C : Ca_; }
  const Eigen::MatrixXd& R() const { return all_ ? model_.R : Ra_; }
  /// The arrived part of y (valid after select()).
  const Eigen::VectorXd& y() const { return ya_; }

private:
  Model model_;  ///< own copy (small), so that estimators can be copied (Estimator::clone)
  std::vector<int> idx_;
  Eigen::MatrixXd Ca_, Ra_;
  Eigen::VectorXd ya_;
  std::vector<int> last_idx_;
  bool all_ = false;
  int rows_ = 0;
};

/// Kalman measurement update in Cholesky form: with S = C P C' + R = L L' and W = L^{-1} C P,
///   P+ = P - W'W              (= P - P C' S^{-1} C P, exactly symmetric by construction)
///   x+ = x + W' L^{-1}(y - C x) (= x + K (y - C x), K = P C' S^{-1}; K is never formed)
/// Cancellation guard: when the update removes more than six digits of trace (a long gap of
/// losses on an unstable plant) or leaves a negative diagonal, P+ is recomputed in Joseph form
///   P+ = (I - K C) P (I - K C)' + K R K',
/// which stays positive semidefinite where the subtraction would lose it. The guard costs O(n) on
/// the ordinary path.
class KalmanUpdate
{
public:
  /// Factorises S for the prior covariance P. Throws DivergenceError when S is not positive
  /// definite (only possible when P has overflowed).
  void factor(const Eigen::MatrixXd& P, const Eigen::MatrixXd& C, const Eigen::MatrixXd& R);
  /// How many updates fell back to the Joseph form.
  long josephFallbacks() const { return joseph_; }
  /// e <- L^{-1} e (whitened innovation).
  void whiten(Eigen::VectorXd& e) const { solveLower(llt_, e); }
  void whiten(Eigen::MatrixXd& E) const { solveLower(llt_, E); }
  /// P <- P - W'W on the lower triangle, then mirrored (P must be the P given to factor()).
  void downdate(Eigen::MatrixXd& P) const;
  const Eigen::MatrixXd& W() const { return W_; }

private:
  void joseph(Eigen::MatrixXd& P) const;

  Eigen::MatrixXd S_, W_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  const Eigen::MatrixXd* C_ = nullptr;
  const Eigen::MatrixXd* R_ = nullptr;
  mutable Eigen::MatrixXd prior_;
  mutable long joseph_ = 0;
};

/// Shared state of the linear-Gaussian estimators.
class EstimatorBase : public Estimator
{
public:
  EstimatorBase(const Model& model, Algorithm algorithm);
  const Eigen::VectorXd& state() const override { return x_; }
  const Eigen::MatrixXd& covariance() const override { return P_; }
  Algorithm algorithm() const override { return algorithm_; }
  void reset() override;

protected:
  /// Ppred_ <- A Pin A' + B Q B' (exactly symmetric).
  void predictCovariance(const Eigen::MatrixXd& Pin);
  /// bu_ <- Bu u (zero when the sample has no input); returns whether it is non-zero.
  bool commandEffect(const Sample& sample);
  /// Throws DivergenceError (and marks the estimator diverged) unless x_ and P_ are finite.
  void checkFinite();
  /// Throws DivergenceError when stepped after a divergence without reset().
  void checkNotDiverged() const;
  /// x += W' L^{-1}(y - C x) for the selected rows, after upd_.factor().
  void updateMean(Eigen::VectorXd& x);
  /// Ends a step from the prediction (xpred_, Ppred_): the measurement update of the selected
  /// rows when any arrived (last_updated_), then the result becomes (x_, P_).
  void updateAndCommit();
  /// Runs the numeric part of a step: counts it, marks the estimator diverged when it throws
  /// DivergenceError, and checks the result is finite.
  template <class F>
  void guardedStep(F&& body)
  {
    try
    {
      body();
    }
    catch (const DivergenceError&)
    {
      diverged_ = true;
      throw;
    }
    ++steps_;
    checkFinite();
  }

  Model model_;
  Algorithm algorithm_;
  Eigen::MatrixXd BQBt_;
  ArrivalSelector sel_;
  KalmanUpdate upd_;
  Eigen::VectorXd x_, xpred_, bu_, innov_;
  Eigen::MatrixXd P_, Ppred_, AP_;
  bool diverged_ = false;
};

}  // namespace detail
}  // namespace networked_estimation
