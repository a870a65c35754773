// predictAhead (estimator.hpp): an estimate predicted past its step for predict_to_current_time,
// by kfio's equations (a linear model) or the motion's prediction (motion_prediction.hpp), with
// zero input and outside any filter.
#include "estimators/motion_prediction.hpp"
#include "networked_estimation/estimators/estimator.hpp"

#include <cmath>
#include <string>

namespace networked_estimation
{

double predictAhead(const Model& model, double period, const Eigen::VectorXd& x, const Eigen::MatrixXd& P, double dt,
                    Eigen::VectorXd& xp, Eigen::MatrixXd& Pp)
{
  if (!(dt >= 0.0) || !std::isfinite(dt))
    throw InputError("dt: expected a finite time >= 0 s to predict over, found " + std::to_string(dt));
  if (!(period > 0.0) || !std::isfinite(period))
    throw InputError("period: expected a finite step period > 0 s, found " + std::to_string(period));
  xp = x;
  Pp = P;
  if (model.nonlinear())
  {
    if (dt > 0.0)  // once over dt: xp = f(x, dt), Pp = F P F' + Q dt, two_d_mode applied
    {
      const detail::MotionPrediction<Eigen::VectorXd, Eigen::MatrixXd> prediction(model);
      Eigen::MatrixXd F, FP;
      prediction.predict(x, P, dt, xp, Pp, F, FP);
    }
    return dt;
  }
  const double steps = std::round(dt / period);
  if (steps > static_cast<double>(kMaxPredictAheadSteps))
    throw InputError("dt: " + std::to_string(dt) + " s is " + std::to_string(static_cast<long long>(steps)) +
                     " periods past the step; at most " + std::to_string(kMaxPredictAheadSteps) + " are predicted");
  const long k = static_cast<long>(steps);
  if (k == 0)
    return 0.0;
  // k periods with zero input: xp = A xp, Pp = A Pp A' + B Q B'
  for (long i = 0; i < k; ++i)
  {
    const Eigen::VectorXd x0 = xp;
    const Eigen::MatrixXd P0 = Pp;
    xp = model.A * x0;
    Pp = model.A * P0 * model.A.transpose() + model.B * model.Q * model.B.transpose();
  }
  return static_cast<double>(k) * period;
}

}  // namespace networked_estimation
