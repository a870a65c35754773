// Private building blocks shared by the estimators: sensor selection, the Kalman measurement
// update in Cholesky form, and the base class holding the model and the estimate.
//
// The update and the base class are templates on the sizes of their matrices (estimator_sizes.hpp):
// one implementation of the maths, compiled for dynamic sizes and for a few fixed small ones.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/index_select.hpp"
#include "networked_estimation/estimators/estimator.hpp"

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

/// The DivergenceErrors of the estimators, out of line (the message is only built when thrown).
[[noreturn]] void throwDiverged(Algorithm algorithm, long step);
[[noreturn]] void throwSteppedAfterDivergence(Algorithm algorithm);
/// A Kalman update's C P C' + R is not positive definite.
[[noreturn]] void throwNotPositiveDefinite(double trace);

/// Which sensors of a sample are fused. Size-independent: the estimators copy the rows themselves.
class ArrivalSelector
{
public:
  explicit ArrivalSelector(const Model& model);

  /// Validates the sample's sizes and decides the arrived sensors; sensor s arrives iff
  /// (gamma or ignore_gamma) and its block is finite. Returns the number of arrived rows.
  /// Throws InputError for a wrong size, an infinite cell or a partly missing block.
  int select(const Sample& sample, bool ignore_gamma)
  {
    // the usual cases inline, the rest out of line: a loss (nothing to check), or every value
    // finite (every sensor arrived; no row list needed)
    if (!sample.gamma && !ignore_gamma)
    {
      rows_ = 0;
      all_ = false;
      changed_ = false;
      return 0;
    }
    if (sample.y.size() == m_)
    {
      bool finite = true;
      for (int i = 0; i < m_; ++i)
        finite = finite && std::isfinite(sample.y[i]);
      if (finite)
      {
        rows_ = m_;
        all_ = true;
        changed_ = false;
        return rows_;
      }
    }
    return selectSome(sample, ignore_gamma);
  }

  /// Checks u's size (empty = zero input). Throws InputError.
  void checkInput(const Sample& sample) const
  {
    const Eigen::Index p = sample.u.size();
    bool finite = true;
    for (Eigen::Index i = 0; i < p; ++i)
      finite = finite && std::isfinite(sample.u[i]);
    if (p != 0 && (p != p_ || !finite))
      rejectInput(sample);
  }

  bool all() const { return all_; }
  int rows() const { return rows_; }
  /// The arrived rows (valid after a select() with some but not all sensors).
  const std::vector<int>& arrivedRows() const { return idx_; }
  /// After a select() with some but not all sensors: whether the arrived rows differ from those of
  /// the previous such selection (copies of the arrived rows of C and R are then stale).
  bool changed() const { return changed_; }

private:
  /// select() for a sample where some value is missing or invalid, or the size is wrong.
  int selectSome(const Sample& sample, bool ignore_gamma);
  [[noreturn]] void rejectInput(const Sample& sample) const;

  std::vector<Sensor> sensors_;
  int m_ = 0, p_ = 0;
  std::vector<int> idx_;
  std::vector<int> last_idx_;
  bool all_ = false;
  bool changed_ = false;
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

/// Shared state of the linear-Gaussian estimators, for the sizes S (estimator_sizes.hpp). The
/// model's matrices and the estimate are held in S's types; with fixed sizes, state() and
/// covariance() return dynamic copies refreshed at the end of every step (the public interface).
///
/// A step is written once, in two halves that the algorithm (Derived) gives: predictStep(sample),
/// from (x_, P_) and the command into (xpred_, Ppred_) and the algorithm's own workspace, without
/// changing the estimate; and updateStep(), which fuses the selected rows and commits. step() runs
/// both; predict() runs the first and forms the Prior (Derived::fillPrior); update() the second.
/// The algorithm may also give checkSample(sample) (checks beyond sizes, before anything changes),
/// ignoresGamma(), kPredictionReadsArrivals (its prediction depends on which sensors arrived),
/// saveExtra / checkExtra / restoreExtra (the state it carries beyond x and P).
template <class S, class Derived>
class EstimatorBase : public Estimator
{
public:
  using VecN = typename S::VecN;
  using MatN = typename S::MatN;

