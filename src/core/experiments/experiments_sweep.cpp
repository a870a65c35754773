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
