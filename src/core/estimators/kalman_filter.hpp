#pragma once

#include "estimators/estimator_common.hpp"

namespace networked_estimation
{
namespace detail
{

class KalmanFilter : public EstimatorBase
{
public:
  /// algorithm: KF, KFIO or ACK_KF.
  KalmanFilter(const Model& model, Algorithm algorithm);
  void step(const Sample& sample) override;
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<KalmanFilter>(*this); }
  double commandArrivalProbability() const override;

private:
  int nu_ = -1;
};

}  // namespace detail
}  // namespace networked_estimation
