#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <memory>

#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/estimators/estimator.hpp"

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
/// one Gaussian by moment matching each step. Fixed-size for the sizes of KalmanSizes.
std::unique_ptr<Estimator> makeAoe(const Model& model, ControlLink link, SizeChoice choice);

/// Exact optimal estimator (docs/algorithms.md 5.3): a Gaussian mixture over the command-loss history
/// with one shared covariance, log-weights, and a cap keeping the largest weights. Fixed-size for
/// the sizes of KalmanSizes. The estimator it returns is also an OptimalEstimator.
std::unique_ptr<Estimator> makeOptimalEstimator(const Model& model, ControlLink link, std::size_t max_components,
                                                SizeChoice choice);

/// What the exact optimal estimator tells beyond the Estimator interface (any size; reached by
/// dynamic_cast from the Estimator that makeOptimalEstimator returns).
class OptimalEstimator
{
public:
  virtual ~OptimalEstimator() = default;
  /// The shared component covariance Mhat_k (equals the ACK Kalman filter's, Theorem 1).
  virtual const Eigen::MatrixXd& componentCovariance() const = 0;
  /// Whether the cap has ever discarded a component (the result is then approximate).
  virtual bool capped() const = 0;
};

}  // namespace detail
}  // namespace networked_estimation
