// Monte Carlo engine and the experiments of the `montecarlo` tool (ROS-free).
//
// Determinism: run r draws all its randomness from seeds derived with deriveSeed(seed, r), the
// runs are split into fixed blocks of kBlockRuns, each block is accumulated in run order and the
// blocks are combined in block order, so the results do not depend on the number of threads.
//
// Output contract (read by the plot scripts):
//   DIR/<experiment>.csv    case,series,x,mean,sd,n       (numbers with %.10g)
//   DIR/<experiment>.json   metadata and per-series summaries (see writeExperimentJson)
//   DIR/zhou_fig2_samples.csv  case,run,P11,P12,P21,P22   (zhou_fig2 only)
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Engine

/// Runs per block: the unit of work of a thread and of the deterministic reduction.
constexpr long kBlockRuns = 64;

/// Mean and sample standard deviation (across runs) of every value of a run.
struct Moments
{
  std::vector<double> mean;
  std::vector<double> sd;  ///< sample standard deviation (0 when n < 2)
  long n = 0;
};

/// Thread-safe progress counter over all the runs of an experiment. The callback is called with
/// (done, total) under a mutex after every finished block.
class ProgressCounter
{
public:
  using Callback = std::function<void(long done, long total)>;
  explicit ProgressCounter(Callback callback = nullptr) : callback_(std::move(callback)) {}
  void setTotal(long total) { total_ = total; }
  long total() const { return total_; }
  void add(long runs);

private:
  Callback callback_;
  std::mutex mutex_;
  long done_ = 0;
  long total_ = 0;
};

/// Fills out[0 .. values) with the values of run `run`.
using RunFunction = std::function<void(long run, double* out)>;
/// Builds the per-thread state (estimators, work buffers) and returns the run function using it.
/// Called once per worker thread, from that thread.
using WorkerFactory = std::function<RunFunction()>;

/// Runs `runs` runs on up to `threads` threads (0 = hardware concurrency) and returns the moments
/// of every value. When `raw` is given it receives every run's values (runs x values, row-major).
/// The first exception of a run is rethrown after every thread has stopped.
Moments runMonteCarlo(long runs, std::size_t values, int threads, const WorkerFactory& make_worker,
                      ProgressCounter* progress = nullptr, std::vector<double>* raw = nullptr);

/// The thread count actually used for a requested count (0 = hardware concurrency, at least 1).
int resolveThreads(int requested);

// ---------------------------------------------------------------------------------------------
// Results

struct SeriesResult
{
  std::string name;
  std::vector<double> mean, sd;  ///< one per x of the case
  long n = 0;                    ///< runs
  double window0 = 0.0, window1 = 0.0;  ///< x range of time_average (inclusive)
  double time_average = 0.0;     ///< mean over x in the window of `mean`
  double final_value = 0.0;      ///< mean at the last x
  bool bound = false;            ///< a bound (JSON "bound": true: plotted dashed)
};

struct CaseResult
{
  std::string name, title;
  std::vector<double> x;
  std::vector<SeriesResult> series;
};

/// Per-run values of one case (zhou_fig2: P_{T|T} of every run).
struct SampleSet
{
  std::string case_name;
  std::vector<double> values;  ///< runs x columns, row-major
};

struct ExperimentResult
{
  std::string experiment;
  long runs = 0, steps = 0;
  std::uint64_t seed = 1;
  int threads = 1;
  double wall_seconds = 0.0;
  std::string x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<std::string> assumptions, notes;
  std::vector<CaseResult> cases;
  std::vector<std::string> sample_columns;  ///< empty: no samples file
  std::vector<SampleSet> samples;
};

/// Fills time_average and final_value of every series from its window.
void summarise(ExperimentResult& result);

/// `case,series,x,mean,sd,n` rows (numbers with %.10g).
std::string experimentCsv(const ExperimentResult& result);
/// The JSON metadata document (written by hand, strings escaped).
std::string experimentJson(const ExperimentResult& result);
/// `case,run,<columns>` rows of the samples (empty string when there are none).
std::string samplesCsv(const ExperimentResult& result);
/// Writes DIR/<experiment>.csv, .json (and _samples.csv) atomically, creating DIR if needed.
/// Throws InputError when a file cannot be written.
void writeExperiment(const ExperimentResult& result, const std::string& dir);

// ---------------------------------------------------------------------------------------------
// Experiments

struct MonteCarloConfig
{
  std::string experiment;
  long runs = 0;   ///< 0 = the experiment's default
  long steps = 0;  ///< 0 = the experiment's default
  std::uint64_t seed = 1;
  int threads = 0;  ///< 0 = hardware concurrency
  // custom only
  std::string model_path;
  /// The --channel options: FILE (every sensor) and NAME=FILE (that sensor), see sensor_links.hpp.
  std::vector<std::string> channel_args;
  std::string actuator_channel_path;  ///< empty: every command arrives
  std::vector<std::string> settings_paths;
};

/// Names of the experiments, in a fixed order.
const std::vector<std::string>& experimentNames();
/// Throws ConfigError "unknown experiment 'NAME' (valid: ...)" unless `name` is one of them.
void checkExperimentName(const std::string& name);
/// Default runs and steps of an experiment (throws ConfigError for an unknown name).
void experimentDefaults(const std::string& name, long& runs, long& steps);

/// Runs an experiment. Throws ConfigError for a bad configuration (unknown experiment, missing or
/// invalid custom files), InputError, DivergenceError when an estimator diverges.
ExperimentResult runExperiment(const MonteCarloConfig& config, ProgressCounter* progress = nullptr);

}  // namespace networked_estimation
