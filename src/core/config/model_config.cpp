// Reading the model file (docs/formats.md, "Model file"). Every rejection is a ConfigError naming
// the source, line and key path (src/core/config/yaml_reader.hpp); the checks of a built model are
// in model_validation.cpp.
#include "networked_estimation/config/model.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "config/motion_config.hpp"
#include "config/schedule_config.hpp"
#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

#include <Eigen/Eigenvalues>

namespace networked_estimation
{
using namespace detail;

namespace
{

// ---------------------------------------------------------------------------------------------
// Model
// ---------------------------------------------------------------------------------------------

/// `states`: n distinct non-empty names.
std::vector<std::string> parseStateNames(const Reader& in, const YAML::Node& node, int n)
{
  if (!node.IsSequence() || static_cast<int>(node.size()) != n)
  {
    in.fail(node, "states",
            "expected a list of " + std::to_string(n) + " state names (" + countText("n", n) + "), found " +
                (node.IsSequence() ? std::to_string(node.size()) + " names" : describe(node)));
  }
  std::vector<std::string> names;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const std::string key = indexKey("states", i);
    const std::string name = in.string(node[i], key);
    if (name.empty())
    {
      in.fail(node[i], key, "a state name must not be empty");
    }
    if (name.find_first_not_of("0123456789") == std::string::npos)
    {
      in.fail(node[i], key,
              "a state name must not be a number, found '" + name + "' (angles reads a number as an index)");
    }
    for (std::size_t k = 0; k < names.size(); ++k)
    {
      if (names[k] == name)
      {
        in.fail(node[i], key, "duplicate state name '" + name + "' (also " + indexKey("states", k) + ")");
      }
    }
    names.push_back(name);
  }
  return names;
}

/// `angles`: state indices (0-based) or names of `states`, each at most once; returned ascending.
std::vector<int> parseAngles(const Reader& in, const YAML::Node& node, const std::vector<std::string>& states, int n)
{
  if (!node.IsSequence())
  {
    in.fail(node, "angles", "expected a list of state indices or state names, found " + describe(node));
  }
  std::vector<int> angles;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const std::string key = indexKey("angles", i);
    const YAML::Node e = node[i];
    if (!e.IsScalar())
    {
      in.fail(e, key, "expected a state index or a state name, found " + describe(e));
    }
    const std::string text = e.Scalar();
    const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
    int index = -1;
    if (digits)
    {
      const std::uint64_t v = in.integer(e, key, 0);
      if (v >= static_cast<std::uint64_t>(n))
      {
        in.fail(
            e, key,
            "state index " + text + " out of range (" + countText("n", n) + ": 0 to " + std::to_string(n - 1) + ")");
      }
      index = static_cast<int>(v);
    }
    else
    {
      for (std::size_t k = 0; k < states.size(); ++k)
      {
        if (states[k] == text)
        {
          index = static_cast<int>(k);
        }
      }
      if (index < 0)
      {
        in.fail(e, key,
                states.empty() ? "'" + text +
                                     "' is not a state index, and the model names no states (give an "
                                     "index from 0, or the key states)"
                               : "'" + text + "' is not a state (states: " + joinList(states) + ")");
      }
    }
    for (std::size_t k = 0; k < angles.size(); ++k)
    {
      if (angles[k] == index)
      {
        in.fail(e, key, "state " + std::to_string(index) + " is listed twice (also " + indexKey("angles", k) + ")");
      }
    }
    angles.push_back(index);
  }
  std::sort(angles.begin(), angles.end());
  return angles;
}

