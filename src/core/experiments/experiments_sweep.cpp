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
  static const std::vector<std::string> p = {"arrival_rate", "recovery_rate"};
  return p;
}

std::vector<double> sweepValues(double lo, double hi, long n)
{
  std::vector<double> v;
  for (long i = 0; i < n; ++i)
    v.push_back(n == 1 || i == 0 ? lo
                                 : i == n - 1 ? hi : lo + (hi - lo) * static_cast<double>(i) / static_cast<double>(n - 1));
  return v;
}

SweepAxis parseSweepAxis(const std::string& arg)
{
  const std::string form = "expected SENSOR.PARAM=LO:HI:N, e.g. gnss.arrival_rate=0.05:0.95:19";
  SweepAxis a;
  a.arg = arg;
  const std::string::size_type eq = arg.find('=');
  if (eq == std::string::npos)
    axisError(arg, form);
  const std::string name = arg.substr(0, eq);
  const std::string::size_type dot = name.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == name.size())
    axisError(arg, form);
  a.sensor = name.substr(0, dot);
  a.param = name.substr(dot + 1);
  std::string valid;
  for (const std::string& p : sweepParameters())
    valid += (valid.empty() ? "" : ", ") + p;
  if (a.sensor == "schedule")
    axisError(arg, "the schedule is not swept (only link parameters: SENSOR." + valid + ")");
  if (std::find(sweepParameters().begin(), sweepParameters().end(), a.param) == sweepParameters().end())
    axisError(arg, "unknown parameter '" + a.param + "' (valid: " + valid + ")");
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
  if (a.lo < 0.0 || a.hi > 1.0)
    axisError(arg, a.param + " must lie in [0, 1], the range is [" + mc::fmt(a.lo) + ", " + mc::fmt(a.hi) + "]");
  a.values = sweepValues(a.lo, a.hi, a.count);
  return a;
}

void resolveSweepAxes(std::vector<SweepAxis>& axes, const Model& model,
                      const std::vector<std::optional<ChannelSettings>>& links)
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
    for (std::size_t s = 0; s < model.sensors.size(); ++s)
      if (model.sensors[s].name == a.sensor)
        a.sensor_index = static_cast<int>(s);
    if (a.sensor_index < 0)
      axisError(a.arg, "no sensor '" + a.sensor + "' in model '" + model.name + "' (sensors: " + sensors + ")");
    const auto& link = links.at(static_cast<std::size_t>(a.sensor_index));
    if (a.param == "recovery_rate" && (!link || link->model != LossModelKind::GILBERT_ELLIOTT))
      axisError(a.arg, "recovery_rate needs a gilbert_elliott link on sensor '" + a.sensor +
                           "' (--channel " + a.sensor + "=FILE; its p, loss_bad and loss_good are kept)");
    for (std::size_t j = 0; j < i; ++j)
      if (axes[j].sensor_index == a.sensor_index)
        axisError(a.arg, "sensor '" + a.sensor + "' is already swept by --axis '" + axes[j].arg + "'");
  }
  if (axes.size() == 2 && axes[0].count * axes[1].count > kMaxGridPoints)
    throw ConfigError("--axis '" + axes[0].arg + "' x --axis '" + axes[1].arg + "': " + std::to_string(axes[0].count) +
                      " x " + std::to_string(axes[1].count) + " = " + std::to_string(axes[0].count * axes[1].count) +
                      " grid points, at most " + std::to_string(kMaxGridPoints) + " (split the grid into several sweeps)");
}

