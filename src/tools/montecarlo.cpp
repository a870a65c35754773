// montecarlo: runs one Monte Carlo experiment (paper figure or custom comparison) and writes
// DIR/<experiment>.csv and DIR/<experiment>.json (montecarlo.hpp has the output contract).
#include <cstdio>
#include <iostream>
#include <sstream>
#include <unistd.h>

#include "cli.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"

using namespace networked_estimation;

namespace
{

std::vector<std::string> splitComma(const std::string& text)
{
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ','))
    if (!part.empty())
      out.push_back(part);
  return out;
}

/// Progress on stderr: an in-place bar on a terminal, plain lines every 10 % otherwise.
class ProgressPrinter
{
public:
  ProgressPrinter() : tty_(isatty(2) != 0) {}

  void operator()(long done, long total)
  {
    if (total <= 0)
      return;
    const int percent = static_cast<int>(100 * done / total);
    if (tty_)
    {
      if (percent == last_)
        return;
      last_ = percent;
      const int width = 30, fill = width * percent / 100;
      std::fprintf(stderr, "\rmontecarlo: [%s%s] %3d%% (%ld/%ld runs)", std::string(fill, '#').c_str(),
                   std::string(width - fill, ' ').c_str(), percent, done, total);
      if (done >= total)
        std::fprintf(stderr, "\n");
      std::fflush(stderr);
    }
    else
    {
      const int decile = percent / 10;
      if (decile <= last_)
        return;
      last_ = decile;
      std::fprintf(stderr, "montecarlo: %d%% (%ld/%ld runs)\n", percent, done, total);
      std::fflush(stderr);
    }
  }

private:
  bool tty_;
  int last_ = 0;
};

}  // namespace

int main(int argc, char** argv)
{
  std::string names;
  for (const std::string& n : experimentNames())
    names += (names.empty() ? "" : ", ") + n;
  cli::CommandLine cl(
      "montecarlo",
      "Runs a Monte Carlo experiment and writes DIR/NAME.csv (case,series,x,mean,sd,n) and DIR/NAME.json\n"
      "(metadata, assumptions, per-series summaries); zhou_fig2 also writes DIR/zhou_fig2_samples.csv.\n"
      "Results do not depend on --threads. Experiments: " +
          names + ".\nExit codes: 0 ok, 2 bad arguments or files, 3 an estimator diverged, or a run's plant state\n"
          "crossed the rounding floor (the message names the run and the step: use fewer --steps).",
      {
          {"experiment", "NAME", "experiment to run", true, false},
          {"runs", "N", "Monte Carlo runs (default: per experiment)", false, false},
          {"steps", "T", "time steps / horizon (default: per experiment)", false, false},
          {"seed", "S", "seed (default 1)", false, false},
          {"threads", "J", "worker threads (default: hardware concurrency)", false, false},
          {"out", "DIR", "output directory (created when missing)", true, false},
          {"model", "FILE", "custom: model file (YAML)", false, false},
          {"channel", "[NAME=]FILE",
           "custom: sensor link channel settings (YAML) for every sensor, or NAME=FILE for sensor NAME; a sensor "
           "with neither is lossless",
           false, true},
          {"actuator-channel", "FILE", "custom: controller-to-actuator channel settings (default: lossless)", false,
           false},
          {"settings", "S1,S2,...", "custom: estimator settings files, comma-separated", false, false},
      });
  return cli::runTool(cl, argc, argv, [&]() -> int {
    MonteCarloConfig cfg;
    cfg.experiment = cl.get("experiment");
    try
    {
      checkExperimentName(cfg.experiment);
    }
    catch (const ConfigError& e)
    {
      throw cli::UsageError(e.what());
    }
    cfg.runs = cl.getLong("runs", 0, 1, 100000000);
    cfg.steps = cl.getLong("steps", 0, 1, 100000000);
    cfg.seed = cl.getUint64("seed", 1);
    cfg.threads = static_cast<int>(cl.getLong("threads", 0, 1, 1024));
    const bool custom = cfg.experiment == "custom";
    for (const char* key : {"model", "settings"})
      if (custom && !cl.has(key))
        throw cli::UsageError(std::string("experiment custom needs --") + key);
    for (const char* key : {"model", "channel", "actuator-channel", "settings"})
      if (!custom && cl.has(key))
        throw cli::UsageError(std::string("option '--") + key + "' is only for --experiment custom");
    if (custom)
    {
      cfg.model_path = cl.get("model");
      cfg.channel_args = cl.getAll("channel");
      cfg.actuator_channel_path = cl.get("actuator-channel");
      cfg.settings_paths = splitComma(cl.get("settings"));
      if (cfg.settings_paths.empty())
        throw cli::UsageError("option '--settings': expected comma-separated settings files");
    }
    ProgressPrinter printer;
    ProgressCounter progress([&printer](long done, long total) { printer(done, total); });
    const ExperimentResult result = runExperiment(cfg, &progress);
    writeExperiment(result, cl.get("out"));
    std::fprintf(stderr, "montecarlo: %s: %ld runs x %ld steps on %d threads in %.2f s -> %s/%s.csv\n",
                 result.experiment.c_str(), result.runs, result.steps, result.threads, result.wall_seconds,
                 cl.get("out").c_str(), result.experiment.c_str());
    return 0;
  });
}
