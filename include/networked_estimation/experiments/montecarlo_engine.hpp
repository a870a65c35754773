// The Monte Carlo engine (ROS-free): runs a function of the run index over many runs on several
// threads and returns the mean, sd and heavy-tail statistics of every value it fills in.
//
// Determinism: run r draws all its randomness from seeds derived with deriveSeed(seed, r), the
// runs are split into fixed blocks of kBlockRuns, each block is accumulated in run order and the
// blocks are combined in block order, so the results do not depend on the number of threads.
// A BlockSession passed to the engine computes one shard's blocks or replays merged ones
// (montecarlo_shards.hpp).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
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

class BlockSession;  // below

/// Fills out[0 .. values) with the values of run `run`.
using RunFunction = std::function<void(long run, double* out)>;
/// Builds the per-thread state (estimators, work buffers) and returns the run function using it.
/// Called once per worker thread, from that thread.
using WorkerFactory = std::function<RunFunction()>;

/// Runs `runs` runs on up to `threads` threads (0 = hardware concurrency) and returns the moments
/// of every value, and the statistics `stats` asks for. When `raw` is given it receives every
/// run's values (runs x values, row-major). The first exception of a run is rethrown after every
/// thread has stopped. With a `session` it computes one shard's blocks, or replays merged ones
/// (BlockSession); without, every block.
Moments runMonteCarlo(long runs, std::size_t values, int threads, const WorkerFactory& make_worker,
                      ProgressCounter* progress = nullptr, std::vector<double>* raw = nullptr,
                      const CallStatistics* stats = nullptr, BlockSession* session = nullptr);

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

/// Redirects the runMonteCarlo calls it is passed to (runExperiment passes its session down to
/// every call of the experiment):
///  - shard K of N: a call computes only its blocks b with b % N == K - 1 and appends them to
///    calls(); it returns the moments of those blocks alone (and zero rows in `raw` for the runs it
///    does not own), which only keep the experiment's post-processing going;
///  - replay: call i computes nothing and returns combineBlocks(calls[i]), so an experiment re-run
///    on merged blocks recomputes all its post-processing from exactly the unsharded moments.
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

}  // namespace networked_estimation
