// kf, kfio and ack_kf: one Kalman filter that differs only in what it treats as a measurement and
// which command it applies.
//   kf:     every finite sample is a measurement (it cannot tell a loss); u applied as delivered.
//   kfio:   Sinopoli's filter: updates only when gamma_k = 1; u applied as delivered.
//   ack_kf: kfio told nu_k: applies nu_k Bu u_k (docs/algorithms.md 5.2).
#include "estimators/kalman_filter.hpp"
#include "estimators/estimator_common.hpp"

namespace networked_estimation
{
namespace detail
{
namespace
{

template <class S>
class KalmanFilter final : public EstimatorBase<S, KalmanFilter<S>>
{
  using Base = EstimatorBase<S, KalmanFilter<S>>;
  friend Base;
  using Base::A_;
  using Base::algorithm_;
  using Base::bu_;
  using Base::last_updated_;
  using Base::model_;
  using Base::P_;
  using Base::rows_;
  using Base::x_;
  using Base::xpred_;

public:
  /// algorithm: KF, KFIO or ACK_KF.
  KalmanFilter(const Model& model, Algorithm algorithm) : Base(model, algorithm) {}
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<KalmanFilter>(*this); }

  /// P depends on which sensors arrived only (the command moves the mean alone).
  bool setCovarianceOnly(bool on) override
  {
    this->covariance_only_ = on;
    return true;
  }

  double commandArrivalProbability() const override
  {
    if (algorithm_ == Algorithm::ACK_KF && nu_ >= 0)
      return nu_;
    return Estimator::commandArrivalProbability();
  }

private:
  // EstimatorBase's halves of a step
  bool ignoresGamma() const { return algorithm_ == Algorithm::KF; }
  void checkSample(const Sample& sample) const
  {
    if (algorithm_ == Algorithm::ACK_KF && model_.p() > 0 && sample.u.size() != 0 && sample.nu != 0 && sample.nu != 1)
      throw InputError("ack_kf: nu_k (whether the command reached the actuator) must be 0 or 1, found " +
                       std::to_string(sample.nu));
  }
  void predictStep(const Sample& sample)
  {
    bool apply = this->commandEffect(sample);
    if (algorithm_ == Algorithm::ACK_KF)
    {
      apply = apply && sample.nu == 1;
      told_nu_ = sample.nu;
    }
    if (!this->covariance_only_)
    {
      xpred_.noalias() = A_ * x_;
      if (apply)
        xpred_ += bu_;
    }
    this->predictCovariance(P_);
  }
  void updateStep()
  {
    if (algorithm_ == Algorithm::ACK_KF)
      nu_ = told_nu_;
    last_updated_ = rows_ > 0;
    this->updateAndCommit();
  }
  void saveExtra(EstimatorState& out) const
  {
    if (algorithm_ == Algorithm::ACK_KF)
      out.command_arrival = nu_;
  }
  void restoreExtra(const EstimatorState& s)
  {
    if (algorithm_ == Algorithm::ACK_KF)
      nu_ = s.command_arrival == 0.0 || s.command_arrival == 1.0 ? static_cast<int>(s.command_arrival) : -1;
  }

  int nu_ = -1;
  int told_nu_ = -1;  ///< the sample's nu_k, committed by the update
};

}  // namespace

std::unique_ptr<Estimator> makeKalmanFilter(const Model& model, Algorithm algorithm, SizeChoice choice)
{
  return makeSized<KalmanFilter, Estimator>(KalmanSizes(), choice, false, model, algorithm);
}

}  // namespace detail
}  // namespace networked_estimation
