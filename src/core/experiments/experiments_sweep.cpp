// Experiment sweep (sweep.hpp): the Monte Carlo runs of a stability map over one or two
// parameters. The axes are in sweep_axes.cpp, the analysis in sweep_analysis.cpp, the files in
// sweep_output.cpp.
#include "networked_estimation/experiments/sweep.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"

namespace networked_estimation
{

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

/// The axes, the grid's points and the analysis of a sweep, before any run.
std::shared_ptr<SweepResult> sweepGrid(const MonteCarloConfig& cfg, const CustomSetup& su)
{
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
  return sweep;
}

/// A grid point's model, estimators' settings and links.
struct SweepPoint
{
  Model model;
  std::vector<EstimatorSettings> settings;
  LossyRunOptions options;  ///< sensor_links: the point's
};

/// What every run of a sweep reads: the setup, the grid, the sizes of a run and the grid points.
struct SweepPlan
{
  const CustomSetup* su = nullptr;
  const SweepResult* sweep = nullptr;
  long T = 0, half = 0;
  std::vector<double> gw;  ///< growthWeights(T, half)
  std::size_t nf = 0, np = 0;
  /// per run: the statistics of every (point, estimator), then floored (0/1) per point
  std::size_t values = 0;
  std::uint64_t seed = 0;
  bool covariance_only = false, model_varies = false, settings_vary = false;
  /// per grid point; the first alone when every point's model and estimators are the first's
  std::vector<SweepPoint> points;
};

/// Each grid point's model, estimators' settings and links, validated here, before any run.
std::vector<SweepPoint> sweepPoints(const SweepPlan& plan)
{
  const CustomSetup& su = *plan.su;
  const std::vector<SweepAxis>& axes = plan.sweep->axes;
  std::vector<SweepPoint> points;
  points.reserve(plan.np);
  for (const std::vector<double>& v : plan.sweep->point_values)
  {
    SweepPoint pt;
    pt.model = plan.model_varies ? sweepPointModel(su.model, axes, v) : su.model;
    pt.settings = sweepPointSettings(su.settings, axes, v);
    pt.options = su.options;
    pt.options.sensor_links = sweepPointLinks(su.links.link, axes, v);
    if (plan.covariance_only)
      covarianceOnlyEstimators(pt.model, pt.settings, su.names);  // refuses aoe, oe, ekfio
    else
      for (const EstimatorSettings& es : pt.settings)
        makeEstimator(pt.model, es);
    points.push_back(std::move(pt));
    if (!plan.model_varies && !plan.settings_vary && !plan.covariance_only)
      break;  // every point's model and estimators are the first's (only the links differ)
  }
  return points;
}

/// The sizes of a run, its seed, what varies over the grid, and the grid points.
SweepPlan sweepPlan(const RunConfig& rc, const CustomSetup& su, const SweepResult& sweep)
{
  SweepPlan plan;
  plan.su = &su;
  plan.sweep = &sweep;
  plan.T = rc.steps;
  plan.half = plan.T / 2;
  plan.gw = growthWeights(plan.T, plan.half);
  plan.nf = su.settings.size();
  plan.np = static_cast<std::size_t>(sweep.points);
  plan.values = kStats * plan.nf * plan.np + plan.np;
  plan.seed = rc.seed;
  plan.covariance_only = rc.config->covariance_only;
  for (const SweepAxis& a : sweep.axes)
  {
    plan.model_varies = plan.model_varies || a.kind == SweepAxis::Kind::MODEL;
    plan.settings_vary = plan.settings_vary || a.kind == SweepAxis::Kind::SETTINGS;
  }
  plan.points = sweepPoints(plan);
  return plan;
}

/// One thread's estimators, links and plants, and the buffers of a run.
struct SweepWorker
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

/// A worker's estimators (per point when their model or settings vary, else one set for every
/// point), links and plants.
std::shared_ptr<SweepWorker> sweepWorker(const SweepPlan& plan)
{
  const std::vector<SweepPoint>& points = plan.points;
  const std::size_t np = plan.np, nf = plan.nf;
  const bool covariance_only = plan.covariance_only, model_varies = plan.model_varies;
  auto w = std::make_shared<SweepWorker>();
  const std::size_t sets = model_varies || plan.settings_vary || covariance_only ? np : 1;
  for (std::size_t p = 0; p < sets; ++p)
  {
    if (covariance_only)
      w->est.push_back(covarianceOnlyEstimators(points[p].model, points[p].settings, plan.su->names));
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
      w->links.emplace_back(m, sweepPointLinks(plan.su->links.link, plan.sweep->axes, plan.sweep->point_values[p]), 0,
                            plan.su->options.noise_on_loss);
    }
    for (std::size_t p = 0; p < (model_varies ? np : 1); ++p)
    {
      LossyRunOptions plant_options = points[p].options;
      plant_options.sensor_links.clear();  // the plant alone: the links are the point's
      w->plants.emplace_back(points[p].model, 0, plant_options);
    }
    w->traj.resize(static_cast<std::size_t>(plan.T));
    w->on.resize(static_cast<std::size_t>(plan.T));
    w->sample = w->plants.front().received();
  }
  w->alive.assign(nf, 1);
  w->trP_sum.assign(nf, 0.0);
  w->err_sum.assign(nf, 0.0);
  w->growth.assign(nf, 0.0);
  return w;
}

