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
#include "config/field.hpp"
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
std::vector<std::string> parseStateNames(const Field& f, int n)
{
  const YAML::Node& node = f.node();
  if (!node.IsSequence() || static_cast<int>(node.size()) != n)
  {
    f.fail("expected a list of " + std::to_string(n) + " state names (" + countText("n", n) + "), found " +
           (node.IsSequence() ? std::to_string(node.size()) + " names" : f.found()));
  }
  std::vector<std::string> names;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const Field e = f[i];
    const std::string name = e.string();
    if (name.empty())
    {
      e.fail("a state name must not be empty");
    }
    if (name.find_first_not_of("0123456789") == std::string::npos)
    {
      e.fail("a state name must not be a number, found '" + name + "' (angles reads a number as an index)");
    }
    for (std::size_t k = 0; k < names.size(); ++k)
    {
      if (names[k] == name)
      {
        e.fail("duplicate state name '" + name + "' (also " + indexKey(f.key(), k) + ")");
      }
    }
    names.push_back(name);
  }
  return names;
}

/// `angles`: state indices (0-based) or names of `states`, each at most once; returned ascending.
std::vector<int> parseAngles(const Field& f, const std::vector<std::string>& states, int n)
{
  const YAML::Node& node = f.node();
  if (!node.IsSequence())
  {
    f.fail("expected a list of state indices or state names, found " + f.found());
  }
  std::vector<int> angles;
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    const Field e = f[i];
    if (!e.isScalar())
    {
      e.fail("expected a state index or a state name, found " + e.found());
    }
    const std::string text = e.text();
    const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
    int index = -1;
    if (digits)
    {
      const std::uint64_t v = e.integer(0);
      if (v >= static_cast<std::uint64_t>(n))
      {
        e.fail("state index " + text + " out of range (" + countText("n", n) + ": 0 to " + std::to_string(n - 1) + ")");
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
        e.fail(states.empty() ? "'" + text +
                                    "' is not a state index, and the model names no states (give an "
                                    "index from 0, or the key states)"
                              : "'" + text + "' is not a state (states: " + joinList(states) + ")");
      }
    }
    for (std::size_t k = 0; k < angles.size(); ++k)
    {
      if (angles[k] == index)
      {
        e.fail("state " + std::to_string(index) + " is listed twice (also " + indexKey(f.key(), k) + ")");
      }
    }
    angles.push_back(index);
  }
  std::sort(angles.begin(), angles.end());
  return angles;
}

/// The model being read, with the map it comes from (rows that depend on other keys look there).
struct ModelParse
{
  Model model;
  Field map;
  int n() const { return model.n(); }
  int nw() const { return static_cast<int>(model.B.cols()); }
  int m() const { return static_cast<int>(model.C.rows()); }
};

std::string rowsText(int n)
{
  return countText("n", n) + " rows";
}

std::string colsText(int n)
{
  return countText("n", n) + " columns";
}

/// One entry of `sensors`: {name, C, R}.
struct SensorParse
{
  Sensor sensor;
  Eigen::MatrixXd C, R;
  std::string c_key;  ///< "sensors[i].C", for R's size hint
  const ModelParse& in;
};

void readSensor(const Field& f, ModelParse& p, std::vector<Eigen::MatrixXd>& cs, std::vector<Eigen::MatrixXd>& rs)
{
  using S = SensorParse;
  static const std::vector<KeyRule<S>> table = {
      requiredKey<S>("name",
                     [](const Field& name, S& s)
                     {
                       s.sensor.name = name.string();
                       if (s.sensor.name.empty())
                       {
                         name.fail("sensor name must not be empty");
                       }
                       const std::vector<Sensor>& others = s.in.model.sensors;
                       for (std::size_t k = 0; k < others.size(); ++k)
                       {
                         if (others[k].name == s.sensor.name)
                         {
                           name.fail("duplicate sensor name '" + s.sensor.name + "' (also " + indexKey("sensors", k) +
                                     ".name)");
                         }
                       }
                     }),
      requiredKey<S>("C",
                     [](const Field& c, S& s)
                     {
                       s.C = c.matrix(-1, s.in.n(), colsText(s.in.n()));
                       s.c_key = c.key();
                     }),
      requiredKey<S>("R",
                     [](const Field& r, S& s)
                     {
                       const int size = static_cast<int>(s.C.rows());
                       s.R = r.matrix(size, size, "size = " + std::to_string(size) + ", the rows of " + s.c_key);
                       r.checkCovariance(s.R, "R", Definiteness::POSITIVE);
                     }),
  };
  SensorParse s{Sensor(), Eigen::MatrixXd(), Eigen::MatrixXd(), "", p};
  readKeys(f, table, s);
  s.sensor.offset = p.model.sensors.empty() ? 0 : p.model.sensors.back().offset + p.model.sensors.back().size;
  s.sensor.size = static_cast<int>(s.C.rows());
  p.model.sensors.push_back(s.sensor);
  cs.push_back(s.C);
  rs.push_back(s.R);
}

