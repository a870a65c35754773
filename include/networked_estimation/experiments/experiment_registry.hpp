// The experiments of the `montecarlo` tool by name (ROS-free): their configuration, defaults and
// runExperiment.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "networked_estimation/experiments/experiment_result.hpp"
#include "networked_estimation/experiments/montecarlo_engine.hpp"

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Experiments

struct MonteCarloConfig
{
  std::string experiment;
  long runs = 0;   ///< 0 = the experiment's default
  long steps = 0;  ///< 0 = the experiment's default
  std::uint64_t seed = 1;
  int threads = 0;  ///< 0 = hardware concurrency
  /// --threshold: the M of the tail probabilities P(value > M) in every output (at most kMaxThresholds).
  std::vector<double> thresholds;
  // custom and sweep only
  std::string model_path;
  /// The --channel options: FILE (every sensor) and NAME=FILE (that sensor), see sensor_links.hpp.
  std::vector<std::string> channel_args;
  std::string actuator_channel_path;  ///< empty: every command arrives
  std::vector<std::string> settings_paths;
  /// sweep only: the --axis options, SENSOR.PARAM=LO:HI:N (sweep.hpp).
  std::vector<std::string> axis_args;
  /// Inputs given as text rather than as files (Python's Model, Link and settings objects): the
  /// model path, a --channel FILE or a settings entry that is a key here is read from its text (a
  /// model or channel file's YAML, or estimator settings), and the shards hash and carry the text.
  std::map<std::string, std::string> inline_inputs;
  /// custom and sweep: --covariance-only, the estimators' random Riccati recursion driven by the
  /// links' arrivals alone (no plant: any horizon, no rounding floor); only for the estimators whose
  /// P does not depend on the data (Estimator::setCovarianceOnly).
  bool covariance_only = false;
};

/// The most --threshold values of one experiment.
constexpr std::size_t kMaxThresholds = 16;

/// Names of the experiments, in a fixed order.
const std::vector<std::string>& experimentNames();
/// Throws ConfigError "unknown experiment 'NAME' (valid: ...)" unless `name` is one of them.
void checkExperimentName(const std::string& name);
/// Default runs and steps of an experiment (throws ConfigError for an unknown name).
void experimentDefaults(const std::string& name, long& runs, long& steps);

/// The experiments that take the --model, --channel, --actuator-channel and --settings options
/// (custom, covariance, sweep).
bool takesCustomInputs(const std::string& experiment);
/// The configuration as it runs: custom with covariance_only is the experiment covariance (its
/// outputs DIR/covariance.csv and .json), which always has covariance_only set. Throws ConfigError
/// for an unknown experiment, or covariance_only on one that takes no custom inputs.
MonteCarloConfig canonicalConfig(const MonteCarloConfig& config);

/// Runs an experiment (its canonicalConfig). With a `session`, every Monte Carlo call of the
/// experiment computes one shard's blocks or replays merged ones (BlockSession, montecarlo_shards.hpp).
/// Throws ConfigError for a bad configuration (unknown experiment, missing or invalid custom files),
/// InputError, DivergenceError when an estimator diverges.
ExperimentResult runExperiment(const MonteCarloConfig& config, ProgressCounter* progress = nullptr,
                               BlockSession* session = nullptr);

}  // namespace networked_estimation
