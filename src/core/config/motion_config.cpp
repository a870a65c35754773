// The model file's keys of a built-in motion (motion_config.hpp).
#include "config/motion_config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>

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

void readMotion(const Reader& in, const YAML::Node& node, Model& model)
{
  const YAML::Node m_node = node["motion"];
  if (!m_node)
  {
    if (node["two_d_mode"])
      in.fail(node["two_d_mode"], "two_d_mode", "only with motion omni_3d (a linear model has no planar constraint)");
    return;
  }
  const std::string name = in.string(m_node, "motion");
  try
  {
    model.motion = motionFromString(name, "motion");
  }
  catch (const ConfigError&)
  {
    in.fail(m_node, "motion", "expected omni_2d or omni_3d, found '" + name + "'");
  }
  const std::string why = "not used with motion " + name + " (";
  if (node["A"])
    in.fail(node["A"], "A", why + "the motion equations predict; docs/algorithms.md 7)");
  if (node["B"])
    in.fail(node["B"], "B", why + "the process noise enters every state: Q is n x n, per second)");
  if (node["control"])
    in.fail(node["control"], "control", why + "a built-in motion has no command input)");
  if (node["uncertainty"])
    in.fail(node["uncertainty"], "uncertainty", why + "a built-in motion has no uncertain parameters)");
  if (!node["period"])
    in.fail(node, "period", "required with motion " + name + " (the step of a sample without its own duration)");
  if (const YAML::Node t = node["two_d_mode"])
  {
    model.two_d_mode = in.boolean(t, "two_d_mode");
    if (model.two_d_mode && model.motion != Motion::OMNI_3D)
      in.fail(t, "two_d_mode", "only for omni_3d (omni_2d is planar already)");
  }
  const int n = motionStates(model.motion);
  model.A.resize(0, 0);
  model.B = Eigen::MatrixXd::Identity(n, n);
}

void readMotionNames(const Reader& in, const YAML::Node& node, Model& model)
{
  const std::vector<std::string>& names = motionStateNames(model.motion);
  const std::string motion = toString(model.motion);
  if (const YAML::Node s = node["states"])
  {
    bool same = s.IsSequence() && s.size() == names.size();
    for (std::size_t i = 0; same && i < names.size(); ++i)
      same = s[i].IsScalar() && s[i].Scalar() == names[i];
    if (!same)
      in.fail(s, "states", motion + "'s states are " + joinList(names) + " (leave the key out)");
  }
  if (const YAML::Node a = node["angles"])
  {
    const std::vector<int>& angles = motionAngles(model.motion);
    bool same = a.IsSequence() && a.size() == angles.size();
    for (std::size_t i = 0; same && i < angles.size(); ++i)
      same = a[i].IsScalar() && (a[i].Scalar() == names[static_cast<std::size_t>(angles[i])] ||
                                 a[i].Scalar() == std::to_string(angles[i]));
    if (!same)
      in.fail(a, "angles", motion + "'s angles are " + angleList(model.motion) + " (leave the key out)");
  }
  model.states = names;
  model.angles = motionAngles(model.motion);
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
