// Private building blocks shared by the estimators: sensor selection and the base class holding
// the model and the estimate (the Kalman update is kalman_update.hpp, the numerics cholesky.hpp).
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

#include "estimators/cholesky.hpp"
#include "estimators/estimator_sizes.hpp"
#include "estimators/kalman_update.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/index_select.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{
namespace detail
{

/// The DivergenceErrors of the estimators, out of line (the message is only built when thrown).
[[noreturn]] void throwDiverged(Algorithm algorithm, long step);
[[noreturn]] void throwSteppedAfterDivergence(Algorithm algorithm);

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
