// Experiment covariance (montecarlo --covariance-only): the random Riccati recursion of the custom
// experiment's estimators, driven by the links' arrivals alone.
#include <cmath>
#include <limits>
#include <memory>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "networked_estimation/simulation/schedule_sampler.hpp"

namespace networked_estimation
{
namespace mc
{

std::vector<std::unique_ptr<Estimator>> covarianceOnlyEstimators(const Model& model,
                                                                 const std::vector<EstimatorSettings>& settings,
                                                                 const std::vector<std::string>& names)
{
  std::vector<std::unique_ptr<Estimator>> est;
  for (std::size_t j = 0; j < settings.size(); ++j)
  {
    est.push_back(makeEstimator(model, settings[j]));
    if (!est.back()->setCovarianceOnly(true))
      throw ConfigError("--covariance-only: estimator '" + names[j] + "' (" + toString(settings[j].algorithm) +
                        "): its covariance depends on the measurements, not only on which arrived, so it has no "
                        "random Riccati recursion to run without the plant (covariance-only: kf, kfio, ack_kf, rseio)");
  }
  return est;
}

ArrivalDraws::ArrivalDraws(const Model& model, const LossyRunOptions& options)
  : links_(model, options.sensor_links, 0, options.noise_on_loss), schedule_(model.schedule, model.sensors.size(), 0)
{
  zero_.y = Eigen::VectorXd::Zero(model.m());
  zero_.v = zero_.y;
  sample_.y.resize(model.m());
  sample_.nu = -1;
}

void ArrivalDraws::restart(std::uint64_t seed)
{
  links_.reseed(seed);
  schedule_.restart(deriveSeed(seed, 300));
}

const Sample& ArrivalDraws::next()
{
  links_.receive(zero_, schedule_.next(), sample_);
  return sample_;
}

ExperimentResult covarianceExperiment(const RunConfig& rc)
{
  const MonteCarloConfig& cfg = *rc.config;
  const CustomSetup su = loadCustomSetup(cfg, "covariance");
  const Model& model = su.model;
  covarianceOnlyEstimators(model, su.settings, su.names);  // refuses the others before any run
  if (rc.progress)
    rc.progress->setTotal(rc.runs);
  const long T = rc.steps;
  const std::size_t nf = su.settings.size();
  const std::size_t values = nf * static_cast<std::size_t>(T) + nf;
  const std::uint64_t seed = rc.seed;
  const std::vector<EstimatorSettings>& settings = su.settings;
  const std::vector<std::string>& names = su.names;
  const LossyRunOptions& options = su.options;
  // Run r draws exactly the arrivals of `simulate --seed S+r` (and of the custom experiment's run r):
  // the same link and schedule streams, seeded from S+r as LossyRun seeds them, without the plant.
  WorkerFactory factory = [&model, &settings, &names, &options, T, nf, seed]() -> RunFunction
  {
    struct Worker
    {
      std::vector<std::unique_ptr<Estimator>> est;
      std::unique_ptr<ArrivalDraws> arrivals;
    };
    auto w = std::make_shared<Worker>();
    w->est = covarianceOnlyEstimators(model, settings, names);
    w->arrivals = std::make_unique<ArrivalDraws>(model, options);
    return [w, T, nf, seed](long r, double* out)
    {
      w->arrivals->restart(seed + static_cast<std::uint64_t>(r));
      for (auto& e : w->est)
        e->reset();
      std::vector<char> alive(nf, 1);
      for (long k = 1; k <= T; ++k)
      {
        const Sample& sample = w->arrivals->next();
        for (std::size_t j = 0; j < nf; ++j)
        {
          double& v = out[j * static_cast<std::size_t>(T) + static_cast<std::size_t>(k - 1)];
          if (alive[j])
          {
            try
            {
              w->est[j]->step(sample);
              v = w->est[j]->covariance().trace();
            }
            catch (const DivergenceError&)
            {
              alive[j] = 0;  // P left the doubles: tr P is +inf from here on (the mean is infinite)
            }
          }
          if (!alive[j])
            v = std::numeric_limits<double>::infinity();
        }
      }
      for (std::size_t j = 0; j < nf; ++j)
        out[nf * static_cast<std::size_t>(T) + j] = alive[j] ? 0.0 : 1.0;
    };
  };
  const double w0 = static_cast<double>(T / 2 + 1), w1 = static_cast<double>(T);
  CallStatistics stats = callStatistics(rc);
  for (std::size_t j = 0; j < nf; ++j)
    addSpan(stats, j * static_cast<std::size_t>(T), stepAxis(T), w0, w1);
  const Moments m = runMonteCarlo(rc.runs, values, rc.threads, factory, rc.progress, nullptr, &stats, rc.session);

  ExperimentResult res;
  CaseResult c;
  c.name = model.name.empty() ? "model" : model.name;
  std::string described = su.links.describe();
  for (char& ch : described)
    if (ch == '\n')
      ch = ';';
  c.title = "model " + cfg.model_path + "; links " + described + "; covariance only";
  c.x = stepAxis(T);
  std::string overflowed;
  for (std::size_t j = 0; j < nf; ++j)
  {
    c.series.push_back(makeSeries(names[j], m, j * static_cast<std::size_t>(T), static_cast<std::size_t>(T), w0, w1));
    const long lost = std::lround(m.mean[nf * static_cast<std::size_t>(T) + j] * static_cast<double>(m.n));
    if (lost > 0)
      overflowed += (overflowed.empty() ? "" : ", ") + names[j] + ": " + std::to_string(lost) + " of " +
                    std::to_string(m.n) + " runs";
  }
  res.cases.push_back(c);
  res.x_label = "k";
  res.y_label = "tr P_k|k";
  res.log_y = true;
  res.assumptions = {
      "covariance only: no plant is simulated; each estimator runs its own covariance recursion (the code of its "
      "ordinary step, without the state) on the arrivals of run r, which are exactly those of `simulate --seed "
      "S+r` with the same --channel options and the model's schedule (S = --seed)",
      "valid for the estimators whose P depends only on which sensors arrived (kf, kfio, ack_kf, rseio): for them "
      "tr P_k|k is the estimator's conditional mean squared error given the arrivals, and its mean over runs "
      "E[tr P_k|k] the quantity the papers plot",
      "a step where no sensor arrived: the sensors that transmitted deliver the noise only (kf fuses it, as with "
      "the plant); with control, the commands move only the mean and are not drawn",
  };
  res.notes = {"time_average = mean of E[tr P_k] over the last half, k = floor(T/2)+1 .. T"};
  if (!overflowed.empty())
    res.notes.push_back(
        "P overflowed the doubles (tr P = inf from that step on, so the mean is infinite; the "
        "quantiles and tail probabilities stay exact) in " +
        overflowed);
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
