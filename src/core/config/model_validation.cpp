// Checking a built model (validateModel: dimensions, symmetry, definiteness, finite values, the
// angles' rules) and the lookups by name and angle over it (model.hpp). parseModel (model_config.cpp)
// ends with these checks; code that builds a Model by hand calls validateModel itself.
#include "networked_estimation/config/model.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "config/motion_config.hpp"
#include "config/schedule_config.hpp"
#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

#include <Eigen/Dense>

namespace networked_estimation
{
using namespace detail;

namespace
{

/// "state 2 ('yaw')" or "state 2".
std::string stateLabel(const Model& model, int j)
{
  return model.states.empty() ? "state " + std::to_string(j)
                              : "state " + std::to_string(j) + " ('" + model.states[j] + "')";
}

/// Whether row i of C is the unit vector e_j.
bool isUnitRow(const Eigen::MatrixXd& C, Eigen::Index i, int j)
{
  for (Eigen::Index c = 0; c < C.cols(); ++c)
  {
    if (C(i, c) != (c == j ? 1.0 : 0.0))
    {
      return false;
    }
  }
  return true;
}

/// The linear model must be periodic in an angle j (docs/formats.md 1.2b): adding 2 pi to x_j
/// changes nothing but x_j, now and at every later step. So column j of A is e_j (the angle keeps
/// its value and feeds no other state), column j of every dA and dC is zero, and every row of C
/// that involves x_j measures it alone (a unit row, whose innovation is wrapped).
template <class Fail>
void checkAngle(const Model& model, int j, const Fail& fail)
{
  const std::string what = stateLabel(model, j);
  for (Eigen::Index i = 0; i < model.A.rows(); ++i)
  {
    if (model.A(i, j) != (i == j ? 1.0 : 0.0))
    {
      fail("A", "column " + std::to_string(j) + " must be the unit vector e_" + std::to_string(j) + " because " + what +
                    " is an angle (an angle keeps its value and feeds no other state linearly; found A(" +
                    std::to_string(i) + "," + std::to_string(j) + ") = " + formatNumber(model.A(i, j)) + ")");
    }
  }
  for (Eigen::Index i = 0; i < model.C.rows(); ++i)
  {
    if (model.C(i, j) != 0.0 && !isUnitRow(model.C, i, j))
    {
      std::string row = "row " + std::to_string(i);
      for (const Sensor& s : model.sensors)
      {
        if (i >= s.offset && i < s.offset + s.size)
        {
          row = "row " + std::to_string(i - s.offset) + " of sensor '" + s.name + "'";
        }
      }
      fail("C", row + " involves " + what +
                    ", an angle, without measuring it alone (an angle is measured by a row "
                    "that is the unit vector e_" +
                    std::to_string(j) + ", found C(" + std::to_string(i) + "," + std::to_string(j) +
                    ") = " + formatNumber(model.C(i, j)) + " in a row that is not)");
    }
  }
  for (std::size_t u = 0; u < model.uncertainty.size(); ++u)
  {
    const Uncertainty& e = model.uncertainty[u];
    const std::string key = indexKey("uncertainty", u);
    if (e.dA.cols() > j && !e.dA.col(j).isZero(0.0))
    {
      fail(key + ".dA", "column " + std::to_string(j) + " must be zero because " + what + " is an angle");
    }
    if (e.dC.cols() > j && !e.dC.col(j).isZero(0.0))
    {
      fail(key + ".dC", "column " + std::to_string(j) + " must be zero because " + what + " is an angle");
    }
  }
}

}  // namespace

std::vector<int> angularRows(const Model& model)
{
  std::vector<int> rows;
  if (model.angles.empty())
  {
    return rows;
  }
  for (Eigen::Index i = 0; i < model.C.rows(); ++i)
  {
    for (const int j : model.angles)
    {
      if (j < model.C.cols() && isUnitRow(model.C, i, j))
      {
        rows.push_back(static_cast<int>(i));
      }
    }
  }
  return rows;
}

std::string stateName(const Model& model, int i)
{
  return i >= 0 && static_cast<std::size_t>(i) < model.states.size() ? model.states[static_cast<std::size_t>(i)]
                                                                     : "state " + std::to_string(i);
}

namespace
{

/// The checks of a built model, each failing with "<source>: <key>: <problem>" (no line: the model
/// may not come from a file).
class ModelChecks
{
public:
  ModelChecks(const Model& model, const std::string& source)
    : model_(model), source_(source), n_(model.n()), n_text_(countText("n", model.n()))
  {
  }

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const
  {
    throw ConfigError(message(source_, 0, key, problem));
  }

