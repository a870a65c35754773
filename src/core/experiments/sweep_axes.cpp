// The axes of a sweep (sweep.hpp): parsing and resolving --axis, the grid's values, and the model,
// links and estimators' settings at one grid point.
#include "networked_estimation/experiments/sweep.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "experiments/experiment_support.hpp"
#include "io/tokens.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

namespace
{

constexpr long kMaxAxisPoints = 10000;
/// Grid points of a sweep at most: every point keeps 5 accumulators per estimator in every block of
/// 64 runs (and in a shard file), and gets its own verdict.
constexpr long kMaxGridPoints = 10000;

[[noreturn]] void axisError(const std::string& arg, const std::string& what)
{
  throw ConfigError("--axis '" + arg + "': " + what);
}

std::string joined(const std::vector<std::string>& v)
{
  std::string out;
  for (const std::string& s : v)
    out += (out.empty() ? "" : ", ") + s;
  return out;
}

/// "A[i][j]" -> row, col (false unless exactly that form with two non-negative integers).
bool parseEntry(const std::string& text, std::string& matrix, int& row, int& col)
{
  if (text.size() < 7 || text[1] != '[' || text.back() != ']')
    return false;
  matrix = text.substr(0, 1);
  const std::string::size_type mid = text.find("][");
  if (mid == std::string::npos)
    return false;
  const std::string a = text.substr(2, mid - 2), b = text.substr(mid + 2, text.size() - mid - 3);
  long r = 0, c = 0;
  if (!tokens::parseLong(a, r) || !tokens::parseLong(b, c) || r < 0 || c < 0 || r > 100000 || c > 100000)
    return false;
  row = static_cast<int>(r);
  col = static_cast<int>(c);
  return true;
}

}  // namespace

const std::vector<std::string>& sweepParameters()
{
  static const std::vector<std::string> p = {"arrival_rate", "recovery_rate", "loss", "p", "r",
                                             "loss_good",    "loss_bad"};
  return p;
}

const std::vector<std::string>& sweepSettingsParameters()
{
  static const std::vector<std::string> p = {"mu", "recovery", "failure"};
  return p;
}

std::string SweepAxis::name() const
{
  if (kind != Kind::MODEL)
    return sensor + "." + param;
  if (param == "A" || param == "C")
    return "model." + param + "[" + std::to_string(row) + "][" + std::to_string(col) + "]";
  return "model." + param;
}

std::vector<double> sweepValues(double lo, double hi, long n)
{
  std::vector<double> v;
  for (long i = 0; i < n; ++i)
    v.push_back(n == 1 || i == 0 ? lo
                : i == n - 1     ? hi
                                 : lo + (hi - lo) * static_cast<double>(i) / static_cast<double>(n - 1));
  return v;
}

