#pragma once

#include "estimators/estimator_common.hpp"

namespace networked_estimation
{
namespace detail
{

/// Markov chain of the actuator link (docs/algorithms.md 5.1): q1 = recovery, q2 = failure.
struct ControlLink
{
  double q1 = 0.5, q2 = 0.5;
  /// P(nu_k = 1 | P(nu_{k-1} = 1) = p1).
  double next(double p1) const { return p1 * (1.0 - q2) + (1.0 - p1) * q1; }
  /// Stationary P(nu = 1) = q1 / (q1 + q2) (1 when the chain never leaves state 1).
  double stationary() const { return q1 + q2 > 0.0 ? q1 / (q1 + q2) : 1.0; }
};

/// Approximate optimal estimator (docs/algorithms.md 5.4): a 2-component mixture over nu_k collapsed to
/// one Gaussian by moment matching each step.
class Aoe : public EstimatorBase
{
public:
  Aoe(const Model& model, ControlLink link);
  void step(const Sample& sample) override;
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<Aoe>(*this); }
  double commandArrivalProbability() const override { return nu1_; }
  void reset() override;

private:
  ControlLink link_;
  double nu1_;  ///< nuhat_k^[1]
  Eigen::VectorXd z0_, dlt_, wd_;
};

/// Exact optimal estimator (docs/algorithms.md 5.3): a Gaussian mixture over the command-loss history
/// with one shared covariance, log-weights, and a cap keeping the largest weights.
class OptimalEstimator : public EstimatorBase
{
public:
  OptimalEstimator(const Model& model, ControlLink link, std::size_t max_components);
  void step(const Sample& sample) override;
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<OptimalEstimator>(*this); }
  double commandArrivalProbability() const override { return nu1_; }
  std::size_t components() const override { return static_cast<std::size_t>(count_); }
  void reset() override;
  /// The shared component covariance Mhat_k (equals the ACK Kalman filter's, Theorem 1).
  const Eigen::MatrixXd& componentCovariance() const { return M_; }
  /// Whether the cap has ever discarded a component (the result is then approximate).
  bool capped() const { return capped_; }

private:
  void cap();
  void output();

  ControlLink link_;
  std::size_t max_components_;
  Eigen::Index count_ = 1;
  Eigen::MatrixXd means_, next_means_;     ///< n x capacity
  Eigen::VectorXd logw_, next_logw_;       ///< log weights
  Eigen::VectorXd q_, next_q_;             ///< P(newest bit = 1 | component)
  Eigen::MatrixXd M_, E_, D_, Am_;
  Eigen::VectorXd w_;
  std::vector<Eigen::Index> order_;
  double nu1_;
  bool capped_ = false;
};

}  // namespace detail
}  // namespace networked_estimation