  void size(const std::string& key, const Eigen::MatrixXd& M, Eigen::Index rows, Eigen::Index cols,
            const std::string& hint) const
  {
    if (M.rows() != rows || M.cols() != cols)
    {
      fail(key, "expected " + dims(rows, cols) + (hint.empty() ? "" : " (" + hint + ")") + ", found " +
                    dims(M.rows(), M.cols()));
    }
  }

  void finite(const std::string& key, const std::string& label, const Eigen::MatrixXd& M) const
  {
    const std::string problem = finitenessProblem(M, label);
    if (!problem.empty())
    {
      fail(key, problem);
    }
  }

  /// M (key; `label` in the finiteness message) of a shape `shaped` says is right ("expected
  /// <expected>, found RxC" otherwise), finite.
  void gain(const std::string& key, const std::string& label, const Eigen::MatrixXd& M, bool shaped,
            const std::string& expected) const
  {
    if (!shaped)
    {
      fail(key, "expected " + expected + ", found " + dims(M.rows(), M.cols()));
    }
    finite(key, label, M);
  }

  void covariance(const std::string& key, const std::string& label, const Eigen::MatrixXd& M, bool strict) const
  {
    finite(key, label, M);
    const CovarianceCheck check =
        networked_estimation::checkCovariance(M, strict ? Definiteness::POSITIVE : Definiteness::SEMIDEFINITE);
    if (!check.ok())
    {
      fail(key, check.describe(label));
    }
  }

