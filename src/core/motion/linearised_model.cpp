// The linear model of a built-in motion around one state (linearised_model.hpp).
#include "networked_estimation/motion/linearised_model.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

namespace
{

/// "1, 2, 3".
std::string stateValues(const Eigen::VectorXd& v)
{
  std::string out;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    out += (i ? ", " : "") + detail::formatNumber(v[i]);
  return out;
}

}  // namespace

std::string linearisationStateProblem(const Model& model, const Eigen::VectorXd& at, double dt)
{
  if (!model.nonlinear())
    return "";
  const int n = model.n();
  const std::vector<std::string>& names = motionStateNames(model.motion);
  if (at.size() != n)
    return "expected a finite state of " + std::to_string(n) + " values (" + toString(model.motion) + ": " +
           detail::joinList(names) + "), found " + std::to_string(at.size()) +
           (at.size() ? " (" + stateValues(at) + ")" : std::string());
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(at[i]))
      return "entry " + std::to_string(i) + " (" + names[static_cast<std::size_t>(i)] +
             "): expected a finite number, found " + detail::formatNumber(at[i]);
  Eigen::VectorXd next;
  Eigen::MatrixXd F;
  propagate(model.motion, at, dt, next, &F);
  const std::string entry = detail::nonFiniteEntry(F, "F");
  if (!entry.empty())
    return "the Jacobian of " + toString(model.motion) + " there over " + detail::plainNumber(dt) +
           " s is not finite (" + entry + "): expected a state of smaller values, found [" + stateValues(at) + "]";
  return "";
}

Model linearisedModel(const Model& model, const Eigen::VectorXd& at, double dt)
{
  if (!model.nonlinear())
    return model;
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw ConfigError("linearisation of model '" + model.name + "': expected a step duration > 0 s, found " +
                      std::to_string(dt));
  const std::string problem = linearisationStateProblem(model, at, dt);
  if (!problem.empty())
    throw ConfigError("linearisation of model '" + model.name + "': " + problem);
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