std::vector<std::optional<ChannelSettings>> sweepPointLinks(const std::vector<std::optional<ChannelSettings>>& links,
                                                            const std::vector<SweepAxis>& axes,
                                                            const std::vector<double>& values)
{
  std::vector<std::optional<ChannelSettings>> out = links;
  for (std::size_t i = 0; i < axes.size(); ++i)
  {
    std::optional<ChannelSettings>& l = out.at(static_cast<std::size_t>(axes[i].sensor_index));
    ChannelSettings c = l ? *l : ChannelSettings{};
    if (axes[i].param == "arrival_rate")
    {
      c.model = LossModelKind::BERNOULLI;
      c.loss = 1.0 - values[i];
    }
    else
      c.r = values[i];
    l = c;
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
      out.verdicts.push_back(toString(stabilityVerdict(model, all, linkModels(sweepPointLinks(links, axes, point))).kind));
    }
  const SweepAxis& last = axes.back();
  const std::string quantity = last.param == "arrival_rate" ? "arrival rate" : "recovery rate";
  for (std::size_t i = 0; i < (axes.size() > 1 ? v1.size() : 1); ++i)
  {
    const std::vector<double> point =
        axes.size() > 1 ? std::vector<double>{v1[i], last.values.front()} : std::vector<double>{last.values.front()};
    const std::vector<SensorMargin> margins =
        sensorMargins(model, linkModels(sweepPointLinks(links, axes, point)));
    const SensorMargin& m = margins.at(static_cast<std::size_t>(last.sensor_index));
    SweepAnalysis::Critical c;
    if (axes.size() > 1)
      c.at = v1[i];
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
      for (double x : {c.trP_mean, c.trP_sd, c.err_mean, c.err_sd, c.trP_avg_mean, c.trP_avg_sd, c.err_avg_mean,
                       c.err_avg_sd})
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
// last half, diverged (0/1), the growth exponent of log tr P_k over the last half; then one value
// per run: floored (0/1).
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
  resolveSweepAxes(sweep->axes, model, su.links.link);
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
  const std::size_t values = kStats * nf * np + 1;
  const std::uint64_t seed = rc.seed;
  const std::vector<EstimatorSettings>& settings = su.settings;
  std::vector<std::vector<std::optional<ChannelSettings>>> point_links;
  for (const std::vector<double>& v : sweep->point_values)
    point_links.push_back(sweepPointLinks(su.links.link, axes, v));
  // Plant without sensor links: the links only decide what reaches the estimators, so one
  // simulated plant (and schedule, and actuator link) serves every grid point of a run.
  LossyRunOptions plant_options = su.options;
  plant_options.sensor_links.clear();
  const bool noise_on_loss = su.options.noise_on_loss;
  const bool covariance_only = cfg.covariance_only;
  if (covariance_only)
    covarianceOnlyEstimators(model, su.settings, su.names);  // refuses aoe, oe, ekfio before any run
  // covariance only: each point's arrivals (its links and the schedule) without the plant
  std::vector<LossyRunOptions> point_options;
  for (const auto& l : point_links)
  {
    point_options.push_back(su.options);
    point_options.back().sensor_links = l;
  }
  // Run r at every point is `simulate --seed S+r` with that point's links (common random numbers
  // across the grid), replayed by every estimator as in the custom experiment. One Monte Carlo call
  // of all the points: per run, the plant once, then each point's links and estimators.
  WorkerFactory factory = [&model, &settings, &plant_options, &point_links, &point_options, &su, &gw, T, half, nf,
                           np, values, noise_on_loss, covariance_only, seed]() -> RunFunction {
    struct Worker
    {
      std::vector<std::unique_ptr<Estimator>> est;
      std::vector<ArrivalDraws> arrivals;  // per grid point, covariance only
      std::vector<SensorLinkSet> links;  // per grid point
      std::optional<LossyRun> plant;     // restarted for every run: no allocation per run
      std::vector<SimulatedSample> traj;
      std::vector<std::vector<bool>> on;
      std::vector<char> alive;
      std::vector<double> trP_sum, err_sum, growth;
      std::vector<int> angles;  // the model's: their errors wrapped
      Sample sample;
    };
    auto w = std::make_shared<Worker>();
    if (covariance_only)
    {
      w->est = covarianceOnlyEstimators(model, settings, su.names);
      for (const LossyRunOptions& o : point_options)
        w->arrivals.emplace_back(model, o);
      w->alive.assign(nf, 1);
      w->trP_sum.assign(nf, 0.0);
      w->growth.assign(nf, 0.0);
      return [w, &gw, T, half, nf, np, values, seed](long r, double* out) {
        std::fill(out, out + values, 0.0);
        const std::uint64_t rs = seed + static_cast<std::uint64_t>(r);
        for (std::size_t p = 0; p < np; ++p)
        {
          ArrivalDraws& arrivals = w->arrivals[p];
          arrivals.restart(rs);
          for (std::size_t j = 0; j < nf; ++j)
          {
            w->est[j]->reset();
            w->alive[j] = 1;
            w->trP_sum[j] = w->growth[j] = 0.0;
          }
          for (long k = 1; k <= T; ++k)
          {
            const Sample& sample = arrivals.next();
            for (std::size_t j = 0; j < nf; ++j)
            {
              if (!w->alive[j])
                continue;
              try
              {
                w->est[j]->step(sample);
              }
              catch (const DivergenceError&)
              {
                w->alive[j] = 0;
                continue;
              }
              if (k > half)
              {
                const double trace = w->est[j]->covariance().trace();
                w->trP_sum[j] += trace;
                addGrowth(w->growth[j], gw[static_cast<std::size_t>(k - half - 1)], trace);
              }
            }
          }
          for (std::size_t j = 0; j < nf; ++j)
          {
            double* o = out + kStats * (p * nf + j);
            if (w->alive[j])
            {
              o[0] = w->est[j]->covariance().trace();
              o[2] = w->trP_sum[j] / static_cast<double>(T - half);
              o[5] = w->growth[j];
            }
            if (!w->alive[j] || !(std::isfinite(o[0]) && std::isfinite(o[2])))
            {
              std::fill(o, o + kStats, 0.0);
              o[4] = 1.0;  // diverged: P left the doubles
            }
          }
        }
      };
    }
    for (const EstimatorSettings& s : settings)
      w->est.push_back(makeEstimator(model, s));
    for (const auto& l : point_links)
      w->links.emplace_back(model, l, 0, noise_on_loss);
    w->plant.emplace(model, 0, plant_options);
    w->traj.resize(static_cast<std::size_t>(T));
    w->on.resize(static_cast<std::size_t>(T));
    w->alive.assign(nf, 1);
    w->trP_sum.assign(nf, 0.0);
    w->err_sum.assign(nf, 0.0);
    w->growth.assign(nf, 0.0);
    w->angles = model.angles;
    w->sample = w->plant->received();
    return [w, &gw, T, half, nf, np, values, seed](long r, double* out) {
      std::fill(out, out + values, 0.0);
      const std::uint64_t rs = seed + static_cast<std::uint64_t>(r);
      LossyRun& plant = *w->plant;
      plant.restart(rs);
      for (long k = 0; k < T; ++k)
      {
        try
        {
          w->traj[static_cast<std::size_t>(k)] = plant.step();  // same sizes: no allocation
        }
        catch (const DivergenceError&)
        {
          out[values - 1] = 1.0;  // the plant crossed the rounding floor: no statistic of this run
          return;
        }
        w->on[static_cast<std::size_t>(k)] = plant.scheduled();
      }
      for (std::size_t p = 0; p < np; ++p)
      {
        SensorLinkSet& links = w->links[p];
        links.reseed(rs);
        for (std::size_t j = 0; j < nf; ++j)
        {
          w->est[j]->reset();
          w->alive[j] = 1;
          w->trP_sum[j] = w->err_sum[j] = w->growth[j] = 0.0;
        }
        for (long k = 1; k <= T; ++k)
        {
          const SimulatedSample& s = w->traj[static_cast<std::size_t>(k - 1)];
          links.receive(s, w->on[static_cast<std::size_t>(k - 1)], w->sample);
          const bool gamma = w->sample.gamma;
          for (std::size_t j = 0; j < nf; ++j)
          {
            if (!w->alive[j])
              continue;
            Estimator& e = *w->est[j];
            w->sample.gamma = gamma;
            w->sample.nu = e.algorithm() == Algorithm::ACK_KF ? (s.nu ? 1 : 0) : -1;
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
              w->err_sum[j] += squaredError(s.x, e.state(), w->angles);
              addGrowth(w->growth[j], gw[static_cast<std::size_t>(k - half - 1)], trace);
            }
          }
        }
        const SimulatedSample& last = w->traj[static_cast<std::size_t>(T - 1)];
        for (std::size_t j = 0; j < nf; ++j)
        {
          double* o = out + kStats * (p * nf + j);
          if (w->alive[j])
          {
            const Estimator& e = *w->est[j];
            o[0] = e.covariance().trace();
            o[1] = squaredError(last.x, e.state(), w->angles);
            o[2] = w->trP_sum[j] / static_cast<double>(T - half);
            o[3] = w->err_sum[j] / static_cast<double>(T - half);
            o[5] = w->growth[j];
          }
          if (!w->alive[j] ||
              !(std::isfinite(o[0]) && std::isfinite(o[1]) && std::isfinite(o[2]) && std::isfinite(o[3])))
          {
            std::fill(o, o + kStats, 0.0);
            o[4] = 1.0;  // diverged
          }
        }
      }
    };
  };

  const CallStatistics stats = callStatistics(rc);
  const Moments m = runMonteCarlo(rc.runs, values, rc.threads, factory, rc.progress, nullptr, &stats);
  const long floored = std::lround(m.mean[values - 1] * static_cast<double>(m.n));
  const std::size_t nt = m.thresholds.size();
  for (std::size_t p = 0; p < np; ++p)
    for (std::size_t j = 0; j < nf; ++j)
    {
      const std::size_t o = kStats * (p * nf + j);
      SweepCell c;
      c.n = m.n;
      c.floored = floored;
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
  std::string described = su.links.describe();
  for (char& ch : described)
    if (ch == '\n')
      ch = ';';
  res.assumptions = {
      "model " + cfg.model_path + "; links " + described +
          (cfg.actuator_channel_path.empty() ? "" : "; actuator " + cfg.actuator_channel_path),
      "at each grid point the swept sensors' links are replaced: SENSOR.arrival_rate = an i.i.d. (bernoulli) link "
      "with P(arrived) = value, SENSOR.recovery_rate = the sensor's gilbert_elliott link with r = value",
      "run r at every grid point is `simulate --seed S+r` with that point's links (S = --seed: common random numbers "
      "across the grid), replayed by every estimator as in the custom experiment",
      "per grid point and estimator: mean and sd over the runs of tr P_T and |x_T - xhat_T|^2 at k = T = steps, and "
      "of their means over the last half of the horizon, k = floor(T/2)+1 .. T",
      "a cell's statistics are empty (CSV) / absent unless every run completed: diverged = runs where the estimator "
      "failed (covariance not finite or not positive definite), floored = runs where the plant state crossed the "
      "rounding floor (use fewer --steps for an unstable plant)",
      "verdicts and the critical curve: the core stability analysis (analyze's verdict and per-sensor margin) at "
      "each point's links",
  };
  if (covariance_only)
    res.assumptions.push_back("covariance only: no plant; every estimator runs its covariance recursion on the "
                              "arrivals of run r at the point (those of `simulate --seed S+r`), so the err columns "
                              "are empty and no run is floored; diverged = runs where P left the doubles");
  res.notes = {"DIR/sweep.csv has one row per (grid point, estimator); DIR/sweep.json's \"sweep\" has the axes, "
               "the per-point verdicts and the critical curve (docs/formats.md, section 8)"};
  res.sweep = sweep;
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