  /// period, A (or the motion), B, Q.
  void dynamics() const;
  /// C, R and the sensors that cover C's rows.
  void sensors() const;
  /// x0, P0.
  void initial() const;
  void uncertainty() const;
  /// states, angles.
  void names() const;
  /// control.Bu, schedule.
  void controlAndSchedule() const;

private:
  const Model& model_;
  const std::string& source_;
  const Eigen::Index n_;
  const std::string n_text_;
};

void ModelChecks::dynamics() const
{
  if (!std::isfinite(model_.period) || model_.period < 0.0)
  {
    fail("period", "expected a positive number of seconds (or 0 for unset), found " + formatNumber(model_.period));
  }

  // A, or a built-in motion
  if (model_.nonlinear())
  {
    const auto problem = motionModelProblem(model_);
    if (!problem.first.empty())
    {
      fail(problem.first, problem.second);
    }
  }
  else
  {
    if (model_.two_d_mode)
    {
      fail("two_d_mode", "only with motion omni_3d (a linear model has no planar constraint)");
    }
    if (model_.A.size() == 0)
    {
      fail("A", "empty matrix");
    }
    gain("A", "A", model_.A, model_.A.rows() == model_.A.cols(), "a square matrix (n x n)");
  }

  // B, Q
  gain("B", "B", model_.B, model_.B.rows() == n_ && model_.B.cols() > 0,
       std::to_string(n_) + " rows and at least one column (" + n_text_ + ")");
  const Eigen::Index nw = model_.B.cols();
  size("Q", model_.Q, nw, nw, countText("nw", static_cast<int>(nw)) + ", the columns of B");
  covariance("Q", "Q", model_.Q, true);
  if (model_.nonlinear())
  {
    const std::string problem = motionPeriodProblem(model_);
    if (!problem.empty())
    {
      fail("period", problem);
    }
  }
}

void ModelChecks::sensors() const
{
  gain("C", "C", model_.C, model_.C.rows() > 0 && model_.C.cols() == n_,
       "at least one row and " + std::to_string(n_) + " columns (" + n_text_ + ")");
  const Eigen::Index m = model_.C.rows();
  size("R", model_.R, m, m, countText("m", static_cast<int>(m)) + ", the rows of C");
  covariance("R", "R", model_.R, true);

  if (model_.sensors.empty())
  {
    fail("sensors", "at least one sensor is required");
  }
  Eigen::Index next = 0;
  std::set<std::string> names;
  for (std::size_t i = 0; i < model_.sensors.size(); ++i)
  {
    const Sensor& s = model_.sensors[i];
    const std::string key = indexKey("sensors", i);
    if (s.name.empty())
    {
      fail(key + ".name", "sensor name must not be empty");
    }
    if (!names.insert(s.name).second)
    {
      fail(key + ".name", "duplicate sensor name '" + s.name + "'");
    }
    if (s.offset != next || s.size < 1)
    {
      fail(key, "expected offset " + std::to_string(next) +
                    " and size >= 1 (sensors cover the rows "
                    "of C in order), found offset " +
                    std::to_string(s.offset) + " and size " + std::to_string(s.size));
    }
    next += s.size;
  }
  if (next != m)
  {
    fail("sensors", "the sensors cover " + std::to_string(next) + " rows but C has " + std::to_string(m));
  }
  for (const Sensor& a : model_.sensors)
  {
    for (const Sensor& b : model_.sensors)
    {
      if (&a != &b && !model_.R.block(a.offset, b.offset, a.size, b.size).isZero(0.0))
      {
        fail("R", "not block diagonal over sensors (R couples sensors '" + a.name + "' and '" + b.name + "')");
      }
    }
  }
}

void ModelChecks::initial() const
{
  if (model_.x0.size() != n_)
  {
    fail("x0",
         "expected " + std::to_string(n_) + " entries (" + n_text_ + "), found " + std::to_string(model_.x0.size()));
  }
  finite("x0", "x0", model_.x0);
  size("P0", model_.P0, n_, n_, n_text_);
  covariance("P0", "P0", model_.P0, false);
}

void ModelChecks::uncertainty() const
{
  const Eigen::Index nw = model_.B.cols();
  const Eigen::Index m = model_.C.rows();
  for (std::size_t j = 0; j < model_.uncertainty.size(); ++j)
  {
    const Uncertainty& u = model_.uncertainty[j];
    const std::string key = indexKey("uncertainty", j);
    size(key + ".dA", u.dA, n_, n_, n_text_);
    finite(key + ".dA", "dA", u.dA);
    size(key + ".dB", u.dB, n_, nw, n_text_ + ", " + countText("nw", static_cast<int>(nw)));
    finite(key + ".dB", "dB", u.dB);
    size(key + ".dC", u.dC, m, n_, countText("m", static_cast<int>(m)) + " stacked rows, " + n_text_);
    finite(key + ".dC", "dC", u.dC);
    if (!std::isfinite(u.range) || u.range < 0.0)
    {
      fail(key + ".range", "expected a non-negative number, found " + formatNumber(u.range));
    }
  }
}

void ModelChecks::names() const
{
  if (!model_.states.empty())
  {
    if (static_cast<Eigen::Index>(model_.states.size()) != n_)
    {
      fail("states", "expected " + std::to_string(n_) + " names (" + n_text_ + "), found " +
                         std::to_string(model_.states.size()));
    }
    std::set<std::string> state_names;
    for (std::size_t i = 0; i < model_.states.size(); ++i)
    {
      if (model_.states[i].empty() || !state_names.insert(model_.states[i]).second)
      {
        fail(indexKey("states", i), "expected a unique non-empty name, found '" + model_.states[i] + "'");
      }
    }
  }
  for (std::size_t a = 0; a < model_.angles.size(); ++a)
  {
    const int j = model_.angles[a];
    const std::string key = indexKey("angles", a);
    if (j < 0 || j >= n_ || (a > 0 && j <= model_.angles[a - 1]))
    {
      fail(key, "expected distinct state indices in [0, " + std::to_string(n_ - 1) + "], ascending, found " +
                    std::to_string(j));
    }
    checkAngle(model_, j, [this](const std::string& key, const std::string& problem) { fail(key, problem); });
  }
}

void ModelChecks::controlAndSchedule() const
{
  // control
  gain("control.Bu", "Bu", model_.Bu, model_.Bu.rows() == n_,
       std::to_string(n_) + " rows (" + n_text_ + "; use an " + std::to_string(n_) + "x0 matrix without control)");

  // schedule
  const std::string schedule_problem = scheduleProblem(model_.schedule, model_.sensors.size());
  if (!schedule_problem.empty())
  {
    throw ConfigError(message(source_, 0, "", schedule_problem));
  }
}

}  // namespace

void validateModel(const Model& model, const std::string& source)
{
  const ModelChecks check(model, source);
  check.dynamics();
  check.sensors();
  check.initial();
  check.uncertainty();
  check.names();
  check.controlAndSchedule();
}

std::size_t sensorIndex(const Model& model, const std::string& name, const std::string& key)
{
  std::string names;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    if (model.sensors[i].name == name)
      return i;
    names += (names.empty() ? "" : ", ") + model.sensors[i].name;
  }
  throw ConfigError(key + ": '" + name + "' is not a sensor of the model (sensors: " + names + ")");
}

}  // namespace networked_estimation