/// Simulates plant `plant` for run seed `rs` into the worker's trajectory; false when the plant
/// crossed the rounding floor (no statistic of this run).
bool simulateSweepPlant(SweepWorker& w, std::size_t plant, std::uint64_t rs, long T)
{
  LossyRun& run = w.plants[plant];
  run.restart(rs);
  for (long k = 0; k < T; ++k)
  {
    try
    {
      w.traj[static_cast<std::size_t>(k)] = run.step();  // same sizes: no allocation
    }
    catch (const DivergenceError&)
    {
      return false;
    }
    w.on[static_cast<std::size_t>(k)] = run.scheduled();
  }
  return true;
}

/// Step k of every live estimator on the worker's sample (s: the plant's step, null covariance
/// only), adding to the last half's sums.
void stepSweepEstimators(SweepWorker& w, std::vector<std::unique_ptr<Estimator>>& est, const SweepPlan& plan, long k,
                         const SimulatedSample* s, const std::vector<int>& angles)
{
  const bool gamma = w.sample.gamma;
  for (std::size_t j = 0; j < plan.nf; ++j)
  {
    if (!w.alive[j])
      continue;
    Estimator& e = *est[j];
    w.sample.gamma = gamma;
    w.sample.nu = s && e.algorithm() == Algorithm::ACK_KF ? (s->nu ? 1 : 0) : -1;
    try
    {
      e.step(w.sample);
    }
    catch (const DivergenceError&)
    {
      w.alive[j] = 0;
      continue;
    }
    if (k > plan.half)
    {
      const double trace = e.covariance().trace();
      w.trP_sum[j] += trace;
      if (s)
        w.err_sum[j] += squaredError(s->x, e.state(), angles);
      addGrowth(w.growth[j], plan.gw[static_cast<std::size_t>(k - plan.half - 1)], trace);
    }
  }
}

/// The statistics of every estimator at grid point p into `out` (kStats per (point, estimator)).
void sweepStatistics(const SweepWorker& w, const std::vector<std::unique_ptr<Estimator>>& est, const SweepPlan& plan,
                     std::size_t p, const std::vector<int>& angles, double* out)
{
  const long T = plan.T, half = plan.half;
  for (std::size_t j = 0; j < plan.nf; ++j)
  {
    double* o = out + kStats * (p * plan.nf + j);
    if (w.alive[j])
    {
      const Estimator& e = *est[j];
      o[0] = e.covariance().trace();
      o[1] = plan.covariance_only ? 0.0 : squaredError(w.traj[static_cast<std::size_t>(T - 1)].x, e.state(), angles);
      o[2] = w.trP_sum[j] / static_cast<double>(T - half);
      o[3] = w.err_sum[j] / static_cast<double>(T - half);
      o[5] = w.growth[j];
    }
    if (!w.alive[j] || !(std::isfinite(o[0]) && std::isfinite(o[1]) && std::isfinite(o[2]) && std::isfinite(o[3])))
    {
      std::fill(o, o + kStats, 0.0);
      o[4] = 1.0;  // diverged (covariance only: P left the doubles)
    }
  }
}

/// Run `rs` of every estimator at grid point p (its plant simulated), its statistics into `out`.
void runSweepPoint(SweepWorker& w, const SweepPlan& plan, std::size_t p, std::uint64_t rs, double* out)
{
  std::vector<std::unique_ptr<Estimator>>& est = w.est[w.est.size() > 1 ? p : 0];
  for (std::size_t j = 0; j < plan.nf; ++j)
  {
    est[j]->reset();
    w.alive[j] = 1;
    w.trP_sum[j] = w.err_sum[j] = w.growth[j] = 0.0;
  }
  const std::vector<int>& angles = plan.points[plan.model_varies ? p : 0].model.angles;
  if (plan.covariance_only)
    w.arrivals[p].restart(rs);
  else
    w.links[p].reseed(rs);
  for (long k = 1; k <= plan.T; ++k)
  {
    const SimulatedSample* s = nullptr;
    if (plan.covariance_only)
      w.sample = w.arrivals[p].next();
    else
    {
      s = &w.traj[static_cast<std::size_t>(k - 1)];
      w.links[p].receive(*s, w.on[static_cast<std::size_t>(k - 1)], w.sample);
    }
    stepSweepEstimators(w, est, plan, k, s, angles);
  }
  sweepStatistics(w, est, plan, p, angles, out);
}

