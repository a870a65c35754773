// AOE and OE for non-acknowledged control links with Markov losses (docs/algorithms.md 5.3, 5.4).
#include "estimators/aoe_estimators.hpp"
#include "estimators/estimator_common.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace networked_estimation
{
namespace detail
{
namespace
{

template <class S>
class Aoe final : public EstimatorBase<S, Aoe<S>>
{
  using Base = EstimatorBase<S, Aoe<S>>;
  friend Base;
  using Base::A_;
  using Base::bu_;
  using Base::last_updated_;
  using Base::P_;
  using Base::Ppred_;
  using Base::rows_;
  using Base::x_;

public:
  Aoe(const Model& model, ControlLink link) : Base(model, Algorithm::AOE), link_(link), nu1_(link.stationary()) {}
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<Aoe>(*this); }
  double commandArrivalProbability() const override { return nu1_; }

  void reset() override
  {
    Base::reset();
    nu1_ = link_.stationary();
  }

private:
  // EstimatorBase's halves of a step
  void predictStep(const Sample& sample)
  {
    // 1. mode prediction (19a,b)
    nubar1_ = link_.next(nu1_);
    nubar0_ = 1.0 - nubar1_;
    // 2. conditional prediction (20a,b): zbar0 = A x, zbar1 = zbar0 + Bu u; Zbar = A P A' + BQB'
    has_input_ = this->commandEffect(sample);
    z0_.noalias() = A_ * x_;
    this->predictCovariance(P_);
    dlt_ = bu_;  // zhat1 - zhat0, before the update
  }
  void updateStep()
  {
    const bool has_input = has_input_;
    const double nubar1 = nubar1_, nubar0 = nubar0_;
    last_updated_ = rows_ > 0;
    double nuhat1 = nubar1;
    if (last_updated_)
    {
      // 3-5. gain, mode update (19c) in log-odds form, conditional update (20c,d)
      this->withArrived(
          [&](auto& upd, const auto& C, const auto& R, const auto& y)
          {
            upd.factor(Ppred_, C, R);
            const auto& innov = upd.updateMean(y, z0_);  // L^{-1} e0; z0 += W' L^{-1} e0
            if (has_input)
            {
              const auto& wd = upd.whitenedImage(bu_);  // L^{-1} C Bu u
              const double L = innov.dot(wd) - 0.5 * wd.squaredNorm() + std::log(nubar1) - std::log(nubar0);
              nuhat1 = 1.0 / (1.0 + std::exp(-L));
              dlt_.noalias() -= upd.W().transpose() * wd;  // (I - K C) Bu u
            }
            upd.downdate(Ppred_);  // Zhat
          });
    }
    // 6. collapse (21), (22): x = zhat0 + nuhat1 dlt, P = Zhat + nuhat0 nuhat1 dlt dlt'
    x_ = z0_;
    if (has_input)
    {
      x_ += nuhat1 * dlt_;
      const double spread = nuhat1 * (1.0 - nuhat1);
      if (spread > 0.0)
      {
        Ppred_.noalias() += spread * (dlt_ * dlt_.transpose());
        mirrorLower(Ppred_);
      }
    }
    nu1_ = nuhat1;
    this->commit(P_, Ppred_);
  }
  /// The moments of the predicted two-component mixture (docs/algorithms.md 2.8):
  /// xp = zbar0 + nubar1 Bu u, Pp = Zbar + nubar0 nubar1 (Bu u)(Bu u)'.
  void fillPrior(Prior& prior)
  {
    xp_ = z0_;
    Pp_ = Ppred_;
    if (has_input_)
    {
      xp_ += nubar1_ * bu_;
      const double spread = nubar0_ * nubar1_;
      if (spread > 0.0)
      {
        Pp_.noalias() += spread * (bu_ * bu_.transpose());
        mirrorLower(Pp_);
      }
    }
    prior.setMoments(xp_, Pp_);
  }
  void saveExtra(EstimatorState& out) const { out.command_arrival = nu1_; }
  void checkExtra(const EstimatorState& s) const
  {
    if (!(s.command_arrival >= 0.0 && s.command_arrival <= 1.0))
      throw InputError("restore: command_arrival: expected a probability in [0, 1], found " +
                       std::to_string(s.command_arrival));
  }
  void restoreExtra(const EstimatorState& s) { nu1_ = s.command_arrival; }

  ControlLink link_;
  double nu1_;  ///< nuhat_k^[1]
  // the prediction (predictStep) the update reads
  double nubar1_ = 0.0, nubar0_ = 1.0;
  bool has_input_ = false;
  typename S::VecN z0_, dlt_;
  typename S::VecN xp_;  ///< the prior's moments (fillPrior)
  typename S::MatN Pp_;
};

template <class S>
class OptimalFilter final : public EstimatorBase<S, OptimalFilter<S>>, public OptimalEstimator
{
  using Base = EstimatorBase<S, OptimalFilter<S>>;
  friend Base;
  using Base::A_;
  using Base::bu_;
  using Base::last_updated_;
  using Base::model_;
  using Base::P_;
  using Base::Ppred_;
  using Base::rows_;
  using Base::x_;
  using MatNX = Mat<S::N, kDynamic>;  ///< one column per component

public:
  OptimalFilter(const Model& model, ControlLink link, std::size_t max_components)
    : Base(model, Algorithm::OE), link_(link), max_components_(std::max<std::size_t>(1, max_components))
  {
    reset();
  }
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<OptimalFilter>(*this); }
  double commandArrivalProbability() const override { return nu1_; }
  std::size_t components() const override { return static_cast<std::size_t>(count_); }
  const Eigen::MatrixXd& componentCovariance() const override
  {
    if constexpr (S::kFixed)
    {
      Md_ = M_;
      return Md_;
    }
    else
    {
      return M_;
    }
  }
  bool capped() const override { return capped_; }

  void reset() override
  {
    Base::reset();
    const Eigen::Index cap = static_cast<Eigen::Index>(max_components_);
    means_.resize(model_.n(), std::min<Eigen::Index>(cap, 64));
    logw_.resize(means_.cols());
    q_.resize(means_.cols());
    count_ = 1;
    means_.col(0) = model_.x0;
    logw_[0] = 0.0;
    q_[0] = link_.stationary();  // nuhat_0 = pi_nu
    M_ = model_.P0;
    nu1_ = q_[0];
    capped_ = false;
  }

private:
  // EstimatorBase's halves of a step. The prediction leaves the mixture as it is: the predicted
  // shared covariance goes to Ppred_, the children to next_means_, next_logw_, next_q_
  // (next_count_ of them); the update takes them over.
  void predictStep(const Sample& sample)
  {
    const int n = model_.n();
    const bool split = this->commandEffect(sample);
    // prediction of the shared covariance (12)
    this->predictCovariance(M_);
    // children: nu_k = 0 (A m) and nu_k = 1 (A m + Bu u), prior weights (15) through the link chain.
    // Without an input effect both children have the same mean: they stay one component whose
    // newest-bit probability carries the chain (exact, and no doubling).
    const Eigen::Index children = split ? 2 * count_ : count_;
    if (next_means_.cols() < children)
    {
      next_means_.resize(n, children);
      next_logw_.resize(children);
      next_q_.resize(children);
    }
    Am_.noalias() = A_ * means_.leftCols(count_);  // A m for every parent, one product
    Eigen::Index c = 0;
    for (Eigen::Index i = 0; i < count_; ++i)
    {
      const double t1 = link_.next(q_[i]);
      if (!split)
      {
        next_means_.col(c) = Am_.col(i);
        next_logw_[c] = logw_[i];
        next_q_[c] = t1;
        ++c;
        continue;
      }
      const double lw[2] = {logw_[i] + std::log(1.0 - t1), logw_[i] + std::log(t1)};
      for (int b = 0; b < 2; ++b)
      {
        if (!(lw[b] > -std::numeric_limits<double>::infinity()))
          continue;  // a hypothesis of probability zero
        next_means_.col(c) = Am_.col(i);
        if (b == 1)
          next_means_.col(c) += bu_;
        next_logw_[c] = lw[b];
        next_q_[c] = b;
        ++c;
      }
    }
    next_count_ = c;
  }
  void updateStep()
  {
    this->commit(M_, Ppred_);
    count_ = next_count_;
    means_.swap(next_means_);
    logw_.swap(next_logw_);
    q_.swap(next_q_);
    // measurement update (13), (14): shared gain, per-component innovations and likelihoods
    last_updated_ = rows_ > 0;
    if (last_updated_)
    {
      this->withArrived(
          [&](auto& upd, const auto& C, const auto& R, const auto& y)
          {
            upd.factor(M_, C, R);
            auto mc = means_.leftCols(count_);
            E_.noalias() = -C * mc;  // no temporary: E_ keeps its storage across steps
            E_.colwise() += y;
            upd.wrapInnovations(E_);
            upd.whiten(E_);
            logw_.head(count_) -= 0.5 * E_.colwise().squaredNorm().transpose();
            mc.noalias() += upd.W().transpose() * E_;
            upd.downdate(M_);
          });
    }
    // normalise (log-sum-exp)
    const double mx = logw_.head(count_).maxCoeff();
    const double lse = mx + std::log((logw_.head(count_).array() - mx).exp().sum());
    logw_.head(count_).array() -= lse;
    cap();
    output();
  }
  /// The moments of the predicted mixture (docs/algorithms.md 2.8): the children's weights
  /// normalised, xp = sum w m, Pp = M + sum w (m - xp)(m - xp)' (angles as in output()).
  void fillPrior(Prior& prior)
  {
    const Eigen::Index c = next_count_;
    pw_ = next_logw_.head(c);
    pw_.array() -= pw_.maxCoeff();
    pw_ = pw_.array().exp();
    pw_ /= pw_.sum();
    pm_ = next_means_.leftCols(c);
    for (const int a : this->angle_states_)
      for (Eigen::Index j = 1; j < c; ++j)
        pm_(a, j) = pm_(a, 0) + wrapAngle(pm_(a, j) - pm_(a, 0));
    xp_.noalias() = pm_ * pw_;
    Pp_ = Ppred_;
    if (c > 1)
    {
      D_ = pm_.colwise() - xp_;
      D_ = D_ * pw_.cwiseSqrt().asDiagonal();
      Pp_.noalias() += D_ * D_.transpose();
      mirrorLower(Pp_);
    }
    prior.setMoments(xp_, Pp_);
  }
  void saveExtra(EstimatorState& out) const
  {
    out.command_arrival = nu1_;
    out.means = means_.leftCols(count_);
    out.log_weights = logw_.head(count_);
    out.newest_bit = q_.head(count_);
    out.shared_covariance = M_;
    out.capped = capped_;
  }
  void checkExtra(const EstimatorState& s) const
  {
    const Eigen::Index c = s.means.cols();
    const int n = model_.n();
    if (s.means.rows() != n || c < 1 || s.log_weights.size() != c || s.newest_bit.size() != c)
      throw InputError("restore: means, log_weights, newest_bit: expected an oe mixture of n = " + std::to_string(n) +
                       " rows and as many weights and bits as components, found " + std::to_string(s.means.rows()) +
                       " x " + std::to_string(c) + ", " + std::to_string(s.log_weights.size()) + " and " +
                       std::to_string(s.newest_bit.size()));
    if (s.shared_covariance.rows() != n || s.shared_covariance.cols() != n)
      throw InputError("restore: shared_covariance: expected " + std::to_string(n) + " x " + std::to_string(n) +
                       ", found " + std::to_string(s.shared_covariance.rows()) + " x " +
                       std::to_string(s.shared_covariance.cols()));
  }
  void restoreExtra(const EstimatorState& s)
  {
    const Eigen::Index c = s.means.cols();
    if (means_.cols() < c)
    {
      means_.resize(model_.n(), c);
      logw_.resize(c);
      q_.resize(c);
    }
    count_ = c;
    means_.leftCols(c) = s.means;
    logw_.head(c) = s.log_weights;
    q_.head(c) = s.newest_bit;
    M_ = s.shared_covariance;
    nu1_ = s.command_arrival;
    capped_ = s.capped;
  }

private:
  void cap()
  {
    const Eigen::Index cap = static_cast<Eigen::Index>(max_components_);
    if (count_ <= cap)
      return;
    order_.resize(count_);
    std::iota(order_.begin(), order_.end(), 0);
    std::nth_element(order_.begin(), order_.begin() + cap, order_.end(),
                     [&](Eigen::Index a, Eigen::Index b) { return logw_[a] > logw_[b]; });
    order_.resize(cap);
    std::sort(order_.begin(), order_.end());
    for (Eigen::Index j = 0; j < cap; ++j)
    {
      const Eigen::Index i = order_[j];
      if (i != j)
      {
        means_.col(j) = means_.col(i);
        logw_[j] = logw_[i];
        q_[j] = q_[i];
      }
    }
    count_ = cap;
    const double mx = logw_.head(count_).maxCoeff();
    const double lse = mx + std::log((logw_.head(count_).array() - mx).exp().sum());
    logw_.head(count_).array() -= lse;
    capped_ = true;
  }

  void output()
  {
    // (17): x = sum w m; P = M + sum w (m - x)(m - x)'
    w_ = logw_.head(count_).array().exp();
    auto mc = means_.leftCols(count_);
    // An angle's components are first taken to the turn nearest to the first component's (each
    // m_j wrapped relative to it), so that the mean and the spread are those of the angles, not of
    // their representatives in (-pi, pi]: components at pi - a and -pi + a average to pi, not 0.
    // They are wrapped again afterwards (x itself by the step).
    for (const int a : this->angle_states_)
      for (Eigen::Index j = 1; j < count_; ++j)
        mc(a, j) = mc(a, 0) + wrapAngle(mc(a, j) - mc(a, 0));
    x_.noalias() = mc * w_;
    nu1_ = w_.dot(q_.head(count_));
    P_ = M_;
    if (count_ > 1)
    {
      D_ = mc.colwise() - x_;
      D_ = D_ * w_.cwiseSqrt().asDiagonal();
      P_.noalias() += D_ * D_.transpose();
      mirrorLower(P_);
    }
    wrapEntries(mc, this->angle_states_);
  }

  ControlLink link_;
  std::size_t max_components_;
  Eigen::Index count_ = 1;
  Eigen::Index next_count_ = 1;       ///< children of the pending prediction
  MatNX means_, next_means_;          ///< n x capacity
  Eigen::VectorXd logw_, next_logw_;  ///< log weights
  Eigen::VectorXd q_, next_q_;        ///< P(newest bit = 1 | component)
  typename S::MatN M_;
  Mat<S::M, kDynamic> E_;  ///< whitened innovations, one column per component
  MatNX D_, Am_;
  mutable Eigen::MatrixXd Md_;  ///< fixed sizes: the dynamic copy componentCovariance() returns
  Eigen::VectorXd w_;
  std::vector<Eigen::Index> order_;
  MatNX pm_;             ///< the prior's components (fillPrior)
  Eigen::VectorXd pw_;   ///< their weights
  typename S::VecN xp_;  ///< the prior's moments
  typename S::MatN Pp_;
  double nu1_;
  bool capped_ = false;
};

}  // namespace

std::unique_ptr<Estimator> makeAoe(const Model& model, ControlLink link, SizeChoice choice)
{
  return makeSized<Aoe, Estimator>(KalmanSizes(), choice, false, model, link);
}

std::unique_ptr<Estimator> makeOptimalEstimator(const Model& model, ControlLink link, std::size_t max_components,
                                                SizeChoice choice)
{
  return makeSized<OptimalFilter, Estimator>(KalmanSizes(), choice, false, model, link, max_components);
}

}  // namespace detail
}  // namespace networked_estimation