  EstimatorBase(const Model& model, Algorithm algorithm) : model_(model), algorithm_(algorithm), sel_(model_)
  {
    Eigen::MatrixXd bqb = model_.B * model_.Q * model_.B.transpose();
    symmetrise(bqb);
    BQBt_ = bqb;
    A_ = model_.A;
    Bu_ = model_.Bu;
    C_ = model_.C;
    R_ = model_.R;
    Ca_ = C_;
    Ra_ = R_;
    ya_.resize(C_.rows());
    bu_ = VecN::Zero(model_.n());
    x_ = model_.x0;
    xpred_ = VecN::Zero(model_.n());  // (the covariance-only mode never writes it)
    P_ = model_.P0;
    Ppred_.resize(model_.n(), model_.n());
    AP_.resize(model_.n(), model_.n());
    xd_.resize(S::kFixed ? model_.n() : 0);
    Pd_.resize(S::kFixed ? model_.n() : 0, S::kFixed ? model_.n() : 0);
    angle_states_ = model_.angles;
    angle_rows_ = angularRows(model_);
    publish();
  }

  void step(const Sample& sample) final
  {
    pending_ = false;
    prepare(sample);
    guardedStep(
        [&]
        {
          self().predictStep(sample);
          self().updateStep();
        });
  }
  const Prior& predict(const Sample& sample) final
  {
    pending_ = false;
    prepare(sample);
    try
    {
      self().predictStep(sample);
    }
    catch (const DivergenceError&)
    {
      diverged_ = true;
      throw;
    }
    if constexpr (Derived::kPredictionReadsArrivals)
    {
      pred_rows_ = rows_;
      pred_all_ = sel_.all();
      if (rows_ > 0 && !pred_all_)
        pred_idx_ = sel_.arrivedRows();
    }
    prior_.begin(model_, own_R_ ? &sample.R : nullptr);
    self().fillPrior(prior_);
    pending_ = true;
    return prior_;
  }
  void update(const Sample& sample) final
  {
    if (!pending_)
      throw InputError(toString(algorithm_) +
                       ": update without a pending prediction: call predict(sample) first (step, reset and restore "
                       "end a prediction)");
    rows_ = select(sample, self().ignoresGamma());
    pending_ = false;
    bool again = false;
    if constexpr (Derived::kPredictionReadsArrivals)
      again = rows_ != pred_rows_ || sel_.all() != pred_all_ ||
              (rows_ > 0 && !pred_all_ && sel_.arrivedRows() != pred_idx_);
    guardedStep(
        [&]
        {
          if (again)
            self().predictStep(sample);
          self().updateStep();
        });
  }

  using Estimator::snapshot;
  void snapshot(EstimatorState& out) const final
  {
    out.algorithm = algorithm_;
    out.x = x_;
    out.P = P_;
    out.steps = steps_;
    out.last_updated = last_updated_;
    out.diverged = diverged_;
    out.command_arrival = std::numeric_limits<double>::quiet_NaN();
    out.means.resize(0, 0);
    out.log_weights.resize(0);
    out.newest_bit.resize(0);
    out.shared_covariance.resize(0, 0);
    out.capped = false;
    self().saveExtra(out);
  }
  void restore(const EstimatorState& s) final
  {
    const int n = model_.n();
    if (s.algorithm != algorithm_)
      throw InputError("restore: algorithm: expected " + toString(algorithm_) + ", found " + toString(s.algorithm));
    if (s.x.size() != n || s.P.rows() != n || s.P.cols() != n)
      throw InputError("restore: x, P: expected " + std::to_string(n) + " and " + std::to_string(n) + " x " +
                       std::to_string(n) + ", found " + std::to_string(s.x.size()) + " and " +
                       std::to_string(s.P.rows()) + " x " + std::to_string(s.P.cols()));
    self().checkExtra(s);
    x_ = s.x;
    P_ = s.P;
    steps_ = s.steps;
    last_updated_ = s.last_updated;
    diverged_ = s.diverged;
    pending_ = false;
    self().restoreExtra(s);
    publish();
  }

  const Eigen::VectorXd& state() const override
  {
    if constexpr (S::kFixed)
      return xd_;
    else
      return x_;
  }
  const Eigen::MatrixXd& covariance() const override
  {
    if constexpr (S::kFixed)
      return Pd_;
    else
      return P_;
  }
  Algorithm algorithm() const override { return algorithm_; }
  std::string implementation() const override { return S::name(); }
  void reset() override
  {
    x_ = model_.x0;
    P_ = model_.P0;
    steps_ = 0;
    last_updated_ = false;
    diverged_ = false;
    pending_ = false;
    publish();
  }

protected:
  using Update = KalmanUpdate<S::N, S::M>;

