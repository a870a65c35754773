// The model file's keys of a built-in motion (motion_config.hpp).
#include "config/motion_config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace detail
{

namespace
{

/// "[yaw]" / "[roll, pitch, yaw]".
std::string angleList(Motion motion)
{
  std::string out;
  for (const int a : motionAngles(motion))
    out += (out.empty() ? "" : ", ") + motionStateNames(motion)[static_cast<std::size_t>(a)];
  return "[" + out + "]";
}

}  // namespace

void readMotion(const Field& f, const Field& map, Model& model)
{
  const std::string name = f.string();
  try
  {
    model.motion = motionFromString(name, "motion");
  }
  catch (const ConfigError&)
  {
    f.fail("expected omni_2d or omni_3d, found '" + name + "'");
  }
  const std::string why = "not used with motion " + name + " (";
  if (map["A"])
    map["A"].fail(why + "the motion equations predict; docs/algorithms.md 7)");
  if (map["B"])
    map["B"].fail(why + "the process noise enters every state: Q is n x n, per second)");
  if (map["control"])
    map["control"].fail(why + "a built-in motion has no command input)");
  if (map["uncertainty"])
    map["uncertainty"].fail(why + "a built-in motion has no uncertain parameters)");
  if (!map["period"])
    map.failAt(map["period"].key(),
               "required with motion " + name + " (the step of a sample without its own duration)");
  const int n = motionStates(model.motion);
  model.A.resize(0, 0);
  model.B = Eigen::MatrixXd::Identity(n, n);
  model.states = motionStateNames(model.motion);
  model.angles = motionAngles(model.motion);
}

void readTwoDMode(const Field& f, Model& model)
{
  if (!model.nonlinear())
    f.fail("only with motion omni_3d (a linear model has no planar constraint)");
  model.two_d_mode = f.boolean();
  if (model.two_d_mode && model.motion != Motion::OMNI_3D)
    f.fail("only for omni_3d (omni_2d is planar already)");
}

void checkMotionStates(const Field& f, const Model& model)
{
  const std::vector<std::string>& names = motionStateNames(model.motion);
  const YAML::Node& s = f.node();
  bool same = s.IsSequence() && s.size() == names.size();
  for (std::size_t i = 0; same && i < names.size(); ++i)
    same = s[i].IsScalar() && s[i].Scalar() == names[i];
  if (!same)
    f.fail(toString(model.motion) + "'s states are " + joinList(names) + " (leave the key out)");
}

void checkMotionAngles(const Field& f, const Model& model)
{
  const std::vector<std::string>& names = motionStateNames(model.motion);
  const std::vector<int>& angles = motionAngles(model.motion);
  const YAML::Node& a = f.node();
  bool same = a.IsSequence() && a.size() == angles.size();
  for (std::size_t i = 0; same && i < angles.size(); ++i)
    same = a[i].IsScalar() &&
           (a[i].Scalar() == names[static_cast<std::size_t>(angles[i])] || a[i].Scalar() == std::to_string(angles[i]));
  if (!same)
    f.fail(toString(model.motion) + "'s angles are " + angleList(model.motion) + " (leave the key out)");
}

std::pair<std::string, std::string> motionModelProblem(const Model& model)
{
  const std::string motion = toString(model.motion);
  const int n = model.n();
  if (model.A.size() != 0)
    return {"A", "not used with motion " + motion + " (found " + dims(model.A.rows(), model.A.cols()) + ")"};
  if (!model.B.isIdentity(0.0) || model.B.rows() != n || model.B.cols() != n)
    return {"B", "must be the " + std::to_string(n) + "x" + std::to_string(n) + " identity with motion " + motion};
  if (model.Bu.cols() != 0)
    return {"control", "not used with motion " + motion};
  if (!model.uncertainty.empty())
    return {"uncertainty", "not used with motion " + motion};
  if (!(model.period > 0.0))
    return {"period", "required with motion " + motion};
  if (model.two_d_mode && model.motion != Motion::OMNI_3D)
    return {"two_d_mode", "only for omni_3d"};
  if (model.states != motionStateNames(model.motion))
    return {"states", motion + "'s states are " + joinList(motionStateNames(model.motion))};
  if (model.angles != motionAngles(model.motion))
    return {"angles", motion + "'s angles are " + angleList(model.motion)};
  return {};
}

std::string motionPeriodProblem(const Model& model)
{
  const int n = model.n();
  const double dt = model.period;
  if (!model.nonlinear() || !(dt > 0.0) || model.Q.rows() != n || model.Q.cols() != n)
    return "";
  const std::string found = ", found " + formatNumber(dt);
  Eigen::VectorXd next;
  Eigen::MatrixXd F;
  propagate(model.motion, Eigen::VectorXd::Zero(n), dt, next, &F);
  const std::string entry = nonFiniteEntry(F, "F");
  if (!entry.empty())
    return "expected a number of seconds over which one step of " + toString(model.motion) + " is finite" + found +
           " (its Jacobian F has period^2 / 2 terms: " + entry + ")";
  Eigen::Index big = 0;  // Q is positive definite: its largest entry is on its diagonal
  model.Q.diagonal().maxCoeff(&big);
  if (!std::isfinite(model.Q(big, big) * dt))
    return "expected a number of seconds over which the process noise of a step, Q period, is finite" + found + " (Q(" +
           std::to_string(big) + "," + std::to_string(big) + ") = " + formatNumber(model.Q(big, big)) + " per second)";
  return "";
}

}  // namespace detail
}  // namespace networked_estimation
