// AOE and OE for non-acknowledged control links with Markov losses (docs/algorithms.md 5.3, 5.4).
#include "estimators/aoe_estimators.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace networked_estimation
{
namespace detail
{

Aoe::Aoe(const Model& model, ControlLink link)
  : EstimatorBase(model, Algorithm::AOE), link_(link), nu1_(link.stationary())
{
}

void Aoe::reset()
{
  EstimatorBase::reset();
  nu1_ = link_.stationary();
}

void Aoe::step(const Sample& sample)
{
  checkNotDiverged();
  sel_.checkInput(sample);
  const int rows = sel_.select(sample, false);
  guardedStep([&] {
    // 1. mode prediction (19a,b)
    const double nubar1 = link_.next(nu1_);
    const double nubar0 = 1.0 - nubar1;
    // 2. conditional prediction (20a,b): zbar0 = A x, zbar1 = zbar0 + Bu u; Zbar = A P A' + BQB'
    const bool has_input = commandEffect(sample);
    z0_.noalias() = model_.A * x_;
    predictCovariance(P_);
    dlt_ = bu_;  // zhat1 - zhat0, before the update
    last_updated_ = rows > 0;
    double nuhat1 = nubar1;
    if (last_updated_)
    {
      // 3-5. gain, mode update (19c) in log-odds form, conditional update (20c,d)
      upd_.factor(Ppred_, sel_.C(), sel_.R());
      innov_ = sel_.y();
      innov_.noalias() -= sel_.C() * z0_;
      upd_.whiten(innov_);  // L^{-1} e0
      z0_.noalias() += upd_.W().transpose() * innov_;
      if (has_input)
      {
        wd_.noalias() = sel_.C() * bu_;
        upd_.whiten(wd_);  // L^{-1} C Bu u
        const double L = innov_.dot(wd_) - 0.5 * wd_.squaredNorm() + std::log(nubar1) - std::log(nubar0);
        nuhat1 = 1.0 / (1.0 + std::exp(-L));
        dlt_.noalias() -= upd_.W().transpose() * wd_;  // (I - K C) Bu u
      }
      upd_.downdate(Ppred_);  // Zhat
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
    P_.swap(Ppred_);
  });
}

OptimalEstimator::OptimalEstimator(const Model& model, ControlLink link, std::size_t max_components)
  : EstimatorBase(model, Algorithm::OE), link_(link), max_components_(std::max<std::size_t>(1, max_components))
{
  reset();
}

void OptimalEstimator::reset()
{
  EstimatorBase::reset();
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

void OptimalEstimator::step(const Sample& sample)
{
  checkNotDiverged();
  sel_.checkInput(sample);
  const int rows = sel_.select(sample, false);
  guardedStep([&] {
    const int n = model_.n();
    const bool split = commandEffect(sample);
    // prediction of the shared covariance (12)
    predictCovariance(M_);
    M_.swap(Ppred_);
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
    Am_.noalias() = model_.A * means_.leftCols(count_);  // A m for every parent, one product
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
    count_ = c;
    means_.swap(next_means_);
    logw_.swap(next_logw_);
    q_.swap(next_q_);
    // measurement update (13), (14): shared gain, per-component innovations and likelihoods
    last_updated_ = rows > 0;
    if (last_updated_)
    {
      upd_.factor(M_, sel_.C(), sel_.R());
      auto mc = means_.leftCols(count_);
      E_.noalias() = -sel_.C() * mc;  // no temporary: E_ keeps its storage across steps
      E_.colwise() += sel_.y();
      upd_.whiten(E_);
      logw_.head(count_) -= 0.5 * E_.colwise().squaredNorm().transpose();
      mc.noalias() += upd_.W().transpose() * E_;
      upd_.downdate(M_);
    }
    // normalise (log-sum-exp)
    const double mx = logw_.head(count_).maxCoeff();
    const double lse = mx + std::log((logw_.head(count_).array() - mx).exp().sum());
    logw_.head(count_).array() -= lse;
    cap();
    output();
  });
}

void OptimalEstimator::cap()
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

void OptimalEstimator::output()
{
  // (17): x = sum w m; P = M + sum w (m - x)(m - x)'
  w_ = logw_.head(count_).array().exp();
  const auto mc = means_.leftCols(count_);
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
}

}  // namespace detail
}  // namespace networked_estimation
