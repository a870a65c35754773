// The experiments of the montecarlo tool by name (experiment_registry.hpp): their defaults, the
// canonical configuration and runExperiment.
#include "networked_estimation/experiments/experiment_registry.hpp"

#include <chrono>
#include <cmath>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

namespace
{

struct ExperimentEntry
{
  const char* name;
  long runs, steps;
  ExperimentResult (*run)(const mc::RunConfig&);
};

const std::vector<ExperimentEntry>& entries()
{
  static const std::vector<ExperimentEntry> e = {
      {"zhou_fig1", 5000, 500, &mc::zhouFig1},
      {"zhou_fig2", 5000, 500, &mc::zhouFig2},
      {"custom", 1000, 200, &mc::customExperiment},
      {"sweep", 1000, 200, &mc::sweepExperiment},
      {"covariance", 1000, 1000, &mc::covarianceExperiment},
      {"lin_fig2", 1000, 30, &mc::linFig2},
      {"lin_fig3", 500, 30, &mc::linFig3},
      {"lin_fig4", 1000, 30, &mc::linFig4},
      {"lin_fig5", 1000, 50, &mc::linFig5},
      {"yang_fig2", 10000, 40, &mc::yangFig2},
      {"sinopoli_fig2", 1000, 100, &mc::sinopoliFig2},
      {"mo_sinopoli_tail", 10000, 200, &mc::moSinopoliTail},
  };
  return e;
}

const ExperimentEntry& entry(const std::string& name)
{
  for (const ExperimentEntry& e : entries())
    if (name == e.name)
      return e;
  std::string valid;
  for (const ExperimentEntry& e : entries())
    valid += (valid.empty() ? "" : ", ") + std::string(e.name);
  throw ConfigError("unknown experiment '" + name + "' (valid: " + valid + ")");
}

}  // namespace

const std::vector<std::string>& experimentNames()
{
  static const std::vector<std::string> names = []
  {
    std::vector<std::string> v;
    for (const ExperimentEntry& e : entries())
      v.push_back(e.name);
    return v;
  }();
  return names;
}

void checkExperimentName(const std::string& name)
{
  entry(name);
}

void experimentDefaults(const std::string& name, long& runs, long& steps)
{
  const ExperimentEntry& e = entry(name);
  runs = e.runs;
  steps = e.steps;
}

bool takesCustomInputs(const std::string& experiment)
{
  return experiment == "custom" || experiment == "covariance" || experiment == "sweep";
}

MonteCarloConfig canonicalConfig(const MonteCarloConfig& in)
{
  MonteCarloConfig c = in;
  checkExperimentName(c.experiment);
  if (c.thresholds.size() > kMaxThresholds)
    throw ConfigError("--threshold: at most " + std::to_string(kMaxThresholds) + " thresholds, found " +
                      std::to_string(c.thresholds.size()));
  for (std::size_t i = 0; i < c.thresholds.size(); ++i)
  {
    if (!std::isfinite(c.thresholds[i]))
      throw ConfigError("--threshold: expected finite numbers, found " + mc::fmt(c.thresholds[i]));
    for (std::size_t j = 0; j < i; ++j)
      if (c.thresholds[j] == c.thresholds[i])
        throw ConfigError("--threshold: " + mc::fmt(c.thresholds[i]) + " is given twice");
  }
  if (c.covariance_only && !takesCustomInputs(c.experiment))
    throw ConfigError("experiment " + c.experiment +
                      ": --covariance-only is for the experiments custom, covariance "
                      "and sweep");
  if (c.experiment == "custom" && c.covariance_only)
    c.experiment = "covariance";
  if (c.experiment == "covariance")
    c.covariance_only = true;
  return c;
}

ExperimentResult runExperiment(const MonteCarloConfig& in, ProgressCounter* progress, BlockSession* session)
{
  const MonteCarloConfig config = canonicalConfig(in);
  const ExperimentEntry& e = entry(config.experiment);
  mc::RunConfig rc;
  rc.runs = config.runs > 0 ? config.runs : e.runs;
  rc.steps = config.steps > 0 ? config.steps : e.steps;
  rc.seed = config.seed;
  rc.threads = resolveThreads(config.threads);
  rc.config = &config;
  rc.progress = progress;
  rc.session = session;
  const auto t0 = std::chrono::steady_clock::now();
  ExperimentResult r = e.run(rc);
  const auto t1 = std::chrono::steady_clock::now();
  r.experiment = e.name;
  r.runs = rc.runs;
  r.steps = rc.steps;
  r.seed = rc.seed;
  r.threads = rc.threads;
  r.wall_seconds = std::chrono::duration<double>(t1 - t0).count();
  r.thresholds = config.thresholds;
  summarise(r);
  return r;
}

}  // namespace networked_estimation