/// Run r at every grid point: `simulate --seed S+r` with the point's model and links (common random
/// numbers across the grid), replayed by every estimator as in the custom experiment. When only
/// links vary, the links only decide what reaches the estimators, so one simulated plant (and
/// schedule, and actuator link) serves every point. Covariance only: each point's arrivals, no plant.
void sweepRun(SweepWorker& w, const SweepPlan& plan, long r, double* out)
{
  std::fill(out, out + plan.values, 0.0);
  const std::uint64_t rs = plan.seed + static_cast<std::uint64_t>(r);
  double* const floored = out + kStats * plan.nf * plan.np;  // per point
  const bool own_plants = !plan.covariance_only && plan.model_varies;
  if (!plan.covariance_only && !plan.model_varies && !simulateSweepPlant(w, 0, rs, plan.T))
  {
    std::fill(floored, floored + plan.np, 1.0);
    return;
  }
  for (std::size_t p = 0; p < plan.np; ++p)
  {
    if (own_plants && !simulateSweepPlant(w, p, rs, plan.T))
    {
      floored[p] = 1.0;
      continue;
    }
    runSweepPoint(w, plan, p, rs, out);
  }
}

/// Each (grid point, estimator)'s cell from the moments of the runs: empty unless every run completed.
void sweepCells(const Moments& m, const SweepPlan& plan, SweepResult& sweep)
{
  const std::size_t nf = plan.nf, np = plan.np, nt = m.thresholds.size();
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
        if (!plan.covariance_only)  // no plant: no errors
        {
          c.err_mean = m.mean[o + 1];
          c.err_sd = m.sd[o + 1];
          c.err_avg_mean = m.mean[o + 3];
          c.err_avg_sd = m.sd[o + 3];
          c.err_median = m.sketches.at(o + 1).quantile(0.5);
        }
      }
      sweep.cells.push_back(c);
    }
}

/// The assumptions of the result: the files, what an axis sets, how the runs are drawn and counted.
std::vector<std::string> sweepAssumptions(const MonteCarloConfig& cfg, const CustomSetup& su)
{
  std::string described = su.links.describe();
  for (char& ch : described)
    if (ch == '\n')
      ch = ';';
  std::vector<std::string> assumptions = {
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
  if (cfg.covariance_only)
    assumptions.push_back(
        "covariance only: no plant; every estimator runs its covariance recursion on the "
        "arrivals of run r at the point (those of `simulate --seed S+r`), so the err columns "
        "are empty and no run is floored; diverged = runs where P left the doubles");
  return assumptions;
}

}  // namespace

ExperimentResult sweepExperiment(const RunConfig& rc)
{
  const MonteCarloConfig& cfg = *rc.config;
  const CustomSetup su = loadCustomSetup(cfg, "sweep");
  const std::shared_ptr<SweepResult> sweep = sweepGrid(cfg, su);
  if (rc.progress)
    rc.progress->setTotal(rc.runs);
  const SweepPlan plan = sweepPlan(rc, su, *sweep);
  WorkerFactory factory = [&plan]() -> RunFunction
  {
    std::shared_ptr<SweepWorker> w = sweepWorker(plan);
    return [w, &plan](long r, double* out) { sweepRun(*w, plan, r, out); };
  };
  const CallStatistics stats = callStatistics(rc);
  const Moments m = runMonteCarlo(rc.runs, plan.values, rc.threads, factory, rc.progress, nullptr, &stats, rc.session);
  sweepCells(m, plan, *sweep);

  const std::vector<SweepAxis>& axes = sweep->axes;
  ExperimentResult res;
  res.x_label = axes[0].name();
  res.y_label = axes.size() > 1 ? axes[1].name() : "tr P_T";
  res.log_y = axes.size() == 1;
  res.plot.kind = PlotHints::Kind::SWEEP;  // the stability map of the "sweep" member
  res.plot.tails = false;
  res.assumptions = sweepAssumptions(cfg, su);
  res.notes = {
      "DIR/sweep.csv has one row per (grid point, estimator); DIR/sweep.json's \"sweep\" has the axes, "
      "the per-point verdicts and the critical curve (docs/formats.md, section 8)"};
  res.sweep = sweep;
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
