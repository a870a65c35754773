// montecarlo: runs one Monte Carlo experiment (paper figure or custom comparison) and writes
// DIR/<experiment>.csv and DIR/<experiment>.json (montecarlo.hpp has the output contract).
// With --shard K/N it computes one shard and writes DIR/<experiment>.shard-K-of-N.json instead;
// `montecarlo merge DIR...` merges the shards into the unsharded outputs (montecarlo_shards.hpp).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <unistd.h>

#include "cli.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/experiments/montecarlo_shards.hpp"
#include "networked_estimation/experiments/sweep.hpp"

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

/// Progress on stderr: an in-place bar on a terminal, plain lines every 10 % otherwise. The counter
/// counts the runs of every Monte Carlo set of the experiment (a case, a grid point of lin_fig2):
/// with `runs` per set, a total above it is shown as runs x sets.
class ProgressPrinter
{
public:
  explicit ProgressPrinter(long runs) : tty_(isatty(2) != 0), runs_(runs) {}

  /// "(1000/2000 runs)", or "(1000/2000 runs = 100 runs x 20 sets)" for several sets.
  std::string count(long done, long total) const
  {
    std::string text = "(" + std::to_string(done) + "/" + std::to_string(total) + " runs";
    if (runs_ > 0 && total > runs_ && total % runs_ == 0)
      text += " = " + std::to_string(runs_) + " runs x " + std::to_string(total / runs_) + " sets";
    return text + ")";
  }

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
      std::fprintf(stderr, "\rmontecarlo: [%s%s] %3d%% %s", std::string(fill, '#').c_str(),
                   std::string(width - fill, ' ').c_str(), percent, count(done, total).c_str());
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
      std::fprintf(stderr, "montecarlo: %d%% %s\n", percent, count(done, total).c_str());
      std::fflush(stderr);
    }
  }

private:
  bool tty_;
  long runs_;
  int last_ = 0;
};

/// `montecarlo merge DIR... [--out DIR]`: the directories are positional, the options go to the
/// usual parser.
int mergeMain(int argc, char** argv)
{
  cli::CommandLine cl(
      "montecarlo merge DIR...",
      "Merges the shard files DIR/NAME.shard-K-of-N.json written by `montecarlo ... --shard K/N --out DIR` into\n"
      "DIR/NAME.csv and DIR/NAME.json (and zhou_fig2_samples.csv), exactly as the unsharded run writes them\n"
      "(the JSON's threads and wall_seconds aside: the shards' largest thread count and their summed wall time).\n"
      "Every shard file in the directories (of --experiment NAME only, when given) is read; they must be of\n"
      "one experiment with the same --runs, --steps, --seed, N and custom or sweep arguments (--axis too),\n"
      "every K of 1..N exactly once, and a custom or sweep experiment's input files (read again at their\n"
      "recorded paths, relative ones from the current directory) unchanged.\n"
      "Exit codes: 0 ok; 2 bad arguments, or a missing, duplicate, foreign or malformed shard (the message\n"
      "names the file and the field); 3 never.",
      {
          {"experiment", "NAME",
           "merge only the shards of NAME (default: every shard file; they must be of one "
           "experiment)",
           false, false},
          {"out", "DIR", "output directory (created when missing; default: the first DIR)", false, false},
      });
  std::vector<std::string> dirs;
  std::vector<char*> args = {argv[0]};
  for (int i = 2; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (a.compare(0, 2, "--") == 0 || a == "-h")
    {
      args.push_back(argv[i]);
      if ((a == "--out" || a == "--experiment") && i + 1 < argc)
        args.push_back(argv[++i]);
    }
    else
      dirs.push_back(a);
  }
  return cli::runTool(cl, static_cast<int>(args.size()), args.data(),
                      [&]() -> int
                      {
                        if (dirs.empty())
                          throw cli::UsageError("merge: expected one or more directories of shard files");
                        std::vector<ShardFile> shards;
                        if (cl.has("experiment"))
                        {
                          try
                          {
                            checkExperimentName(cl.get("experiment"));
                          }
                          catch (const ConfigError& e)
                          {
                            throw cli::UsageError(e.what());
                          }
                        }
                        for (const std::string& file : findShardFiles(dirs, cl.get("experiment")))
                          shards.push_back(readShard(file));
                        const std::size_t count = shards.size();
                        const std::string out = cl.get("out", dirs.front());
                        const ExperimentResult result = mergeShards(std::move(shards));
                        writeExperiment(result, out);
                        std::string shown = out;
                        while (shown.size() > 1 && shown.back() == '/')
                          shown.pop_back();
                        std::fprintf(stderr, "montecarlo merge: %s: %zu shards, %ld runs x %ld steps -> %s/%s.csv\n",
                                     result.experiment.c_str(), count, result.runs, result.steps, shown.c_str(),
                                     result.experiment.c_str());
                        return 0;
                      });
}

}  // namespace

