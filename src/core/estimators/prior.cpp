// predictPrior (estimator.hpp): the prediction of kfio and ekfio for callers outside an estimator
// (the rejection thresholds' gate); the motion's part is ekfio's own (motion_prediction.hpp).
#include "estimators/motion_prediction.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{

void predictPrior(const Model& model, const Eigen::VectorXd& x, const Eigen::MatrixXd& P, const Eigen::VectorXd& u,
                  double dt, Eigen::VectorXd& xp, Eigen::MatrixXd& Pp)
{
  if (model.nonlinear())
  {
    Sample timing;
    timing.dt = dt;
    const detail::MotionPrediction<Eigen::VectorXd, Eigen::MatrixXd> prediction(model);
    Eigen::MatrixXd F, FP;
    prediction.predict(x, P, detail::stepDuration(timing, model), xp, Pp, F, FP);
    return;
  }
  xp = model.A * x;
  if (model.hasControl() && u.size() == model.p())
    xp += model.Bu * u;
  Pp = model.A * P * model.A.transpose() + model.B * model.Q * model.B.transpose();
}

}  // namespace networked_estimation