SweepAxis parseSweepAxis(const std::string& arg)
{
  const std::string form =
      "expected NAME=LO:HI:N with NAME SENSOR.PARAM, ESTIMATOR.PARAM or model.ENTRY, e.g. "
      "gnss.arrival_rate=0.05:0.95:19, kfio.mu=0.5:1:6, model.A[0][0]=1:1.5:11, model.Q*=0.1:10:5";
  SweepAxis a;
  a.arg = arg;
  const std::string::size_type eq = arg.find('=');
  if (eq == std::string::npos)
    axisError(arg, form);
  const std::string name = arg.substr(0, eq);
  const std::string model_entries = "A[i][j], C[i][j], Q* or R*";
  if (name.compare(0, 6, "model.") == 0)
  {
    a.kind = SweepAxis::Kind::MODEL;
    a.sensor = "model";
    const std::string entry = name.substr(6);
    if (entry == "Q*" || entry == "R*")
      a.param = entry;
    else if (!parseEntry(entry, a.param, a.row, a.col) || (a.param != "A" && a.param != "C"))
      axisError(arg, "unknown model entry '" + entry + "' (valid: model." + model_entries + ")");
  }
  else
  {
    const std::string::size_type dot = name.rfind('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == name.size())
      axisError(arg, form);
    a.sensor = name.substr(0, dot);
    a.param = name.substr(dot + 1);
    const std::vector<std::string>& lp = sweepParameters();
    const std::vector<std::string>& sp = sweepSettingsParameters();
    if (a.sensor == "schedule")
      axisError(arg, "the schedule is not swept (a sensor's link: SENSOR." + joined(lp) + "; an estimator: ESTIMATOR." +
                         joined(sp) + "; the model: model." + model_entries + ")");
    if (a.param == "delay")
      axisError(arg,
                "delay is not simulated by the Monte Carlo (only the LossyChannel nodelet delays messages; the "
                "estimators see every arrival at its own step)");
    if (std::find(sp.begin(), sp.end(), a.param) != sp.end())
      a.kind = SweepAxis::Kind::SETTINGS;
    else if (std::find(lp.begin(), lp.end(), a.param) == lp.end())
      axisError(arg, "unknown parameter '" + a.param + "' (valid: a sensor's " + joined(lp) + "; an estimator's " +
                         joined(sp) + "; the model's model." + model_entries + ")");
  }
  const std::vector<std::string> range = tokens::split(arg.substr(eq + 1), ':');
  if (range.size() != 3)
    axisError(arg, form);
  if (!tokens::parseFinite(range[0], a.lo))
    axisError(arg, "LO '" + range[0] + "' is not a number");
  if (!tokens::parseFinite(range[1], a.hi))
    axisError(arg, "HI '" + range[1] + "' is not a number");
  double n = 0.0;
  if (!tokens::parseFinite(range[2], n) || n != std::floor(n) || n < 1 || n > kMaxAxisPoints)
    axisError(arg, "N '" + range[2] + "' is not an integer in [1, " + std::to_string(kMaxAxisPoints) + "]");
  a.count = static_cast<long>(n);
  if (a.lo > a.hi)
    axisError(arg, "LO " + mc::fmt(a.lo) + " is above HI " + mc::fmt(a.hi));
  if (a.count == 1 && a.lo != a.hi)
    axisError(arg, "N = 1 needs LO = HI");
  const std::string range_text = "the range is [" + mc::fmt(a.lo) + ", " + mc::fmt(a.hi) + "]";
  if (a.kind == SweepAxis::Kind::MODEL)
  {
    if ((a.param == "Q*" || a.param == "R*") && !(a.lo > 0.0))
      axisError(arg, a.name() + " (a factor) must be > 0, " + range_text);
  }
  else if (a.param == "mu")
  {
    if (!(a.lo > 0.0 && a.hi <= 1.0))
      axisError(arg, "mu must lie in (0, 1], " + range_text);
  }
  else if (a.lo < 0.0 || a.hi > 1.0)
    axisError(arg, a.param + " must lie in [0, 1], " + range_text);
  a.values = sweepValues(a.lo, a.hi, a.count);
  return a;
}

void resolveSweepAxes(std::vector<SweepAxis>& axes, const Model& model,
                      const std::vector<std::optional<ChannelSettings>>& links,
                      const std::vector<std::string>& estimators, const std::vector<EstimatorSettings>& settings)
{
  if (axes.empty() || axes.size() > 2)
    throw ConfigError("experiment sweep: expected one or two --axis options, found " + std::to_string(axes.size()));
  std::string sensors;
  for (const Sensor& s : model.sensors)
    sensors += (sensors.empty() ? "" : ", ") + s.name;
  for (std::size_t i = 0; i < axes.size(); ++i)
  {
    SweepAxis& a = axes[i];
    a.sensor_index = -1;
    if (a.kind == SweepAxis::Kind::LINK)
    {
      for (std::size_t s = 0; s < model.sensors.size(); ++s)
        if (model.sensors[s].name == a.sensor)
          a.sensor_index = static_cast<int>(s);
      if (a.sensor_index < 0)
        axisError(a.arg, "no sensor '" + a.sensor + "' in model '" + model.name + "' (sensors: " + sensors + ")");
      const auto& link = links.at(static_cast<std::size_t>(a.sensor_index));
      const bool ge = link && link->model == LossModelKind::GILBERT_ELLIOTT;
      if (a.param != "arrival_rate" && a.param != "loss" && !ge)
        axisError(a.arg, a.param + " needs a gilbert_elliott link on sensor '" + a.sensor + "' (--channel " + a.sensor +
                             "=FILE; its other keys are kept)");
      if (a.param == "loss" && ge)
        axisError(a.arg, "loss is a bernoulli link's key; sensor '" + a.sensor +
                             "' has a gilbert_elliott link (sweep its loss_good or loss_bad)");
    }
    else if (a.kind == SweepAxis::Kind::SETTINGS)
    {
      for (std::size_t j = 0; j < estimators.size(); ++j)
        if (estimators[j] == a.sensor)
          a.sensor_index = static_cast<int>(j);
      if (a.sensor_index < 0)
        axisError(a.arg, "no estimator '" + a.sensor + "' (estimators: " + joined(estimators) + ")");
      const EstimatorSettings& es = settings.at(static_cast<std::size_t>(a.sensor_index));
      if (a.param == "mu" && es.algorithm != Algorithm::RSEIO)
        axisError(a.arg, "mu is rseio's; estimator '" + a.sensor + "' is " + toString(es.algorithm));
      if ((a.param == "recovery" || a.param == "failure") &&
          !((es.algorithm == Algorithm::AOE || es.algorithm == Algorithm::OE) && es.has_control_link))
        axisError(a.arg, a.param + " is the control_link of aoe or oe; estimator '" + a.sensor + "' has none");
    }
    else
    {
      if (model.nonlinear() && a.param == "A")
        axisError(a.arg, "model '" + model.name + "' has a built-in motion, no A");
      const Eigen::MatrixXd& M = a.param == "A" ? model.A : model.C;
      if ((a.param == "A" || a.param == "C") && (a.row >= M.rows() || a.col >= M.cols()))
        axisError(a.arg, "model '" + model.name + "': " + a.param + " is " + std::to_string(M.rows()) + " x " +
                             std::to_string(M.cols()) + " (entries from [0][0])");
    }
    for (std::size_t j = 0; j < i; ++j)
      if (axes[j].name() == a.name() ||
          (a.kind == SweepAxis::Kind::LINK && axes[j].kind == SweepAxis::Kind::LINK &&
           axes[j].sensor_index == a.sensor_index && (a.param == "arrival_rate" || axes[j].param == "arrival_rate")))
        axisError(a.arg,
                  (a.kind == SweepAxis::Kind::LINK && (a.param == "arrival_rate" || axes[j].param == "arrival_rate")
                       ? "sensor '" + a.sensor + "'"  // arrival_rate replaces the whole link
                       : a.name()) +
                      " is already swept by --axis '" + axes[j].arg + "'");
  }
  if (axes.size() == 2 && axes[0].count * axes[1].count > kMaxGridPoints)
    throw ConfigError("--axis '" + axes[0].arg + "' x --axis '" + axes[1].arg + "': " + std::to_string(axes[0].count) +
                      " x " + std::to_string(axes[1].count) + " = " + std::to_string(axes[0].count * axes[1].count) +
                      " grid points, at most " + std::to_string(kMaxGridPoints) +
                      " (split the grid into several sweeps)");
}

std::vector<std::optional<ChannelSettings>> sweepPointLinks(const std::vector<std::optional<ChannelSettings>>& links,
                                                            const std::vector<SweepAxis>& axes,
                                                            const std::vector<double>& values)
{
  std::vector<std::optional<ChannelSettings>> out = links;
  for (std::size_t i = 0; i < axes.size(); ++i)
  {
    if (axes[i].kind != SweepAxis::Kind::LINK)
      continue;
    std::optional<ChannelSettings>& l = out.at(static_cast<std::size_t>(axes[i].sensor_index));
    ChannelSettings c = l ? *l : ChannelSettings{};
    const std::string& k = axes[i].param;
    if (k == "arrival_rate")
    {
      c.model = LossModelKind::BERNOULLI;
      c.loss = 1.0 - values[i];
    }
    else if (k == "loss")
      c.loss = values[i];
    else if (k == "recovery_rate" || k == "r")
      c.r = values[i];
    else if (k == "p")
      c.p = values[i];
    else if (k == "loss_good")
      c.loss_good = values[i];
    else
      c.loss_bad = values[i];
    l = c;
  }
  return out;
}

Model sweepPointModel(const Model& model, const std::vector<SweepAxis>& axes, const std::vector<double>& values)
{
  Model m = model;
  bool changed = false;
  for (std::size_t i = 0; i < axes.size(); ++i)
  {
    const SweepAxis& a = axes[i];
    if (a.kind != SweepAxis::Kind::MODEL)
      continue;
    changed = true;
    if (a.param == "A")
      m.A(a.row, a.col) = values[i];
    else if (a.param == "C")
      m.C(a.row, a.col) = values[i];
    else if (a.param == "Q*")
      m.Q *= values[i];
    else
      m.R *= values[i];
  }
  if (changed)
  {
    try
    {
      validateModel(m, model.name);
    }
    catch (const ConfigError& e)
    {
      std::string at;
      for (std::size_t i = 0; i < axes.size(); ++i)
        at += (at.empty() ? "" : ", ") + axes[i].name() + " = " + mc::fmt(values[i]);
      throw ConfigError("sweep: the model at " + at + " is not valid: " + e.what());
    }
  }
  return m;
}

std::vector<EstimatorSettings> sweepPointSettings(const std::vector<EstimatorSettings>& settings,
                                                  const std::vector<SweepAxis>& axes, const std::vector<double>& values)
{
  std::vector<EstimatorSettings> out = settings;
  for (std::size_t i = 0; i < axes.size(); ++i)
  {
    const SweepAxis& a = axes[i];
    if (a.kind != SweepAxis::Kind::SETTINGS)
      continue;
    EstimatorSettings& s = out.at(static_cast<std::size_t>(a.sensor_index));
    if (a.param == "mu")
      s.mu = values[i];
    else if (a.param == "recovery")
      s.recovery = values[i];
    else
      s.failure = values[i];
  }
  return out;
}

}  // namespace networked_estimation
