// Experiment sweep: stability maps over one or two link parameters (sweep.hpp).
#include "networked_estimation/experiments/sweep.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <sstream>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/io/json_writer.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "io/tokens.hpp"

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

std::vector<LinkModel> linkModels(const std::vector<std::optional<ChannelSettings>>& links)
{
  std::vector<LinkModel> v;
  for (const auto& l : links)
    v.push_back(l ? LinkModel::fromSettings(*l) : LinkModel::iid(1.0));
  return v;
}

/// %.10g, or `null_text` for NaN / infinity.
std::string sweepNumber(double v, const char* null_text)
{
  return std::isfinite(v) ? mc::fmt(v) : null_text;
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

namespace
{

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

SweepAnalysis analyseSweep(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                           const std::vector<SweepAxis>& axes)
{
  SweepAnalysis out;
  std::vector<int> all;
  for (std::size_t s = 0; s < model.sensors.size(); ++s)
    all.push_back(static_cast<int>(s));
  const std::vector<double>& v1 = axes.front().values;
  const std::vector<double> v2 = axes.size() > 1 ? axes[1].values : std::vector<double>{0.0};
  for (double a : v1)
    for (double b : v2)
    {
      const std::vector<double> point = axes.size() > 1 ? std::vector<double>{a, b} : std::vector<double>{a};
      out.verdicts.push_back(toString(
          stabilityVerdict(sweepPointModel(model, axes, point), all, linkModels(sweepPointLinks(links, axes, point)))
              .kind));
    }
  const SweepAxis& last = axes.back();
  const bool rate = last.kind == SweepAxis::Kind::LINK &&
                    (last.param == "arrival_rate" || last.param == "recovery_rate" || last.param == "r");
  const std::string quantity = last.param == "arrival_rate" ? "arrival rate" : "recovery rate";
  for (std::size_t i = 0; i < (axes.size() > 1 ? v1.size() : 1); ++i)
  {
    SweepAnalysis::Critical c;
    if (axes.size() > 1)
      c.at = v1[i];
    if (!rate)
    {
      c.note = "not applicable: the analysis gives critical arrival and recovery rates, not a critical " + last.name();
      out.critical.push_back(c);
      continue;
    }
    const std::vector<double> point =
        axes.size() > 1 ? std::vector<double>{v1[i], last.values.front()} : std::vector<double>{last.values.front()};
    const std::vector<SensorMargin> margins =
        sensorMargins(sweepPointModel(model, axes, point), linkModels(sweepPointLinks(links, axes, point)));
    const SensorMargin& m = margins.at(static_cast<std::size_t>(last.sensor_index));
    c.note = m.note;
    c.half_line = m.half_line;
    if (m.quantity != quantity)
      c.note = "not applicable: " + (m.quantity.empty() ? m.note : "the margin is on the " + m.quantity);
    else if (m.half_line)
    {
      c.diverges_at = m.band.diverges_at;
      c.converges_at = m.band.converges_at;
      c.undecided_band = m.band.undecided_band;
    }
    else
      c.note = "the stable set along " + last.name() + " is not a half-line (no single critical value): " + m.note;
    out.critical.push_back(c);
  }
  return out;
}

std::string sweepCsv(const SweepResult& sw)
{
  std::ostringstream os;
  os << "point,i1,i2,x1,x2,estimator,n,diverged,floored,trP_mean,trP_sd,err_mean,err_sd,trP_avg_mean,trP_avg_sd,"
        "err_avg_mean,err_avg_sd,verdict,trP_se,trP_p5,trP_p25,trP_median,trP_p75,trP_p95,err_se,err_median,growth,"
        "growth_low,growth_high";
  for (double t : sw.thresholds)
    os << ",trP_" << thresholdColumn(t);
  os << '\n';
  const long n2 = sw.axes.size() > 1 ? sw.axes[1].count : 1;
  for (long p = 0; p < sw.points; ++p)
  {
    const std::vector<double>& v = sw.point_values[static_cast<std::size_t>(p)];
    for (std::size_t j = 0; j < sw.estimators.size(); ++j)
    {
      const SweepCell& c = sw.cells[static_cast<std::size_t>(p) * sw.estimators.size() + j];
      os << p << ',' << p / n2 << ',' << (sw.axes.size() > 1 ? p % n2 : 0) << ',' << mc::fmt(v[0]) << ','
         << (v.size() > 1 ? mc::fmt(v[1]) : "") << ',' << sw.estimators[j] << ',' << c.n << ',' << c.diverged << ','
         << c.floored;
      for (double x :
           {c.trP_mean, c.trP_sd, c.err_mean, c.err_sd, c.trP_avg_mean, c.trP_avg_sd, c.err_avg_mean, c.err_avg_sd})
        os << ',' << sweepNumber(x, "");
      os << ',' << sw.analysis.verdicts[static_cast<std::size_t>(p)];
      const double rn = std::sqrt(static_cast<double>(c.n));
      const double half = 1.96 * c.growth_sd / rn;  // the 95 % interval of the mean over the runs
      for (double x : {c.trP_sd / rn, c.trP_p5, c.trP_p25, c.trP_median, c.trP_p75, c.trP_p95, c.err_sd / rn,
                       c.err_median, c.growth, c.growth - half, c.growth + half})
        os << ',' << sweepNumber(x, "");
      for (std::size_t t = 0; t < sw.thresholds.size(); ++t)
        os << ',' << (t < c.trP_exceed.size() ? sweepNumber(c.trP_exceed[t], "") : "");
      os << '\n';
    }
  }
  return os.str();
}

void writeSweepJson(JsonWriter& w, const SweepResult& sw, int in)
{
  w.beginObject();
  w.br(in + 2).key("axes").beginArray();
  for (const SweepAxis& a : sw.axes)
  {
    w.br(in + 4).beginObject().member("name", a.name()).member("sensor", a.sensor).member("param", a.param);
    w.member("arg", a.arg).member("lo", mc::rounded(a.lo)).member("hi", mc::rounded(a.hi)).member("count", a.count);
    w.key("values").beginArray();
    for (double v : a.values)
      w.value(mc::rounded(v));
    w.endArray().endObject();
  }
  w.br(in + 2).endArray();
  w.br(in + 2).member("estimators", sw.estimators);
  w.br(in + 2).member("points", sw.points);
  long incomplete = 0;
  for (const SweepCell& c : sw.cells)
    incomplete += (c.diverged > 0 || c.floored > 0) ? 1 : 0;
  w.br(in + 2).member("incomplete_cells", incomplete);
  w.br(in + 2).member("verdicts", sw.analysis.verdicts);
  const SweepAxis& last = sw.axes.back();
  w.br(in + 2).key("critical").beginObject().member("axis", last.name()).key("along");
  if (sw.axes.size() > 1)
    w.value(sw.axes[0].name());
  else
    w.null();
  w.key("curve").beginArray();
  for (const SweepAnalysis::Critical& c : sw.analysis.critical)
  {
    w.br(in + 4).beginObject().member("at", mc::rounded(c.at)).member("diverges_at", mc::rounded(c.diverges_at));
    w.member("converges_at", mc::rounded(c.converges_at)).member("undecided_band", c.undecided_band);
    w.member("half_line", c.half_line).member("note", c.note).endObject();
  }
  w.br(in + 2).endArray().endObject();
  w.br(in).endObject();
}

namespace mc
{

namespace
{

// Per run, grid point and estimator (point-major): tr P_T, |x_T - xhat_T|^2, their means over the
// last half, diverged (0/1), the growth exponent of log tr P_k over the last half; then per grid
// point: floored (0/1; the same at every point when the points share one plant).
constexpr std::size_t kStats = 6;

/// The least-squares slope of log tr P_k over k = half+1 .. T as weights: sum of w_k log tr P_k.
std::vector<double> growthWeights(long T, long half)
{
  std::vector<double> w;
  const double km = 0.5 * static_cast<double>(half + 1 + T);
  double sxx = 0.0;
  for (long k = half + 1; k <= T; ++k)
    sxx += (static_cast<double>(k) - km) * (static_cast<double>(k) - km);
  for (long k = half + 1; k <= T; ++k)
    w.push_back(sxx > 0.0 ? (static_cast<double>(k) - km) / sxx : std::nan(""));
  return w;
}

/// Adds tr P_k's term of the growth exponent (NaN once a trace is not finite and positive).
inline void addGrowth(double& g, double w, double trace)
{
  g += trace > 0.0 && trace <= std::numeric_limits<double>::max() ? w * std::log(trace) : std::nan("");
}

}  // namespace

ExperimentResult sweepExperiment(const RunConfig& rc)
{
  const MonteCarloConfig& cfg = *rc.config;
  const CustomSetup su = loadCustomSetup(cfg, "sweep");
  const Model& model = su.model;
  auto sweep = std::make_shared<SweepResult>();
  for (const std::string& arg : cfg.axis_args)
    sweep->axes.push_back(parseSweepAxis(arg));
  resolveSweepAxes(sweep->axes, model, su.links.link, su.names, su.settings);
  sweep->estimators = su.names;
  sweep->thresholds = cfg.thresholds;
  const std::vector<SweepAxis>& axes = sweep->axes;
  for (double a : axes[0].values)
    for (double b : axes.size() > 1 ? axes[1].values : std::vector<double>{0.0})
      sweep->point_values.push_back(axes.size() > 1 ? std::vector<double>{a, b} : std::vector<double>{a});
  sweep->points = static_cast<long>(sweep->point_values.size());
  // a built-in motion: the verdicts of its linearisation at x0 (local, docs/stability.md 5)
  sweep->analysis = analyseSweep(linearisedModel(model, model.x0, model.period), su.links.link, axes);

  if (rc.progress)
    rc.progress->setTotal(rc.runs);
  const long T = rc.steps, half = T / 2;
  const std::vector<double> gw = growthWeights(T, half);
  const std::size_t nf = su.settings.size(), np = static_cast<std::size_t>(sweep->points);
  // per run: the statistics of every (point, estimator), then floored (0/1) per point
  const std::size_t values = kStats * nf * np + np;
  const std::uint64_t seed = rc.seed;
  const bool covariance_only = cfg.covariance_only;
  bool model_varies = false, settings_vary = false;
  for (const SweepAxis& a : axes)
  {
    model_varies = model_varies || a.kind == SweepAxis::Kind::MODEL;
    settings_vary = settings_vary || a.kind == SweepAxis::Kind::SETTINGS;
  }
  // Each grid point's model, estimators' settings and links (validated here, before any run).
  struct Point
  {
    Model model;
    std::vector<EstimatorSettings> settings;
    LossyRunOptions options;  ///< sensor_links: the point's
  };
  std::vector<Point> points;
  points.reserve(np);
  for (const std::vector<double>& v : sweep->point_values)
  {
    Point pt;
    pt.model = model_varies ? sweepPointModel(model, axes, v) : model;
    pt.settings = sweepPointSettings(su.settings, axes, v);
    pt.options = su.options;
    pt.options.sensor_links = sweepPointLinks(su.links.link, axes, v);
    if (covariance_only)
      covarianceOnlyEstimators(pt.model, pt.settings, su.names);  // refuses aoe, oe, ekfio
    else
      for (const EstimatorSettings& es : pt.settings)
        makeEstimator(pt.model, es);
    points.push_back(std::move(pt));
    if (!model_varies && !settings_vary && !covariance_only)
      break;  // every point's model and estimators are the first's (only the links differ)
  }
  const bool noise_on_loss = su.options.noise_on_loss;
  const std::vector<std::string>& names = su.names;
  const std::vector<std::optional<ChannelSettings>>& base_links = su.links.link;
  // Run r at every point is `simulate --seed S+r` with the point's model and links (common random
  // numbers across the grid), replayed by every estimator as in the custom experiment. When only
  // links vary, the links only decide what reaches the estimators, so one simulated plant (and
  // schedule, and actuator link) serves every point. Covariance only: each point's arrivals, no plant.
  WorkerFactory factory = [&, T, half, nf, np, values, noise_on_loss, covariance_only, model_varies, settings_vary,
                           seed]() -> RunFunction
  {
    struct Worker
    {
      std::vector<std::vector<std::unique_ptr<Estimator>>> est;  // per point (or one set for every point)
      std::vector<ArrivalDraws> arrivals;                        // per point, covariance only
      std::vector<SensorLinkSet> links;                          // per point
      std::vector<LossyRun> plants;                              // per point, or one
      std::vector<SimulatedSample> traj;
      std::vector<std::vector<bool>> on;
      std::vector<char> alive;
      std::vector<double> trP_sum, err_sum, growth;
      Sample sample;
    };
    auto w = std::make_shared<Worker>();
    const std::size_t sets = model_varies || settings_vary || covariance_only ? np : 1;
    for (std::size_t p = 0; p < sets; ++p)
    {
      if (covariance_only)
        w->est.push_back(covarianceOnlyEstimators(points[p].model, points[p].settings, names));
      else
      {
        std::vector<std::unique_ptr<Estimator>> e;
        for (const EstimatorSettings& es : points[p].settings)
          e.push_back(makeEstimator(points[p].model, es));
        w->est.push_back(std::move(e));
      }
    }
    // reserved: the elements keep their addresses (a link set and a plant point at their model)
    w->arrivals.reserve(covariance_only ? np : 0);
    w->links.reserve(covariance_only ? 0 : np);
    w->plants.reserve(covariance_only ? 0 : model_varies ? np : 1);
    if (covariance_only)
      for (std::size_t p = 0; p < np; ++p)
        w->arrivals.emplace_back(points[p].model, points[p].options);
    else
    {
      for (std::size_t p = 0; p < np; ++p)
      {
        const Model& m = points[model_varies ? p : 0].model;
        w->links.emplace_back(m, sweepPointLinks(base_links, axes, sweep->point_values[p]), 0, noise_on_loss);
      }
      for (std::size_t p = 0; p < (model_varies ? np : 1); ++p)
      {
        LossyRunOptions plant_options = points[p].options;
        plant_options.sensor_links.clear();  // the plant alone: the links are the point's
        w->plants.emplace_back(points[p].model, 0, plant_options);
      }
      w->traj.resize(static_cast<std::size_t>(T));
      w->on.resize(static_cast<std::size_t>(T));
      w->sample = w->plants.front().received();
    }
    w->alive.assign(nf, 1);
    w->trP_sum.assign(nf, 0.0);
    w->err_sum.assign(nf, 0.0);
    w->growth.assign(nf, 0.0);
    return [w, &gw, &points, T, half, nf, np, values, covariance_only, model_varies, seed](long r, double* out)
    {
      std::fill(out, out + values, 0.0);
      const std::uint64_t rs = seed + static_cast<std::uint64_t>(r);
      double* const floored = out + kStats * nf * np;  // per point
      auto simulate = [&](std::size_t plant)
      {
        LossyRun& run = w->plants[plant];
        run.restart(rs);
        for (long k = 0; k < T; ++k)
        {
          try
          {
            w->traj[static_cast<std::size_t>(k)] = run.step();  // same sizes: no allocation
          }
          catch (const DivergenceError&)
          {
            return false;  // the plant crossed the rounding floor: no statistic of this run
          }
          w->on[static_cast<std::size_t>(k)] = run.scheduled();
        }
        return true;
      };
      bool plant_ok = true;
      if (!covariance_only && !model_varies)
      {
        plant_ok = simulate(0);
        if (!plant_ok)
        {
          std::fill(floored, floored + np, 1.0);
          return;
        }
      }
      for (std::size_t p = 0; p < np; ++p)
      {
        std::vector<std::unique_ptr<Estimator>>& est = w->est[w->est.size() > 1 ? p : 0];
        if (!covariance_only && model_varies && !simulate(p))
        {
          floored[p] = 1.0;
          continue;
        }
        for (std::size_t j = 0; j < nf; ++j)
        {
          est[j]->reset();
          w->alive[j] = 1;
          w->trP_sum[j] = w->err_sum[j] = w->growth[j] = 0.0;
        }
        const std::vector<int>& angles = points[model_varies ? p : 0].model.angles;
        if (covariance_only)
          w->arrivals[p].restart(rs);
        else
          w->links[p].reseed(rs);
        for (long k = 1; k <= T; ++k)
        {
          const SimulatedSample* s = nullptr;
          if (covariance_only)
            w->sample = w->arrivals[p].next();
          else
          {
            s = &w->traj[static_cast<std::size_t>(k - 1)];
            w->links[p].receive(*s, w->on[static_cast<std::size_t>(k - 1)], w->sample);
          }
          const bool gamma = w->sample.gamma;
          for (std::size_t j = 0; j < nf; ++j)
          {
            if (!w->alive[j])
              continue;
            Estimator& e = *est[j];
            w->sample.gamma = gamma;
            w->sample.nu = s && e.algorithm() == Algorithm::ACK_KF ? (s->nu ? 1 : 0) : -1;
            try
            {
              e.step(w->sample);
            }
            catch (const DivergenceError&)
            {
              w->alive[j] = 0;
              continue;
            }
            if (k > half)
            {
              const double trace = e.covariance().trace();
              w->trP_sum[j] += trace;
              if (s)
                w->err_sum[j] += squaredError(s->x, e.state(), angles);
              addGrowth(w->growth[j], gw[static_cast<std::size_t>(k - half - 1)], trace);
            }
          }
        }
        for (std::size_t j = 0; j < nf; ++j)
        {
          double* o = out + kStats * (p * nf + j);
          if (w->alive[j])
          {
            const Estimator& e = *est[j];
            o[0] = e.covariance().trace();
            o[1] = covariance_only ? 0.0 : squaredError(w->traj[static_cast<std::size_t>(T - 1)].x, e.state(), angles);
            o[2] = w->trP_sum[j] / static_cast<double>(T - half);
            o[3] = w->err_sum[j] / static_cast<double>(T - half);
            o[5] = w->growth[j];
          }
          if (!w->alive[j] ||
              !(std::isfinite(o[0]) && std::isfinite(o[1]) && std::isfinite(o[2]) && std::isfinite(o[3])))
          {
            std::fill(o, o + kStats, 0.0);
            o[4] = 1.0;  // diverged (covariance only: P left the doubles)
          }
        }
      }
    };
  };

  const CallStatistics stats = callStatistics(rc);
  const Moments m = runMonteCarlo(rc.runs, values, rc.threads, factory, rc.progress, nullptr, &stats, rc.session);
  const std::size_t nt = m.thresholds.size();
  for (std::size_t p = 0; p < np; ++p)
    for (std::size_t j = 0; j < nf; ++j)
    {
      const std::size_t o = kStats * (p * nf + j);
      SweepCell c;
      c.n = m.n;
      c.floored = std::lround(m.mean[kStats * nf * np + p] * static_cast<double>(m.n));
      c.diverged = std::lround(m.mean[o + 4] * static_cast<double>(m.n));
      if (c.n > 0 && c.diverged == 0 && c.floored == 0)
      {
        c.trP_mean = m.mean[o];
        c.trP_sd = m.sd[o];
        c.trP_avg_mean = m.mean[o + 2];
        c.trP_avg_sd = m.sd[o + 2];
        const QuantileSketch& q = m.sketches.at(o);
        c.trP_p5 = q.quantile(0.05);
        c.trP_p25 = q.quantile(0.25);
        c.trP_median = q.quantile(0.5);
        c.trP_p75 = q.quantile(0.75);
        c.trP_p95 = q.quantile(0.95);
        for (std::size_t t = 0; t < nt; ++t)
          c.trP_exceed.push_back(m.exceed.at(o * nt + t));
        c.growth = m.mean[o + 5];
        c.growth_sd = m.sd[o + 5];
        if (!covariance_only)  // no plant: no errors
        {
          c.err_mean = m.mean[o + 1];
          c.err_sd = m.sd[o + 1];
          c.err_avg_mean = m.mean[o + 3];
          c.err_avg_sd = m.sd[o + 3];
          c.err_median = m.sketches.at(o + 1).quantile(0.5);
        }
      }
      sweep->cells.push_back(c);
    }

  ExperimentResult res;
  res.x_label = axes[0].name();
  res.y_label = axes.size() > 1 ? axes[1].name() : "tr P_T";
  res.log_y = axes.size() == 1;
  res.plot.kind = PlotHints::Kind::SWEEP;  // the stability map of the "sweep" member
  res.plot.tails = false;
  std::string described = su.links.describe();
  for (char& ch : described)
    if (ch == '\n')
      ch = ';';
  res.assumptions = {
      "model " + cfg.model_path + "; links " + described +
          (cfg.actuator_channel_path.empty() ? "" : "; actuator " + cfg.actuator_channel_path),
      "at each grid point the swept parameters take the point's values: SENSOR.arrival_rate = an i.i.d. (bernoulli) "
      "link with P(arrived) = value, SENSOR.KEY = that key of the sensor's link (recovery_rate = r), ESTIMATOR.KEY "
      "= that key of the estimator's settings, model.A[i][j] and model.C[i][j] = that entry, model.Q* and model.R* "
      "= Q and R times the value",
      "run r at every grid point is `simulate --seed S+r` with that point's model and links (S = --seed: common "
      "random numbers across the grid), replayed by every estimator as in the custom experiment",
      "per grid point and estimator: mean and sd over the runs of tr P_T and |x_T - xhat_T|^2 at k = T = steps, and "
      "of their means over the last half of the horizon, k = floor(T/2)+1 .. T",
      "a cell's statistics are empty (CSV) / absent unless every run completed: diverged = runs where the estimator "
      "failed (covariance not finite or not positive definite), floored = runs where the plant state crossed the "
      "rounding floor (use fewer --steps for an unstable plant)",
      "verdicts and the critical curve: the core stability analysis (analyze's verdict and per-sensor margin) at "
      "each point's model and links; a critical curve only along an arrival or recovery rate",
  };
  if (covariance_only)
    res.assumptions.push_back(
        "covariance only: no plant; every estimator runs its covariance recursion on the "
        "arrivals of run r at the point (those of `simulate --seed S+r`), so the err columns "
        "are empty and no run is floored; diverged = runs where P left the doubles");
  res.notes = {
      "DIR/sweep.csv has one row per (grid point, estimator); DIR/sweep.json's \"sweep\" has the axes, "
      "the per-point verdicts and the critical curve (docs/formats.md, section 8)"};
  res.sweep = sweep;
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
