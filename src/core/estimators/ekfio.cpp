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
class ExtendedFilter : public EstimatorBase<S>
{
  using Base = EstimatorBase<S>;
  using Base::last_updated_;
  using Base::model_;
  using Base::sel_;
  using Base::A_;
  using Base::bu_;
  using Base::x_;
  using Base::xpred_;
  using Base::P_;
  using Base::Ppred_;
  using Base::AP_;

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

  void step(const Sample& sample) override
  {
    this->checkNotDiverged();
    sel_.checkInput(sample);
    const double dt = stepDuration(sample, model_);  // InputError for a bad Sample::dt
    const int rows = this->select(sample, false);
    this->guardedStep([&] {
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
        prediction_.predict(x_, P_, dt, xpred_, Ppred_, F_, AP_);
      }
      last_updated_ = rows > 0;
      this->updateAndCommit();
    });
  }

private:
  MotionPrediction<typename S::VecN, typename S::MatN> prediction_;
  typename S::MatN F_;
};

}  // namespace

std::unique_ptr<Estimator> makeExtendedFilter(const Model& model, SizeChoice choice)
{
  return makeSized<ExtendedFilter, Estimator>(ExtendedSizes(), choice, false, model);
}

}  // namespace detail
}  // namespace networked_estimation
