// predictPrior (estimator.hpp): the prediction of kfio and ekfio for callers outside an estimator
// (the rejection thresholds' gate); the motion's part is ekfio's own (motion_prediction.hpp).
#include "estimators/motion_prediction.hpp"
#include "networked_estimation/estimators/estimator.hpp"

#include <cmath>
#include <string>

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

double predictAhead(const Model& model, double period, const Eigen::VectorXd& x, const Eigen::MatrixXd& P,
                    double dt, Eigen::VectorXd& xp, Eigen::MatrixXd& Pp)
{
  if (!(dt >= 0.0) || !std::isfinite(dt))
    throw InputError("dt: expected a finite time >= 0 s to predict over, found " + std::to_string(dt));
  if (!(period > 0.0) || !std::isfinite(period))
    throw InputError("period: expected a finite step period > 0 s, found " + std::to_string(period));
  xp = x;
  Pp = P;
  if (model.nonlinear())
  {
    if (dt > 0.0)  // (predictPrior reads dt = 0 as a whole period)
    {
      const Eigen::VectorXd x0 = xp;
      const Eigen::MatrixXd P0 = Pp;
      predictPrior(model, x0, P0, Eigen::VectorXd(), dt, xp, Pp);
    }
    return dt;
  }
  const double steps = std::round(dt / period);
  if (steps > static_cast<double>(kMaxPredictAheadSteps))
    throw InputError("dt: " + std::to_string(dt) + " s is " + std::to_string(static_cast<long long>(steps)) +
                     " periods past the step; at most " + std::to_string(kMaxPredictAheadSteps) + " are predicted");
  const long k = static_cast<long>(steps);
  for (long i = 0; i < k; ++i)
  {
    const Eigen::VectorXd x0 = xp;
    const Eigen::MatrixXd P0 = Pp;
    predictPrior(model, x0, P0, Eigen::VectorXd(), 0.0, xp, Pp);
  }
  return static_cast<double>(k) * period;
}

}  // namespace networked_estimation
