// Monte Carlo engine and the experiments of the `montecarlo` tool (ROS-free).
//
// Determinism: run r draws all its randomness from seeds derived with deriveSeed(seed, r), the
// runs are split into fixed blocks of kBlockRuns, each block is accumulated in run order and the
// blocks are combined in block order, so the results do not depend on the number of threads.
//
// Output contract (read by the plot scripts):
//   DIR/<experiment>.csv    case,series,x,mean,sd,n,se,p5,p25,median,p75,p95[,P_gt_M...]  (%.10g)
//   DIR/<experiment>.json   metadata and per-series summaries (see writeExperimentJson)
//   DIR/zhou_fig2_samples.csv  case,run,P11,P12,P21,P22   (zhou_fig2 only)
//   sweep: DIR/sweep.csv holds one row per (grid point, estimator) instead (sweep.hpp), and
//   DIR/sweep.json a "sweep" member with the grid, the verdicts and the critical curve
// A sharded run writes DIR/<experiment>.shard-K-of-N.json instead (montecarlo_shards.hpp).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "networked_estimation/experiments/quantile_sketch.hpp"

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Engine

/// Runs per block: the unit of work of a thread and of the deterministic reduction.
constexpr long kBlockRuns = 64;

/// A series of values of a run (values first .. first + x.size() - 1, one per x, x = k) whose
/// per-run summaries a Monte Carlo call computes (CallStatistics::spans).
struct SeriesSpan
{
  std::size_t first = 0;
  std::vector<double> x;
  double window0 = 0.0, window1 = 0.0;  ///< the time average's window of x (inclusive)
};

/// What a Monte Carlo call computes beyond the mean and sd of every value: the statistics of heavy
/// tails (docs/formats.md, "Heavy tails"). Each is exact across threads, blocks and shards.
struct CallStatistics
{
  bool quantiles = false;          ///< a QuantileSketch of every value
  std::vector<double> thresholds;  ///< P(value > M) of every value for every M
  /// Per span and run: the growth exponent of log value, the least-squares slope per unit of x of
  /// log v over the last half of the span (its points i >= count / 2; NaN unless every value there
  /// is finite and > 0, or when fewer than 2 points), and the run's own time average over the window.
  std::vector<SeriesSpan> spans;
};

/// Mean and sample standard deviation (across runs) of every value of a run, and the statistics of
/// the call's CallStatistics.
struct Moments
{
  std::vector<double> mean;
  std::vector<double> sd;  ///< sample standard deviation (0 when n < 2)
  long n = 0;
  std::vector<QuantileSketch> sketches;  ///< per value, when the call asked for quantiles
  std::vector<double> thresholds;        ///< the call's
  std::vector<double> exceed;            ///< value-major, values x thresholds: the fraction of runs above M
  std::vector<SeriesSpan> spans;         ///< the call's
  /// Per span: mean and sd over the runs of the growth exponent and of the time average.
  std::vector<double> growth_mean, growth_sd, average_mean, average_sd;
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
/// of every value, and the statistics `stats` asks for. When `raw` is given it receives every
/// run's values (runs x values, row-major). The first exception of a run is rethrown after every
/// thread has stopped. Under a BlockSessionScope it computes one shard's blocks, or replays merged
/// ones (BlockSession).
Moments runMonteCarlo(long runs, std::size_t values, int threads, const WorkerFactory& make_worker,
                      ProgressCounter* progress = nullptr, std::vector<double>* raw = nullptr,
                      const CallStatistics* stats = nullptr);

/// The thread count actually used for a requested count (0 = hardware concurrency, at least 1).
int resolveThreads(int requested);

// ---------------------------------------------------------------------------------------------
// Blocks: sharding a run across processes (montecarlo_shards.hpp writes and merges the files)

/// The Welford state of one block of a runMonteCarlo call: what a shard computes and a merge
/// combines. Block b holds the runs b kBlockRuns .. min(runs, (b + 1) kBlockRuns) - 1.
struct BlockMoments
{
  long index = 0;
  long count = 0;                ///< runs in the block
  std::vector<double> mean, m2;  ///< per value: the mean and the sum of squared deviations
  std::vector<double> raw;       ///< count x values, row-major, when the call collects per-run values
};

/// The blocks of one runMonteCarlo call that a shard holds (merged: all of them). `values` counts
/// the accumulators of a run: the run's values, then one indicator per value and threshold, then
/// two per span (CallStatistics), in that order.
struct CallBlocks
{
  long runs = 0;
  std::size_t values = 0;
  bool raw = false;                  ///< the call collects per-run values
  std::vector<BlockMoments> blocks;  ///< by increasing index
  bool quantiles = false;            ///< the call keeps quantile sketches
  /// Per value of the run (not the other accumulators): the sketch of the runs of `blocks` (counts add
  /// exactly, so one sketch per shard rather than per block).
  std::vector<QuantileSketch> sketches;
};

/// Blocks of a call of `runs` runs.
long blockCount(long runs);
/// Runs in block b of a call of `runs` runs.
long blockRuns(long runs, long b);

/// The moments of a call from all its blocks, combined in block order exactly as runMonteCarlo
/// combines them (so bit for bit the same), and its per-run values into `raw` when given (all of
/// call.values per run). Throws InputError unless `call` holds every block 0 .. blockCount(runs) - 1
/// once, each of its size. The sketches and the CallStatistics' other results are not filled in.
Moments combineBlocks(const CallBlocks& call, std::vector<double>* raw = nullptr);

/// Redirects the runMonteCarlo calls made on one thread while a BlockSessionScope holds it:
///  - shard K of N: a call computes only its blocks b with b % N == K - 1 and appends them to
///    calls(); it returns the moments of those blocks alone (and zero rows in `raw` for the runs it
///    does not own), which only keep the experiment's post-processing going;
///  - replay: call i computes nothing and returns combineBlocks(calls[i]), so an experiment re-run
///    on merged blocks recomputes all its post-processing from exactly the unsharded moments.
/// A thread-local hook rather than a parameter, so that no experiment has to pass it along.
class BlockSession
{
public:
  /// Shard `index` (1-based) of `count`.
  static BlockSession shard(int index, int count);
  static BlockSession replay(std::vector<CallBlocks> calls);

