// kf, kfio and ack_kf: one Kalman filter that differs only in what it treats as a measurement and
// which command it applies.
//   kf:     every finite sample is a measurement (it cannot tell a loss); u applied as delivered.
//   kfio:   Sinopoli's filter: updates only when gamma_k = 1; u applied as delivered.
//   ack_kf: kfio told nu_k: applies nu_k Bu u_k (docs/algorithms.md 5.2).
#include "estimators/kalman_filter.hpp"

namespace networked_estimation
{
namespace detail
{

KalmanFilter::KalmanFilter(const Model& model, Algorithm algorithm) : EstimatorBase(model, algorithm)
{
}

void KalmanFilter::step(const Sample& sample)
{
  checkNotDiverged();
  sel_.checkInput(sample);
  if (algorithm_ == Algorithm::ACK_KF && model_.p() > 0 && sample.u.size() != 0 && sample.nu != 0 &&
      sample.nu != 1)
    throw InputError("ack_kf: nu_k (whether the command reached the actuator) must be 0 or 1, found " +
                     std::to_string(sample.nu));
  const int rows = sel_.select(sample, algorithm_ == Algorithm::KF);
  guardedStep([&] {
    // prediction
    bool apply = commandEffect(sample);
    if (algorithm_ == Algorithm::ACK_KF)
    {
      apply = apply && sample.nu == 1;
      nu_ = sample.nu;
    }
    xpred_.noalias() = model_.A * x_;
    if (apply)
      xpred_ += bu_;
    predictCovariance(P_);
    last_updated_ = rows > 0;
    updateAndCommit();
  });
}

double KalmanFilter::commandArrivalProbability() const
{
  if (algorithm_ == Algorithm::ACK_KF && nu_ >= 0)
    return nu_;
  return Estimator::commandArrivalProbability();
}

}  // namespace detail
}  // namespace networked_estimation