Model parseModelImpl(const YAML::Node& node, const std::string& source)
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(node, "",
               {"name", "period", "A", "B", "Q", "C", "R", "sensors", "x0", "P0", "uncertainty", "control", "schedule",
                "states", "angles", "motion", "two_d_mode"});

  Model model;
  if (node["name"])
  {
    model.name = in.string(node["name"], "name");
  }
  if (node["period"])
  {
    model.period = in.number(node["period"], "period");
    if (!(model.period > 0.0))
    {
      in.fail(node["period"], "period", "expected a positive number of seconds, found " + node["period"].Scalar());
    }
  }

  // A: n x n, or a built-in motion (no A, B = I)
  readMotion(in, node, model);
  if (!model.nonlinear())
  {
    const YAML::Node a_node = in.require(node, "", "A", "or a built-in motion: motion omni_2d or omni_3d");
    model.A = in.matrix(a_node, "A", -1, -1, "");
    if (model.A.rows() != model.A.cols())
    {
      in.fail(a_node, "A", "expected a square matrix (n x n), found " + dims(model.A.rows(), model.A.cols()));
    }
  }
  const int n = model.n();
  const std::string n_rows = countText("n", n) + " rows";
  const std::string n_cols = countText("n", n) + " columns";

  // B: n x nw (identity by default), Q: nw x nw
  if (node["B"])
  {
    model.B = in.matrix(node["B"], "B", n, -1, n_rows);
  }
  else
  {
    model.B = Eigen::MatrixXd::Identity(n, n);
  }
  const int nw = static_cast<int>(model.B.cols());
  const YAML::Node q_node = in.require(node, "", "Q");
  model.Q = in.matrix(q_node, "Q", nw, nw,
                      model.nonlinear() ? "per second, one row per state of " + toString(model.motion)
                                        : countText("nw", nw) + (node["B"] ? ", the columns of B" : ", B = identity"));
  checkCovariance(in, q_node, "Q", "Q", model.Q, true);
  if (model.nonlinear())
  {
    const std::string problem = motionPeriodProblem(model);
    if (!problem.empty())
    {
      in.fail(node["period"], "period", problem);
    }
  }

  // C / R, or sensors
  const bool has_c = static_cast<bool>(node["C"]);
  const bool has_r = static_cast<bool>(node["R"]);
  const YAML::Node sensors_node = node["sensors"];
  if (sensors_node)
  {
    if (has_c || has_r)
    {
      in.fail(sensors_node, "sensors", "cannot be combined with C/R (give either C and R, or sensors)");
    }
    if (!sensors_node.IsSequence() || sensors_node.size() == 0)
    {
      in.fail(sensors_node, "sensors",
              "expected a non-empty list of sensors ({name, C, R}), found " +
                  (sensors_node.IsSequence() ? std::string("an empty list") : describe(sensors_node)));
    }
    std::vector<Eigen::MatrixXd> cs;
    std::vector<Eigen::MatrixXd> rs;
    int m = 0;
    for (std::size_t i = 0; i < sensors_node.size(); ++i)
    {
      const YAML::Node s = sensors_node[i];
      const std::string prefix = indexKey("sensors", i);
      in.requireMap(s, prefix);
      in.checkKeys(s, prefix, {"name", "C", "R"});
      const YAML::Node name_node = in.require(s, prefix, "name");
      Sensor sensor;
      sensor.name = in.string(name_node, prefix + ".name");
      if (sensor.name.empty())
      {
        in.fail(name_node, prefix + ".name", "sensor name must not be empty");
      }
      for (std::size_t k = 0; k < model.sensors.size(); ++k)
      {
        if (model.sensors[k].name == sensor.name)
        {
          in.fail(name_node, prefix + ".name",
                  "duplicate sensor name '" + sensor.name + "' (also " + indexKey("sensors", k) + ".name)");
        }
      }
      const YAML::Node c_node = in.require(s, prefix, "C");
      const Eigen::MatrixXd c = in.matrix(c_node, prefix + ".C", -1, n, n_cols);
      const int size = static_cast<int>(c.rows());
      const YAML::Node r_node = in.require(s, prefix, "R");
      const Eigen::MatrixXd r = in.matrix(r_node, prefix + ".R", size, size,
                                          "size = " + std::to_string(size) + ", the rows of " + prefix + ".C");
      checkCovariance(in, r_node, prefix + ".R", "R", r, true);
      sensor.offset = m;
      sensor.size = size;
      m += size;
      model.sensors.push_back(sensor);
      cs.push_back(c);
      rs.push_back(r);
    }
    model.C = Eigen::MatrixXd::Zero(m, n);
    model.R = Eigen::MatrixXd::Zero(m, m);
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
    {
      const Sensor& s = model.sensors[i];
      model.C.block(s.offset, 0, s.size, n) = cs[i];
      model.R.block(s.offset, s.offset, s.size, s.size) = rs[i];
    }
  }
  else
  {
    if (!has_c && !has_r)
    {
      in.fail(node, "C", "missing required key (give C and R, or sensors)");
    }
    if (!has_c)
    {
      in.fail(node, "C", "missing required key (R is given)");
    }
    if (!has_r)
    {
      in.fail(node, "R", "missing required key (C is given)");
    }
    model.C = in.matrix(node["C"], "C", -1, n, n_cols);
    const int m = static_cast<int>(model.C.rows());
    model.R = in.matrix(node["R"], "R", m, m, countText("m", m) + ", the rows of C");
    checkCovariance(in, node["R"], "R", "R", model.R, true);
    Sensor sensor;
    sensor.name = "y";
    sensor.offset = 0;
    sensor.size = m;
    model.sensors.push_back(sensor);
  }
  const int m = static_cast<int>(model.C.rows());

  // x0, P0
  if (node["x0"])
  {
    model.x0 = in.vector(node["x0"], "x0", n, countText("n", n));
  }
  else
  {
    model.x0 = Eigen::VectorXd::Zero(n);
  }
  if (node["P0"])
  {
    model.P0 = in.matrix(node["P0"], "P0", n, n, countText("n", n));
    checkCovariance(in, node["P0"], "P0", "P0", model.P0, false);
  }
  else
  {
    model.P0 = Eigen::MatrixXd::Identity(n, n);
  }

  // uncertainty
  if (const YAML::Node u_node = node["uncertainty"])
  {
    if (!u_node.IsSequence())
    {
      in.fail(u_node, "uncertainty", "expected a list of {dA, dB, dC, range}, found " + describe(u_node));
    }
    for (std::size_t j = 0; j < u_node.size(); ++j)
    {
      const YAML::Node e = u_node[j];
      const std::string prefix = indexKey("uncertainty", j);
      in.requireMap(e, prefix);
      in.checkKeys(e, prefix, {"dA", "dB", "dC", "range"});
      Uncertainty u;
      u.dA = e["dA"] ? in.matrix(e["dA"], prefix + ".dA", n, n, countText("n", n)) : Eigen::MatrixXd::Zero(n, n);
      u.dB = e["dB"] ? in.matrix(e["dB"], prefix + ".dB", n, nw, countText("n", n) + ", " + countText("nw", nw))
                     : Eigen::MatrixXd::Zero(n, nw);
      u.dC = e["dC"]
                 ? in.matrix(e["dC"], prefix + ".dC", m, n, countText("m", m) + " stacked rows, " + countText("n", n))
                 : Eigen::MatrixXd::Zero(m, n);
      if (e["range"])
      {
        u.range = in.nonNegative(e["range"], prefix + ".range", "number");
      }
      model.uncertainty.push_back(u);
    }
  }

  // control
  if (const YAML::Node c_node = node["control"])
  {
    in.requireMap(c_node, "control");
    in.checkKeys(c_node, "control", {"Bu"});
    const YAML::Node bu = in.require(c_node, "control", "Bu");
    model.Bu = in.matrix(bu, "control.Bu", n, -1, n_rows);
  }
  else
  {
    model.Bu = Eigen::MatrixXd::Zero(n, 0);
  }

  // schedule
  if (const YAML::Node s_node = node["schedule"])
  {
    model.schedule = parseSchedule(in, s_node, model.sensors);
  }

  // state names and angles
  if (model.nonlinear())
  {
    readMotionNames(in, node, model);
  }
  else if (const YAML::Node s_node = node["states"])
  {
    model.states = parseStateNames(in, s_node, n);
  }
  if (const YAML::Node a_node = node["angles"]; a_node && !model.nonlinear())
  {
    model.angles = parseAngles(in, a_node, model.states, n);
  }

  validateModel(model, source);
  return model;
}

// ---------------------------------------------------------------------------------------------
// Settings
// ---------------------------------------------------------------------------------------------

}  // namespace

Model parseModel(const YAML::Node& node, const std::string& source)
{
  return guarded(source, [&] { return parseModelImpl(node, source); });
}

Model loadModel(const std::string& path)
{
  const YAML::Node root = loadYamlFile(path);
  Model model = parseModel(root, path);
  if (!root["name"])
  {
    model.name = std::filesystem::path(path).stem().string();
  }
  return model;
}

}  // namespace networked_estimation
