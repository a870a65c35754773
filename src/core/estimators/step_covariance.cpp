// Checking a step's own measurement covariance (estimator.hpp, checkStepCovariance).
#include <string>

#include "networked_estimation/common/covariance.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{

void checkStepCovariance(const Model& model, const Sample& sample)
{
  const Eigen::MatrixXd& R = sample.R;
  if (R.size() == 0)
    return;
  const int m = model.m();
  if (R.rows() != m || R.cols() != m)
    throw InputError("R: expected " + std::to_string(m) + " x " + std::to_string(m) +
                     " (m = the model's outputs), found " + std::to_string(R.rows()) + " x " +
                     std::to_string(R.cols()));
  if (!sample.gamma || sample.y.size() != m)
    return;  // nothing fused (or a y the estimator refuses with its own message)
  for (const Sensor& s : model.sensors)
  {
    if (!sample.y.segment(s.offset, s.size).allFinite())
      continue;  // not fused at this step: its block is not used
    const CovarianceCheck check = checkCovariance(R.block(s.offset, s.offset, s.size, s.size), Definiteness::POSITIVE);
    const std::string where = "R: sensor '" + s.name + "': its block";
    switch (check.problem)
    {
      case CovarianceCheck::Problem::NONE:
        break;
      case CovarianceCheck::Problem::NOT_FINITE:
        throw InputError(where + " is not finite");
      case CovarianceCheck::Problem::NOT_SYMMETRIC:
        throw InputError(where + " is not symmetric");
      default:
        throw InputError(where + " is not positive definite");
    }
  }
}

}  // namespace networked_estimation
