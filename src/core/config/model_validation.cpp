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

void validateModel(const Model& model, const std::string& source)
{
  const auto fail = [&source](const std::string& key, const std::string& problem)
  { throw ConfigError(message(source, 0, key, problem)); };
  const auto checkSize = [&fail](const std::string& key, const Eigen::MatrixXd& M, Eigen::Index rows, Eigen::Index cols,
                                 const std::string& hint)
  {
    if (M.rows() != rows || M.cols() != cols)
    {
      fail(key, "expected " + dims(rows, cols) + (hint.empty() ? "" : " (" + hint + ")") + ", found " +
                    dims(M.rows(), M.cols()));
    }
  };
  const auto checkFinite = [&fail](const std::string& key, const std::string& label, const Eigen::MatrixXd& M)
  {
    const std::string problem = finitenessProblem(M, label);
    if (!problem.empty())
    {
      fail(key, problem);
    }
  };
  const auto checkCov =
      [&fail, &checkFinite](const std::string& key, const std::string& label, const Eigen::MatrixXd& M, bool strict)
  {
    checkFinite(key, label, M);
    const CovarianceCheck check =
        networked_estimation::checkCovariance(M, strict ? Definiteness::POSITIVE : Definiteness::SEMIDEFINITE);
    if (!check.ok())
    {
      fail(key, check.describe(label));
    }
  };

  if (!std::isfinite(model.period) || model.period < 0.0)
  {
    fail("period", "expected a positive number of seconds (or 0 for unset), found " + formatNumber(model.period));
  }

  // A, or a built-in motion
  if (model.nonlinear())
  {
    const auto problem = motionModelProblem(model);
    if (!problem.first.empty())
    {
      fail(problem.first, problem.second);
    }
  }
  else
  {
    if (model.two_d_mode)
    {
      fail("two_d_mode", "only with motion omni_3d (a linear model has no planar constraint)");
    }
    if (model.A.size() == 0)
    {
      fail("A", "empty matrix");
    }
    if (model.A.rows() != model.A.cols())
    {
      fail("A", "expected a square matrix (n x n), found " + dims(model.A.rows(), model.A.cols()));
    }
    checkFinite("A", "A", model.A);
  }
  const Eigen::Index n = model.n();
  const std::string n_text = countText("n", static_cast<int>(n));

  // B, Q
  if (model.B.rows() != n || model.B.cols() == 0)
  {
    fail("B", "expected " + std::to_string(n) + " rows and at least one column (" + n_text + "), found " +
                  dims(model.B.rows(), model.B.cols()));
  }
  checkFinite("B", "B", model.B);
  const Eigen::Index nw = model.B.cols();
  checkSize("Q", model.Q, nw, nw, countText("nw", static_cast<int>(nw)) + ", the columns of B");
  checkCov("Q", "Q", model.Q, true);
  if (model.nonlinear())
  {
    const std::string problem = motionPeriodProblem(model);
    if (!problem.empty())
    {
      fail("period", problem);
    }
  }

  // C, R, sensors
  if (model.C.rows() == 0 || model.C.cols() != n)
  {
    fail("C", "expected at least one row and " + std::to_string(n) + " columns (" + n_text + "), found " +
                  dims(model.C.rows(), model.C.cols()));
  }
  checkFinite("C", "C", model.C);
  const Eigen::Index m = model.C.rows();
  checkSize("R", model.R, m, m, countText("m", static_cast<int>(m)) + ", the rows of C");
  checkCov("R", "R", model.R, true);

  if (model.sensors.empty())
  {
    fail("sensors", "at least one sensor is required");
  }
  Eigen::Index next = 0;
  std::set<std::string> names;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    const Sensor& s = model.sensors[i];
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
  for (const Sensor& a : model.sensors)
  {
    for (const Sensor& b : model.sensors)
    {
      if (&a != &b && !model.R.block(a.offset, b.offset, a.size, b.size).isZero(0.0))
      {
        fail("R", "not block diagonal over sensors (R couples sensors '" + a.name + "' and '" + b.name + "')");
      }
    }
  }

  // x0, P0
  if (model.x0.size() != n)
  {
    fail("x0", "expected " + std::to_string(n) + " entries (" + n_text + "), found " + std::to_string(model.x0.size()));
  }
  checkFinite("x0", "x0", model.x0);
  checkSize("P0", model.P0, n, n, n_text);
  checkCov("P0", "P0", model.P0, false);

  // uncertainty
  for (std::size_t j = 0; j < model.uncertainty.size(); ++j)
  {
    const Uncertainty& u = model.uncertainty[j];
    const std::string key = indexKey("uncertainty", j);
    checkSize(key + ".dA", u.dA, n, n, n_text);
    checkFinite(key + ".dA", "dA", u.dA);
    checkSize(key + ".dB", u.dB, n, nw, n_text + ", " + countText("nw", static_cast<int>(nw)));
    checkFinite(key + ".dB", "dB", u.dB);
    checkSize(key + ".dC", u.dC, m, n, countText("m", static_cast<int>(m)) + " stacked rows, " + n_text);
    checkFinite(key + ".dC", "dC", u.dC);
    if (!std::isfinite(u.range) || u.range < 0.0)
    {
      fail(key + ".range", "expected a non-negative number, found " + formatNumber(u.range));
    }
  }

  // states, angles
  if (!model.states.empty())
  {
    if (static_cast<Eigen::Index>(model.states.size()) != n)
    {
      fail("states",
           "expected " + std::to_string(n) + " names (" + n_text + "), found " + std::to_string(model.states.size()));
    }
    std::set<std::string> state_names;
    for (std::size_t i = 0; i < model.states.size(); ++i)
    {
      if (model.states[i].empty() || !state_names.insert(model.states[i]).second)
      {
        fail(indexKey("states", i), "expected a unique non-empty name, found '" + model.states[i] + "'");
      }
    }
  }
  for (std::size_t a = 0; a < model.angles.size(); ++a)
  {
    const int j = model.angles[a];
    const std::string key = indexKey("angles", a);
    if (j < 0 || j >= n || (a > 0 && j <= model.angles[a - 1]))
    {
      fail(key, "expected distinct state indices in [0, " + std::to_string(n - 1) + "], ascending, found " +
                    std::to_string(j));
    }
    checkAngle(model, j, fail);
  }

  // control
  if (model.Bu.rows() != n)
  {
    fail("control.Bu", "expected " + std::to_string(n) + " rows (" + n_text + "; use an " + std::to_string(n) +
                           "x0 matrix without control), found " + dims(model.Bu.rows(), model.Bu.cols()));
  }
  checkFinite("control.Bu", "Bu", model.Bu);

  // schedule
  const std::string schedule_problem = scheduleProblem(model.schedule, model.sensors.size());
  if (!schedule_problem.empty())
  {
    throw ConfigError(message(source, 0, "", schedule_problem));
  }
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