void readSensors(const Field& f, ModelParse& p)
{
  if (p.map["C"] || p.map["R"])
  {
    f.fail("cannot be combined with C/R (give either C and R, or sensors)");
  }
  if (!f.isList() || f.size() == 0)
  {
    f.fail("expected a non-empty list of sensors ({name, C, R}), found " +
           (f.isList() ? std::string("an empty list") : f.found()));
  }
  std::vector<Eigen::MatrixXd> cs;
  std::vector<Eigen::MatrixXd> rs;
  for (const Field& e : f.elements())
  {
    readSensor(e, p, cs, rs);
  }
  const int n = p.n();
  const int m = p.model.sensors.back().offset + p.model.sensors.back().size;
  p.model.C = Eigen::MatrixXd::Zero(m, n);
  p.model.R = Eigen::MatrixXd::Zero(m, m);
  for (std::size_t i = 0; i < p.model.sensors.size(); ++i)
  {
    const Sensor& s = p.model.sensors[i];
    p.model.C.block(s.offset, 0, s.size, n) = cs[i];
    p.model.R.block(s.offset, s.offset, s.size, s.size) = rs[i];
  }
}

/// One entry of `uncertainty`: {dA, dB, dC, range}, each optional (zero by default).
void readUncertainty(const Field& f, ModelParse& p)
{
  struct U
  {
    Uncertainty u;
    int n, nw, m;
  };
  static const std::vector<KeyRule<U>> table = {
      optionalKey<U>(
          "dA", [](const Field& v, U& e) { e.u.dA = v.matrix(e.n, e.n, countText("n", e.n)); },
          [](const Field&, U& e) { e.u.dA = Eigen::MatrixXd::Zero(e.n, e.n); }),
      optionalKey<U>(
          "dB",
          [](const Field& v, U& e)
          { e.u.dB = v.matrix(e.n, e.nw, countText("n", e.n) + ", " + countText("nw", e.nw)); },
          [](const Field&, U& e) { e.u.dB = Eigen::MatrixXd::Zero(e.n, e.nw); }),
      optionalKey<U>(
          "dC",
          [](const Field& v, U& e)
          { e.u.dC = v.matrix(e.m, e.n, countText("m", e.m) + " stacked rows, " + countText("n", e.n)); },
          [](const Field&, U& e) { e.u.dC = Eigen::MatrixXd::Zero(e.m, e.n); }),
      optionalKey<U>("range", [](const Field& v, U& e) { e.u.range = v.nonNegative("number"); }),
  };
  if (!f.isList())
  {
    f.fail("expected a list of {dA, dB, dC, range}, found " + f.found());
  }
  for (const Field& e : f.elements())
  {
    U u{Uncertainty(), p.n(), p.nw(), p.m()};
    readKeys(e, table, u);
    p.model.uncertainty.push_back(u.u);
  }
}

void readControl(const Field& f, ModelParse& p)
{
  static const std::vector<KeyRule<ModelParse>> table = {
      requiredKey<ModelParse>(
          "Bu", [](const Field& bu, ModelParse& q) { q.model.Bu = bu.matrix(q.n(), -1, rowsText(q.n())); }),
  };
  readKeys(f, table, p);
}

/// The single sensor "y" of a model given by C and R.
void readC(const Field& c, ModelParse& p)
{
  if (!p.map["R"])
  {
    p.map.failAt("R", "missing required key (C is given)");
  }
  p.model.C = c.matrix(-1, p.n(), colsText(p.n()));
}

/// R of the single sensor: C was read (without C, C's absence rule has failed before this row).
void readR(const Field& r, ModelParse& p)
{
  const int m = p.m();
  p.model.R = r.matrix(m, m, countText("m", m) + ", the rows of C");
  r.checkCovariance(p.model.R, "R", Definiteness::POSITIVE);
  Sensor sensor;
  sensor.name = "y";
  sensor.offset = 0;
  sensor.size = m;
  p.model.sensors.push_back(sensor);
}