  bool replaying() const { return replay_; }
  int shardIndex() const { return index_; }
  int shardCount() const { return count_; }
  /// Whether this shard computes block b (always true in a replay).
  bool owns(long b) const { return replay_ || b % count_ == index_ - 1; }
  /// Shard: the calls recorded so far. Replay: the calls to return.
  const std::vector<CallBlocks>& calls() const { return calls_; }
  /// Replay: how many calls have been returned.
  std::size_t replayed() const { return next_; }

  /// Shard: appends a call's blocks.
  void record(CallBlocks call) { calls_.push_back(std::move(call)); }
  /// Shard: hands over the recorded calls (the session keeps none).
  std::vector<CallBlocks> takeCalls() { return std::move(calls_); }
  /// Replay: the next call: its moments (of all `values` accumulators), per-run values and sketches.
  /// Throws InputError when the experiment asks for more calls than were recorded, or for a call of
  /// another size.
  Moments replayNext(long runs, std::size_t values, std::vector<double>* raw, bool quantiles,
                     std::vector<QuantileSketch>* sketches);

private:
  BlockSession() = default;
  bool replay_ = false;
  int index_ = 1, count_ = 1;
  std::vector<CallBlocks> calls_;
  std::size_t next_ = 0;
};

/// Installs a session for the runMonteCarlo calls of the current thread until destroyed.
class BlockSessionScope
{
public:
  explicit BlockSessionScope(BlockSession& session);
  ~BlockSessionScope();
  BlockSessionScope(const BlockSessionScope&) = delete;
  BlockSessionScope& operator=(const BlockSessionScope&) = delete;

private:
  BlockSession* previous_;
};

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
  // Heavy tails (docs/formats.md, "Heavy tails"); NaN where the experiment does not compute them.
  /// Per x: the quantiles over the runs (within QuantileSketch::kRelativeError).
  std::vector<double> p5, p25, median, p75, p95;
  /// Per threshold of ExperimentResult::thresholds, per x: the fraction of runs above it.
  std::vector<std::vector<double>> exceed;
  /// The sd over the runs of a run's own time average (its standard error: / sqrt(n)).
  double time_average_sd = std::numeric_limits<double>::quiet_NaN();
  /// The growth exponent of log value per unit of x (CallStatistics::spans): mean and sd over the
  /// runs, and the x range it is fitted over.
  double growth = std::numeric_limits<double>::quiet_NaN(), growth_sd = std::numeric_limits<double>::quiet_NaN();
  double growth_window0 = std::numeric_limits<double>::quiet_NaN(),
         growth_window1 = std::numeric_limits<double>::quiet_NaN();
  /// Whether the mean is estimable (summarise()): every mean finite, its standard error at most a
  /// fifth of it, and not above the 95th percentile; `mean_note` says why not. The plots draw the
  /// median with a quantile band where it is not.
  bool mean_estimable = true;
  std::string mean_note;
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

struct SweepResult;  // sweep.hpp

struct ExperimentResult
{
  std::string experiment;
  long runs = 0, steps = 0;
  std::vector<double> thresholds;  ///< --threshold: the M of the tail probabilities P(value > M)
  std::uint64_t seed = 1;
  int threads = 1;
  double wall_seconds = 0.0;
  std::string x_label, y_label;
  bool log_x = false, log_y = false;
  std::vector<std::string> assumptions, notes;
  std::vector<CaseResult> cases;
  std::vector<std::string> sample_columns;  ///< empty: no samples file
  std::vector<SampleSet> samples;
  /// sweep only: the grid (then `cases` is empty and the CSV is sweepCsv's).
  std::shared_ptr<const SweepResult> sweep;
};

/// Fills time_average and final_value of every series from its window, and mean_estimable.
void summarise(ExperimentResult& result);

/// `case,series,x,mean,sd,n,se,p5,p25,median,p75,p95` and a P_gt_M column per threshold, rows
/// (numbers with %.10g, NaN as nan, empty where not computed).
std::string experimentCsv(const ExperimentResult& result);
/// The JSON metadata document (written by hand, strings escaped).
std::string experimentJson(const ExperimentResult& result);
/// `case,run,<columns>` rows of the samples (empty string when there are none).
std::string samplesCsv(const ExperimentResult& result);
/// Writes DIR/<experiment>.csv, .json (and _samples.csv) atomically, creating DIR if needed.
/// Throws InputError when a file cannot be written.
void writeExperiment(const ExperimentResult& result, const std::string& dir);
/// Creates DIR and its parents when missing. Throws InputError when it cannot, or when a part of
/// the path is not a directory.
void makeOutputDirectory(const std::string& dir);

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
/// The name of the tail probability column of threshold M: "P_gt_" + M (%.10g).
std::string thresholdColumn(double threshold);

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

/// Runs an experiment (its canonicalConfig). Throws ConfigError for a bad configuration (unknown experiment, missing or
/// invalid custom files), InputError, DivergenceError when an estimator diverges.
ExperimentResult runExperiment(const MonteCarloConfig& config, ProgressCounter* progress = nullptr);

}  // namespace networked_estimation