int main(int argc, char** argv)
{
  if (argc >= 2 && std::string(argv[1]) == "merge")
    return mergeMain(argc, argv);
  std::string names;
  for (const std::string& n : experimentNames())
    names += (names.empty() ? "" : ", ") + n;
  cli::CommandLine cl(
      "montecarlo",
      "Runs a Monte Carlo experiment and writes DIR/NAME.csv (case,series,x,mean,sd,n,se,p5,p25,median,p75,p95\n"
      "and P_gt_M per --threshold M) and DIR/NAME.json (metadata, assumptions, per-series summaries with standard\n"
      "errors and the growth exponent of log value); zhou_fig2 also writes DIR/zhou_fig2_samples.csv.\n"
      "Results do not depend on --threads. Experiments: " +
          names +
          ".\nOn a cluster: with --shard K/N it computes only shard K of N (of every Monte Carlo call of the\n"
          "experiment, the blocks of 64 runs b with b % N = K-1) and writes DIR/NAME.shard-K-of-N.json instead;\n"
          "`montecarlo merge DIR... [--out DIR]` then writes the same DIR/NAME.csv and .json as one unsharded\n"
          "run (see montecarlo merge --help).\n"
          "Stability maps: --experiment sweep takes custom's --model, --settings and --channel options and one or\n"
          "two --axis NAME=LO:HI:N (NAME SENSOR.arrival_rate: that sensor's link becomes i.i.d. with this arrival\n"
          "rate; SENSOR.loss: its bernoulli link's loss; SENSOR.recovery_rate (or .r), .p, .loss_good, .loss_bad:\n"
          "that key of its gilbert_elliott --channel link; ESTIMATOR.mu (rseio), ESTIMATOR.recovery, .failure\n"
          "(aoe/oe control_link): that key of the estimator's settings; model.A[i][j], model.C[i][j]: that entry\n"
          "of the model (0-based); model.Q*, model.R*: a factor on Q, on every R), runs --runs runs of --steps\n"
          "steps at each of the N1 x N2 grid points and writes DIR/sweep.csv, one row per (point, estimator): mean\n"
          "and sd of tr P and of |x - xhat|^2 at the last step and averaged over the last half, the runs where the\n"
          "estimator diverged or the plant crossed the rounding floor (then no mean: a sweep never stops on\n"
          "them), and the point's analytic verdict; DIR/sweep.json adds the critical curve of the last axis (for\n"
          "each value of the first). plot_montecarlo.py draws it as a heat map. Schedules are not swept.\n"
          "Unstable plants, long horizons: --experiment covariance (or custom --covariance-only) runs only the\n"
          "estimators' random Riccati recursion on the links' arrivals (no plant, so no rounding floor, any --steps)\n"
          "and writes DIR/covariance.csv: tr P_k per step and estimator (kf, kfio, ack_kf, rseio); sweep\n"
          "--covariance-only fills the tr P columns of every grid point alone.\n"
          "Exit codes: 0 ok, 2 bad arguments or files, 3 an estimator diverged, or a run's plant state\n"
          "crossed the rounding floor (the message names the run and the step: use fewer --steps; not sweep).",
      {
          {"experiment", "NAME", "experiment to run", true, false},
          {"runs", "N", "Monte Carlo runs (default: per experiment)", false, false},
          {"steps", "T", "time steps / horizon (default: per experiment)", false, false},
          {"seed", "S", "seed (default 1)", false, false},
          {"threads", "J", "worker threads (default: hardware concurrency)", false, false},
          {"out", "DIR", "output directory (created when missing)", true, false},
          {"covariance-only", "",
           "custom, sweep: the estimators' covariance recursion on the links' arrivals alone, no plant (custom: the "
           "experiment covariance)",
           false, false},
          {"model", "FILE", "custom, covariance, sweep: model file (YAML)", false, false},
          {"channel", "[NAME=]FILE",
           "custom, covariance, sweep: sensor link channel settings (YAML) for every sensor, or NAME=FILE for sensor "
           "NAME; a sensor "
           "with neither is lossless",
           false, true},
          {"actuator-channel", "FILE",
           "custom, covariance, sweep: controller-to-actuator channel settings (default: lossless)", false, false},
          {"settings", "S1,S2,...",
           "custom, covariance, sweep: estimator settings files or algorithm names (kfio, rseio, ...), comma-separated",
           false, false},
          {"axis", "NAME=LO:HI:N",
           "sweep: a grid axis, N values from LO to HI (NAME: SENSOR.arrival_rate, .loss, .recovery_rate, .r, .p, "
           ".loss_good, .loss_bad; ESTIMATOR.mu, .recovery, .failure; model.A[i][j], model.C[i][j], model.Q*, "
           "model.R*); once or twice",
           false, true},
          {"threshold", "M",
           "also report P(value > M), the fraction of runs above M, of every value (a column P_gt_M; sweep: of tr "
           "P_T, trP_P_gt_M); repeatable, at most 16",
           false, true},
          {"shard", "K/N",
           "compute shard K of N (1 <= K <= N) only and write DIR/NAME.shard-K-of-N.json (merge with montecarlo "
           "merge)",
           false, false},
      });
  return cli::runTool(
      cl, argc, argv,
      [&]() -> int
      {
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
        const bool sweep = cfg.experiment == "sweep";
        const bool custom = takesCustomInputs(cfg.experiment);
        for (const char* key : {"model", "settings"})
          if (custom && !cl.has(key))
            throw cli::UsageError("experiment " + cfg.experiment + " needs --" + key);
        for (const char* key : {"model", "channel", "actuator-channel", "settings", "covariance-only"})
          if (!custom && cl.has(key))
            throw cli::UsageError(std::string("option '--") + key +
                                  "' is only for --experiment custom, covariance or sweep");
        cfg.covariance_only = cl.has("covariance-only");
        for (const std::string& t : cl.getAll("threshold"))
        {
          double m = 0.0;
          char* end = nullptr;
          m = std::strtod(t.c_str(), &end);
          if (t.empty() || end != t.c_str() + t.size() || !std::isfinite(m))
            throw cli::UsageError("option '--threshold': expected a finite number, found '" + t + "'");
          cfg.thresholds.push_back(m);
        }
        try
        {
          canonicalConfig(cfg);  // the thresholds' count and repeats
        }
        catch (const ConfigError& e)
        {
          throw cli::UsageError(e.what());
        }
        if (sweep && !cl.has("axis"))
          throw cli::UsageError("experiment sweep needs --axis NAME=LO:HI:N (once or twice)");
        if (!sweep && cl.has("axis"))
          throw cli::UsageError("option '--axis' is only for --experiment sweep");
        if (sweep)
        {
          cfg.axis_args = cl.getAll("axis");
          if (cfg.axis_args.size() > 2)
            throw cli::UsageError("option '--axis': at most two axes, found " + std::to_string(cfg.axis_args.size()));
          for (const std::string& a : cfg.axis_args)
            try
            {
              parseSweepAxis(a);  // the form and the range now; the sensor once the model is read
            }
            catch (const ConfigError& e)
            {
              throw cli::UsageError(e.what());
            }
        }
        if (custom)
        {
          cfg.model_path = cl.get("model");
          cfg.channel_args = cl.getAll("channel");
          cfg.actuator_channel_path = cl.get("actuator-channel");
          cfg.settings_paths = splitComma(cl.get("settings"));
          if (cfg.settings_paths.empty())
            throw cli::UsageError("option '--settings': expected comma-separated settings files");
        }
        int shard = 0, shards = 0;
        if (cl.has("shard") && !parseShardSpec(cl.get("shard"), shard, shards))
          throw cli::UsageError("option '--shard': expected K/N with integers 1 <= K <= N <= 1000000, found '" +
                                cl.get("shard") + "'");
        long default_runs = 0, default_steps = 0;
        experimentDefaults(cfg.experiment, default_runs, default_steps);
        ProgressPrinter printer(cfg.runs > 0 ? cfg.runs : default_runs);
        ProgressCounter progress([&printer](long done, long total) { printer(done, total); });
        if (shards > 0)
        {
          const ShardFile sf = runShard(cfg, shard, shards, &progress);
          const std::string path = writeShard(sf, cl.get("out"));
          long owned = 0;
          for (const BlockMoments& b : sf.calls.empty() ? std::vector<BlockMoments>{} : sf.calls.front().blocks)
            owned += b.count;
          std::fprintf(stderr,
                       "montecarlo: %s shard %d of %d: %ld of %ld runs x %ld steps on %d threads in %.2f s -> %s\n",
                       cfg.experiment.c_str(), shard, shards, owned, sf.config.runs, sf.config.steps, sf.threads,
                       sf.wall_seconds, path.c_str());
          return 0;
        }
        const ExperimentResult result = runExperiment(cfg, &progress);  // custom --covariance-only: covariance
        writeExperiment(result, cl.get("out"));
        std::fprintf(stderr, "montecarlo: %s: %ld runs x %ld steps%s on %d threads in %.2f s -> %s/%s.csv\n",
                     result.experiment.c_str(), result.runs, result.steps,
                     result.sweep ? (" x " + std::to_string(result.sweep->points) + " grid points").c_str() : "",
                     result.threads, result.wall_seconds, cl.get("out").c_str(), result.experiment.c_str());
        return 0;
      });
}
