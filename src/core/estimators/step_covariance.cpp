// Checking a step's own measurement covariance (estimator.hpp, checkStepCovariance).
#include <Eigen/Cholesky>
#include <string>

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
    throw InputError("R: expected " + std::to_string(m) + " x " + std::to_string(m) + " (m = the model's outputs), found " +
                     std::to_string(R.rows()) + " x " + std::to_string(R.cols()));
  if (!sample.gamma || sample.y.size() != m)
    return;  // nothing fused (or a y the estimator refuses with its own message)
  for (const Sensor& s : model.sensors)
  {
    if (!sample.y.segment(s.offset, s.size).allFinite())
      continue;  // not fused at this step: its block is not used
    const Eigen::MatrixXd block = R.block(s.offset, s.offset, s.size, s.size);
    const std::string where = "R: sensor '" + s.name + "': its block";
    if (!block.allFinite())
      throw InputError(where + " is not finite");
    if (block != block.transpose())
      throw InputError(where + " is not symmetric");
    if (Eigen::LLT<Eigen::MatrixXd>(block).info() != Eigen::Success)
      throw InputError(where + " is not positive definite");
  }
}

}  // namespace networked_estimation
