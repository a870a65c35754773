// Private: the experiments of montecarlo.cpp and small shared helpers.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"

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
ExperimentResult sweepExperiment(const RunConfig& rc);
ExperimentResult linFig2(const RunConfig& rc);
ExperimentResult linFig3(const RunConfig& rc);
ExperimentResult linFig4(const RunConfig& rc);
ExperimentResult linFig5(const RunConfig& rc);
ExperimentResult yangFig2(const RunConfig& rc);

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

/// Zhou's example (Section IV of the paper) with eps ~ U[-delta, delta].
Model zhouExampleModel(double delta);
/// Lin et al.'s example (their Section 7) with C = [[1, -1], [0, 1]], xbar_0 = 0, P_0 = I.
Model aoeExampleModel(double rhoA);
/// Yang et al.'s Example 1: 8 sensors, R_i = I, x_0 ~ N(0, I).
Model yangExampleModel();
/// The arrival rates of Yang et al.'s Example 1.
const std::vector<double>& yangRates();

/// A series from the moments `m` at offset `first` (values first .. first + x_count - 1).
SeriesResult makeSeries(const std::string& name, const Moments& m, std::size_t first, std::size_t count,
                        double window0, double window1);

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