  // The algorithm's defaults (Derived hides the ones it gives).
  static constexpr bool kPredictionReadsArrivals = false;
  void checkSample(const Sample& /*sample*/) const {}
  bool ignoresGamma() const { return false; }
  /// The prior of the one-Gaussian prediction: (xpred_, Ppred_).
  void fillPrior(Prior& prior) const { prior.setMoments(xpred_, Ppred_); }
  void saveExtra(EstimatorState& /*out*/) const {}
  void checkExtra(const EstimatorState& /*s*/) const {}
  void restoreExtra(const EstimatorState& /*s*/) {}

  Derived& self() { return static_cast<Derived&>(*this); }
  const Derived& self() const { return static_cast<const Derived&>(*this); }

  /// The checks of a step that come before anything changes (InputError), then the selection of
  /// the arrived rows (rows_).
  void prepare(const Sample& sample)
  {
    checkNotDiverged();
    sel_.checkInput(sample);
    self().checkSample(sample);
    rows_ = select(sample, self().ignoresGamma());
  }

  /// sel_.select, then the arrived part of y (and, when the set changed, of C and R) is copied:
  /// compacted with dynamic sizes; with fixed sizes in place, a missing row of C zero, its row and
  /// column of R unit and its y zero (rows the update leaves out exactly: KalmanUpdate).
  int select(const Sample& sample, bool ignore_gamma)
  {
    const bool own_R = sample.R.size() != 0;
    if (own_R)
      checkStepR(sample.R);
    const int rows = sel_.select(sample, ignore_gamma);
    // A per-step R (Sample::R) replaces the model's for this step; the compacted copies are
    // rebuilt whenever this step's R or the previous one's was its own.
    const bool rebuild = sel_.changed() || own_R || own_R_;
    own_R_ = own_R;
    if (own_R)
      Rk_ = sample.R;
    if (rows == 0)
      return 0;
    if (sel_.all())
    {
      y_ = sample.y;
      return rows;
    }
    const std::vector<int>& idx = sel_.arrivedRows();
    const typename S::MatM& R = own_R ? Rk_ : R_;
    if constexpr (S::kFixed)
    {
      if (rebuild)
      {
        Ca_.setZero();
        Ra_.setIdentity();
        for (int i : idx)
        {
          Ca_.row(i) = C_.row(i);
          for (int j : idx)
            Ra_(i, j) = R(i, j);
        }
      }
      ya_.setZero();
      for (int i : idx)
        ya_[i] = sample.y[i];
    }
    else
    {
      if (rebuild)
      {
        Ca_ = selectRows(C_, idx);
        Ra_ = selectBlock(R, idx, idx);
        // the angular rows among the compacted ones
        angle_rows_a_.clear();
        for (int i = 0; i < rows; ++i)
          if (std::binary_search(angle_rows_.begin(), angle_rows_.end(), idx[i]))
            angle_rows_a_.push_back(i);
      }
      ya_.resize(rows);
      for (int i = 0; i < rows; ++i)
        ya_[i] = sample.y[idx[i]];
    }
    return rows;
  }
  /// Calls f(update, C, R, y) with the rows of the selected sensors (after select() found some).
  /// The update is told which of these rows measure angles (the fixed-size Ca_ keeps the rows in
  /// place, the dynamic one compacts them).
  template <class F>
  void withArrived(F&& f)
  {
    if (sel_.all())
    {
      upd_.setAngularRows(&angle_rows_);
      f(upd_, C_, own_R_ ? Rk_ : R_, y_);
    }
    else
    {
      upd_.setAngularRows(S::kFixed ? &angle_rows_ : &angle_rows_a_);
      f(upd_, Ca_, Ra_, ya_);
    }
  }
  /// Sample::R: m x m and finite (InputError otherwise, before anything changes).
  void checkStepR(const Eigen::MatrixXd& R) const
  {
    const int m = model_.m();
    if (R.rows() != m || R.cols() != m)
      throw InputError("R_k: expected " + std::to_string(m) + " x " + std::to_string(m) + ", found " +
                       std::to_string(R.rows()) + " x " + std::to_string(R.cols()));
    if (!R.allFinite())
      throw InputError("R_k: not finite");
  }
  /// Ppred_ <- A Pin A' + B Q B' (exactly symmetric).
  void predictCovariance(const MatN& Pin)
  {
    AP_.noalias() = A_ * Pin;
    Ppred_ = BQBt_;
    Ppred_.noalias() += AP_ * A_.transpose();
    symmetrise(Ppred_);
  }
  /// bu_ <- Bu u (zero when the sample has no input); returns whether it is non-zero.
  bool commandEffect(const Sample& sample)
  {
    if (sample.u.size() == 0 || model_.p() == 0)
    {
      bu_.setZero();
      return false;
    }
    applyInput(bu_, Bu_, sample.u);
    return !bu_.isZero(0.0);
  }
  /// Throws DivergenceError (and marks the estimator diverged) unless x_ and P_ are finite.
  void checkFinite()
  {
    // v - v is 0 for a finite v and NaN otherwise: one pass over x and P (allFinite takes two)
    if (!((P_ - P_).sum() + (x_ - x_).sum() == 0.0))
    {
      diverged_ = true;
      throwDiverged(algorithm_, steps_);
    }
  }
  /// Throws DivergenceError when stepped after a divergence without reset().
  void checkNotDiverged() const
  {
    if (diverged_)
      throwSteppedAfterDivergence(algorithm_);
  }
  /// Ends a step from the prediction (xpred_, Ppred_): the measurement update of the selected
  /// rows when any arrived (last_updated_), then the result becomes (x_, P_). In the
  /// covariance-only mode only P: the mean is neither updated nor committed (x_ stays).
  void updateAndCommit()
  {
    if (last_updated_)
      withArrived(
          [&](Update& upd, const auto& C, const auto& R, const auto& y)
          {
            upd.factor(Ppred_, C, R);
            if (!covariance_only_)
              upd.updateMean(y, xpred_);
            upd.downdate(Ppred_);
          });
    if (!covariance_only_)
      commit(x_, xpred_);
    commit(P_, Ppred_);
  }
  /// to <- from; from is workspace afterwards (swapped where that is cheaper than a copy).
  template <class T>
  static void commit(T& to, T& from)
  {
    if constexpr (S::kFixed)
      to = from;
    else
      to.swap(from);
  }
  /// Runs the numeric part of a step: counts it, marks the estimator diverged when it throws
  /// DivergenceError, publishes the result and checks it is finite.
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
    wrapEntries(x_, angle_states_);  // the angular states into (-pi, pi] (none: nothing to do)
    publish();
    checkFinite();
  }
  /// Fixed sizes: the dynamic copies of x_ and P_ that state() and covariance() return (sized by
  /// the constructor; copied through fixed-size maps, which unroll).
  void publish()
  {
    if constexpr (S::kFixed)
    {
      Eigen::Map<VecN>(xd_.data()) = x_;
      Eigen::Map<MatN>(Pd_.data()) = P_;
    }
  }

