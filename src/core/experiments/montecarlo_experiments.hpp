// Private: the experiments of montecarlo.cpp and small shared helpers.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "networked_estimation/simulation/schedule_sampler.hpp"

namespace networked_estimation
{
namespace mc
{

/// Everything an experiment needs: resolved runs/steps/threads and the seed.
struct RunConfig
{
  long runs = 0, steps = 0;
  std::uint64_t seed = 1;
  int threads = 1;
  const MonteCarloConfig* config = nullptr;
  ProgressCounter* progress = nullptr;
};

ExperimentResult zhouFig1(const RunConfig& rc);
ExperimentResult zhouFig2(const RunConfig& rc);
ExperimentResult customExperiment(const RunConfig& rc);
/// custom --covariance-only (experiments_covariance.cpp).
ExperimentResult covarianceExperiment(const RunConfig& rc);
ExperimentResult sweepExperiment(const RunConfig& rc);
ExperimentResult linFig2(const RunConfig& rc);
ExperimentResult linFig3(const RunConfig& rc);
ExperimentResult linFig4(const RunConfig& rc);
ExperimentResult linFig5(const RunConfig& rc);
ExperimentResult yangFig2(const RunConfig& rc);
/// Sinopoli et al. 2004's examples: E[P-] against the arrival rate with its bounds (experiments_sinopoli.cpp).
ExperimentResult sinopoliFig2(const RunConfig& rc);
/// Mo and Sinopoli's tail probability P(P- > M) of the scalar example.
ExperimentResult moSinopoliTail(const RunConfig& rc);
/// The scalar critical arrival rate 1 - 1/a^2 (0 when |a| <= 1).
double sinopoliCriticalRate(double a);

/// What the custom and sweep experiments load from --model, --channel, --actuator-channel and
/// --settings: the model, each sensor's link, the run options (links, paper control sequence) and
/// the estimators (validated against the model) with their names (the settings files' stems).
struct CustomSetup
{
  Model model;
  SensorLinks links;
  LossyRunOptions options;  ///< options.sensor_links = links.link
  std::vector<EstimatorSettings> settings;
  std::vector<std::string> names;
};
/// Throws ConfigError naming the experiment, the option or the file.
CustomSetup loadCustomSetup(const MonteCarloConfig& config, const std::string& experiment);

/// The arrivals of a run without the plant: the sensor links and the schedule of
/// LossyRun(model, S, options), drawn from the same streams (so run r of a covariance-only
/// experiment meets exactly the losses of the custom experiment's run r), as the Sample an
/// estimator in covariance-only mode takes: y 0 on the sensors that arrived, NaN on the others.
class ArrivalDraws
{
public:
  ArrivalDraws(const Model& model, const LossyRunOptions& options);
  /// Starts over for the run seed S (no allocation).
  void restart(std::uint64_t seed);
  /// The next step's arrivals.
  const Sample& next();

private:
  SensorLinkSet links_;
  ScheduleSampler schedule_;
  SimulatedSample zero_;  ///< y = v = 0: what the links pass on is the arrival pattern alone
  Sample sample_;
};

/// The estimators of `settings` in covariance-only mode. Throws ConfigError naming the estimator
/// (`names`) when its covariance depends on the data (aoe, oe, ekfio).
std::vector<std::unique_ptr<Estimator>> covarianceOnlyEstimators(const Model& model,
                                                                 const std::vector<EstimatorSettings>& settings,
                                                                 const std::vector<std::string>& names);

/// Zhou's example (Section IV of the paper) with eps ~ U[-delta, delta].
Model zhouExampleModel(double delta);
/// Lin et al.'s example (their Section 7) with C = [[1, -1], [0, 1]], xbar_0 = 0, P_0 = I.
Model aoeExampleModel(double rhoA);
/// Yang et al.'s Example 1: 8 sensors, R_i = I, x_0 ~ N(0, I).
Model yangExampleModel();
/// The arrival rates of Yang et al.'s Example 1.
const std::vector<double>& yangRates();

/// A series from the moments `m` at offset `first` (values first .. first + x_count - 1), with the
/// heavy-tail statistics the call computed: quantiles, tail probabilities, and from a span of the
/// same values the growth exponent (and the time average's sd when the span has the same window).
SeriesResult makeSeries(const std::string& name, const Moments& m, std::size_t first, std::size_t count,
                        double window0, double window1);
/// Sizes the quantiles and tail probabilities of `s` for `count` points (those `m` has).
void resizeTails(SeriesResult& s, std::size_t count, const Moments& m);
/// Point i of `s`: the quantiles and tail probabilities of value v of `m`.
void setTails(SeriesResult& s, std::size_t i, const Moments& m, std::size_t v);
/// The statistics of an experiment's Monte Carlo calls: quantiles, the --threshold values.
CallStatistics callStatistics(const RunConfig& rc);
/// Adds a span (the series of values first .. first + x.size() - 1) to `st`.
void addSpan(CallStatistics& st, std::size_t first, const std::vector<double>& x, double window0, double window1);

/// %.10g.
inline std::string fmt(double v)
{
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

/// `v` rounded to the digits fmt() prints: the value the JSON outputs hold, as the CSV ones.
inline double rounded(double v)
{
  return std::isfinite(v) ? std::strtod(fmt(v).c_str(), nullptr) : v;
}

/// 1..steps as doubles.
std::vector<double> stepAxis(long steps);

}  // namespace mc
}  // namespace networked_estimation