const std::vector<KeyRule<ModelParse>>& modelTable()
{
  using P = ModelParse;
  static const std::vector<KeyRule<P>> table = {
      optionalKey<P>("name", [](const Field& f, P& p) { p.model.name = f.string(); }),
      optionalKey<P>("period",
                     [](const Field& f, P& p)
                     {
                       p.model.period = f.number();
                       if (!(p.model.period > 0.0))
                       {
                         f.fail("expected a positive number of seconds, found " + f.text());
                       }
                     }),
      // A: n x n, or a built-in motion (no A, B = I)
      optionalKey<P>("motion", [](const Field& f, P& p) { readMotion(f, p.map, p.model); }),
      optionalKey<P>("two_d_mode", [](const Field& f, P& p) { readTwoDMode(f, p.model); }),
      optionalKey<P>(
          "A",
          [](const Field& f, P& p)
          {
            p.model.A = f.matrix(-1, -1, "");
            if (p.model.A.rows() != p.model.A.cols())
            {
              f.fail("expected a square matrix (n x n), found " + dims(p.model.A.rows(), p.model.A.cols()));
            }
          },
          [](const Field& map, P& p)
          {
            if (!p.model.nonlinear())
            {
              map.required("A", "or a built-in motion: motion omni_2d or omni_3d");
            }
          }),
      // B: n x nw (identity by default), Q: nw x nw
      optionalKey<P>(
          "B", [](const Field& f, P& p) { p.model.B = f.matrix(p.n(), -1, rowsText(p.n())); },
          [](const Field&, P& p) { p.model.B = Eigen::MatrixXd::Identity(p.n(), p.n()); }),
      requiredKey<P>("Q",
                     [](const Field& f, P& p)
                     {
                       const int nw = p.nw();
                       p.model.Q =
                           f.matrix(nw, nw,
                                    p.model.nonlinear()
                                        ? "per second, one row per state of " + toString(p.model.motion)
                                        : countText("nw", nw) + (p.map["B"] ? ", the columns of B" : ", B = identity"));
                       f.checkCovariance(p.model.Q, "Q", Definiteness::POSITIVE);
                       if (p.model.nonlinear())
                       {
                         const std::string problem = motionPeriodProblem(p.model);
                         if (!problem.empty())
                         {
                           p.map["period"].fail(problem);
                         }
                       }
                     }),
      // C / R, or sensors
      optionalKey<P>("sensors", readSensors),
      optionalKey<P>("C", readC,
                     [](const Field& map, P& p)
                     {
                       if (!map["sensors"])
                       {
                         map.failAt("C", map["R"] ? "missing required key (R is given)"
                                                  : "missing required key (give C and R, or sensors)");
                       }
                     }),
      optionalKey<P>("R", readR),
      // x0, P0
      optionalKey<P>(
          "x0", [](const Field& f, P& p) { p.model.x0 = f.vector(p.n(), countText("n", p.n())); },
          [](const Field&, P& p) { p.model.x0 = Eigen::VectorXd::Zero(p.n()); }),
      optionalKey<P>(
          "P0",
          [](const Field& f, P& p)
          {
            p.model.P0 = f.matrix(p.n(), p.n(), countText("n", p.n()));
            f.checkCovariance(p.model.P0, "P0", Definiteness::SEMIDEFINITE);
          },
          [](const Field&, P& p) { p.model.P0 = Eigen::MatrixXd::Identity(p.n(), p.n()); }),
      optionalKey<P>("uncertainty", readUncertainty),
      optionalKey<P>("control", readControl, [](const Field&, P& p) { p.model.Bu = Eigen::MatrixXd::Zero(p.n(), 0); }),
      optionalKey<P>("schedule", [](const Field& f, P& p) { p.model.schedule = parseSchedule(f, p.model.sensors); }),
      // state names and angles (a built-in motion has its own: readMotion set them)
      optionalKey<P>("states",
                     [](const Field& f, P& p)
                     {
                       if (p.model.nonlinear())
                         checkMotionStates(f, p.model);
                       else
                         p.model.states = parseStateNames(f, p.n());
                     }),
      optionalKey<P>("angles",
                     [](const Field& f, P& p)
                     {
                       if (p.model.nonlinear())
                         checkMotionAngles(f, p.model);
                       else
                         p.model.angles = parseAngles(f, p.model.states, p.n());
                     }),
  };
  return table;
}

Model parseModelImpl(const YAML::Node& node, const std::string& source)
{
  const Field root(node, source);
  root.requireTopMap();
  ModelParse p{Model(), root};
  readKeys(root, modelTable(), p);
  validateModel(p.model, source);
  return p.model;
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
