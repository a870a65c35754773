// Private: the experiments of the montecarlo tool (experiment_registry.cpp runs them by name).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "experiments/experiment_support.hpp"
#include "experiments/paper_models.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "networked_estimation/simulation/schedule_sampler.hpp"

namespace networked_estimation
{
namespace mc
{

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

}  // namespace mc
}  // namespace networked_estimation
