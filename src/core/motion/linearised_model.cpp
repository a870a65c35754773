// The linear model of a built-in motion around one state (linearised_model.hpp).
#include "networked_estimation/motion/linearised_model.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

Model linearisedModel(const Model& model, const Eigen::VectorXd& at, double dt)
{
  if (!model.nonlinear())
    return model;
  const int n = model.n();
  if (at.size() != n || !at.allFinite())
    throw ConfigError("linearisation of model '" + model.name + "': expected a finite state of " + std::to_string(n) +
                      " values (" + toString(model.motion) + "), found " + std::to_string(at.size()) +
                      (at.allFinite() ? "" : " (not finite)"));
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw ConfigError("linearisation of model '" + model.name + "': expected a step duration > 0 s, found " +
                      std::to_string(dt));
  Model lin = model;
  Eigen::VectorXd next;
  Eigen::MatrixXd F;
  propagate(model.motion, at, dt, next, &F);
  lin.motion = Motion::LINEAR;
  lin.A = F;
  lin.Q = model.Q * dt;
  lin.period = dt;
  lin.x0 = at;
  lin.angles.clear();
  if (model.two_d_mode)
  {
    // the held states: no motion, no noise (a tiny variance keeps Q definite, as a model needs)
    const double floor = 1e-12 * std::max(1.0, lin.Q.diagonal().maxCoeff());
    for (const int held : planarConstrained())
    {
      lin.A.row(held).setZero();
      lin.A.col(held).setZero();
      lin.Q.row(held).setZero();
      lin.Q.col(held).setZero();
      lin.Q(held, held) = floor;
    }
  }
  lin.two_d_mode = false;
  validateModel(lin, "linearisation of model '" + model.name + "'");
  return lin;
}

}  // namespace networked_estimation