  Model model_;
  Algorithm algorithm_;
  ArrivalSelector sel_;
  MatN A_, BQBt_;
  typename S::MatNP Bu_;
  typename S::MatMN C_, Ca_;  ///< C; the rows of the arrived sensors (select())
  typename S::MatM R_, Ra_;
  typename S::MatM Rk_;  ///< this step's own R (Sample::R), when own_R_
  bool own_R_ = false;
  typename S::VecM y_, ya_;
  Update upd_;
  VecN x_, xpred_, bu_;
  MatN P_, Ppred_, AP_;
  Eigen::VectorXd xd_;
  Eigen::MatrixXd Pd_;
  std::vector<int> angle_states_;  ///< model_.angles: wrapped after every step
  std::vector<int> angle_rows_;    ///< angularRows(model_): rows of C_ (and of the fixed-size Ca_)
  std::vector<int> angle_rows_a_;  ///< dynamic sizes: the angular rows' positions in the compacted Ca_
  bool diverged_ = false;
  int rows_ = 0;          ///< the rows selected for this step (prepare, update)
  bool pending_ = false;  ///< predict() ran and its update() has not
  Prior prior_;
  // kPredictionReadsArrivals: the selection predict() predicted for
  int pred_rows_ = 0;
  bool pred_all_ = false;
  std::vector<int> pred_idx_;
  /// Estimator::setCovarianceOnly: set by the estimators that offer it (their P does not depend on the data).
  bool covariance_only_ = false;
};

}  // namespace detail
}  // namespace networked_estimation
