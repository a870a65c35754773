// ekfio: the extended Kalman filter with intermittent observations (docs/algorithms.md 7.4).
//   prediction: xpred = f(x, dt), Ppred = F P F' + Q dt with F = df/dx at x (a built-in motion),
//               or exactly kfio's xpred = A x + Bu u, Ppred = A P A' + B Q B' (a linear model);
//   update:     kfio's, of the sensors that arrived (2.2, angles 2.7), in EstimatorBase.
#include "estimators/ekfio_estimator.hpp"
#include "estimators/estimator_common.hpp"
#include "estimators/motion_prediction.hpp"

namespace networked_estimation
{
namespace detail
{
namespace
{

template <class S>
class ExtendedFilter final : public EstimatorBase<S, ExtendedFilter<S>>
{
  using Base = EstimatorBase<S, ExtendedFilter<S>>;
  friend Base;
  using Base::A_;
  using Base::AP_;
  using Base::bu_;
  using Base::last_updated_;
  using Base::model_;
  using Base::P_;
  using Base::Ppred_;
  using Base::rows_;
  using Base::x_;
  using Base::xpred_;

public:
  explicit ExtendedFilter(const Model& model) : Base(model, Algorithm::EKFIO), prediction_(model)
  {
    xpred_.resize(model_.n());
    reset();
  }
  std::unique_ptr<Estimator> clone() const override { return std::make_unique<ExtendedFilter>(*this); }

  void reset() override
  {
    Base::reset();
    prediction_.constrain(x_, P_);  // two_d_mode: x0 and P0 held planar too
    this->publish();
  }

private:
  // EstimatorBase's halves of a step
  void checkSample(const Sample& sample) { dt_ = stepDuration(sample, model_); }  // InputError for a bad dt
  void predictStep(const Sample& sample)
  {
    if (model_.motion == Motion::LINEAR)
    {
      // exactly kfio's prediction (the same operations: ekfio equals kfio on a linear model)
      xpred_.noalias() = A_ * x_;
      if (this->commandEffect(sample))
        xpred_ += bu_;
      this->predictCovariance(P_);
    }
    else
    {
      prediction_.predict(x_, P_, dt_, xpred_, Ppred_, F_, AP_);
    }
  }
  void updateStep()
  {
    last_updated_ = rows_ > 0;
    this->updateAndCommit();
  }

  MotionPrediction<typename S::VecN, typename S::MatN> prediction_;
  typename S::MatN F_;
  double dt_ = 0.0;  ///< this step's duration (checkSample)
};

}  // namespace

std::unique_ptr<Estimator> makeExtendedFilter(const Model& model, SizeChoice choice)
{
  return makeSized<ExtendedFilter, Estimator>(ExtendedSizes(), choice, false, model);
}

}  // namespace detail
}  // namespace networked_estimation
