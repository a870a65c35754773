// The Monte Carlo engine (montecarlo_engine.hpp): runs in blocks, their Welford moments, the
// heavy-tail statistics of a call, and the shard and replay sessions.
#include "networked_estimation/experiments/montecarlo_engine.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <thread>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

void ProgressCounter::add(long runs)
{
  std::lock_guard<std::mutex> lock(mutex_);
  done_ += runs;
  if (callback_)
    callback_(done_, std::max(total_, done_));
}

int resolveThreads(int requested)
{
  if (requested > 0)
    return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw > 0 ? static_cast<int>(hw) : 1;
}

namespace
{

/// Welford step: adds the run's values `v` to the block. A value that is not finite (a covariance-only
/// run whose P overflowed: +inf) makes the mean the plain sum's (inf, or NaN for mixed signs) and the
/// sd NaN, instead of the NaN of inf - inf.
void addRun(BlockMoments& a, const double* v)
{
  ++a.count;
  const double inv = 1.0 / static_cast<double>(a.count);
  for (std::size_t i = 0; i < a.mean.size(); ++i)
  {
    if (!(std::isfinite(v[i]) && std::isfinite(a.mean[i])))
    {
      a.mean[i] += v[i];
      a.m2[i] = std::nan("");
      continue;
    }
    const double d = v[i] - a.mean[i];
    a.mean[i] += d * inv;
    a.m2[i] += d * (v[i] - a.mean[i]);
  }
}

/// Chan et al.'s pairwise combination (a = a + o) of the count, mean and M2 (not the raw rows).
void mergeInto(BlockMoments& a, const BlockMoments& o)
{
  if (o.count == 0)
    return;
  if (a.count == 0)
  {
    a.count = o.count;
    a.mean = o.mean;
    a.m2 = o.m2;
    return;
  }
  const double na = static_cast<double>(a.count), nb = static_cast<double>(o.count);
  const double n = na + nb;
  for (std::size_t i = 0; i < a.mean.size(); ++i)
  {
    if (!(std::isfinite(o.mean[i]) && std::isfinite(a.mean[i])))
    {
      a.mean[i] += o.mean[i];  // as addRun
      a.m2[i] = std::nan("");
      continue;
    }
    const double d = o.mean[i] - a.mean[i];
    a.mean[i] += d * (nb / n);
    a.m2[i] += o.m2[i] + d * d * (na * nb / n);
  }
  a.count += o.count;
}

/// The moments of the blocks, combined in the order given. The only reduction of the engine: a
/// plain run, a shard and a merge all go through it, so a merge is bit for bit a plain run.
Moments reduceBlocks(const std::vector<const BlockMoments*>& blocks, std::size_t values)
{
  BlockMoments total;
  total.mean.assign(values, 0.0);
  total.m2.assign(values, 0.0);
  for (const BlockMoments* a : blocks)
    mergeInto(total, *a);
  Moments m;
  m.n = total.count;
  m.mean = total.mean;
  m.sd.assign(values, 0.0);
  if (total.count > 1)
    for (std::size_t i = 0; i < values; ++i)
      m.sd[i] = std::isnan(total.m2[i]) ? total.m2[i]
                                        : std::sqrt(std::max(0.0, total.m2[i] / static_cast<double>(total.count - 1)));
  return m;
}

/// The accumulators of a run of a call: its values, one indicator per value and threshold, two per span.
std::size_t accumulators(std::size_t values, const CallStatistics* st)
{
  return st ? values + values * st->thresholds.size() + 2 * st->spans.size() : values;
}

/// A span's per-run summaries as weights over its values.
struct SpanPlan
{
  std::size_t growth_first = 0;        ///< value index of the first point of the growth fit
  std::vector<double> growth_weights;  ///< the least-squares slope of log v: sum of w_j log v_j
  std::vector<std::size_t> window;     ///< value indices of the time average's window
};

std::vector<SpanPlan> planSpans(const CallStatistics* st, std::size_t values)
{
  std::vector<SpanPlan> plans;
  if (!st)
    return plans;
  for (const SeriesSpan& sp : st->spans)
  {
    if (sp.first + sp.x.size() > values)
      throw std::logic_error("runMonteCarlo: a span reaches past the run's values");
    SpanPlan p;
    const std::size_t count = sp.x.size(), half = count / 2;
    p.growth_first = sp.first + half;
    if (count - half >= 2)
    {
      double xm = 0.0, sxx = 0.0;
      for (std::size_t i = half; i < count; ++i)
        xm += sp.x[i];
      xm /= static_cast<double>(count - half);
      for (std::size_t i = half; i < count; ++i)
        sxx += (sp.x[i] - xm) * (sp.x[i] - xm);
      if (sxx > 0.0)
        for (std::size_t i = half; i < count; ++i)
          p.growth_weights.push_back((sp.x[i] - xm) / sxx);
    }
    for (std::size_t i = 0; i < count; ++i)
      if (sp.x[i] >= sp.window0 && sp.x[i] <= sp.window1)
        p.window.push_back(sp.first + i);
    plans.push_back(std::move(p));
  }
  return plans;
}

/// Fills the accumulators after the run's values v[0 .. values): the threshold indicators, then per
/// span the growth exponent and the time average.
void extendRun(double* v, std::size_t values, const CallStatistics& st, const std::vector<SpanPlan>& plans)
{
  double* e = v + values;
  const std::vector<double>& th = st.thresholds;
  if (!th.empty())
    for (std::size_t i = 0; i < values; ++i)
      for (double m : th)
        *e++ = v[i] > m ? 1.0 : 0.0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const SpanPlan& p : plans)
  {
    double g = p.growth_weights.empty() ? nan : 0.0;
    for (std::size_t j = 0; j < p.growth_weights.size(); ++j)
    {
      const double x = v[p.growth_first + j];
      if (!(x > 0.0 && x <= std::numeric_limits<double>::max()))
      {
        g = nan;
        break;
      }
      g += p.growth_weights[j] * std::log(x);
    }
    *e++ = g;
    double sum = 0.0;
    for (std::size_t i : p.window)
      sum += v[i];
    *e++ = p.window.empty() ? nan : sum / static_cast<double>(p.window.size());
  }
}

/// The call's result from the moments of all its accumulators: the statistics split off, the
/// per-run values of `all` (accumulators per run) into `raw` (values per run).
Moments finishCall(Moments m, std::size_t values, const CallStatistics* st, std::vector<QuantileSketch> sketches,
                   const std::vector<double>* all, std::vector<double>* raw)
{
  const std::size_t total = accumulators(values, st);
  if (raw && all && all != raw)
  {
    raw->clear();
    raw->reserve(all->size() / total * values);
    for (std::size_t r = 0; r * total < all->size(); ++r)
      raw->insert(raw->end(), all->begin() + static_cast<std::ptrdiff_t>(r * total),
                  all->begin() + static_cast<std::ptrdiff_t>(r * total + values));
  }
  if (!st)
    return m;
  const std::size_t nt = st->thresholds.size();
  m.thresholds = st->thresholds;
  m.spans = st->spans;
  m.exceed.assign(m.mean.begin() + static_cast<std::ptrdiff_t>(values),
                  m.mean.begin() + static_cast<std::ptrdiff_t>(values + values * nt));
  for (std::size_t k = 0; k < st->spans.size(); ++k)
  {
    const std::size_t o = values + values * nt + 2 * k;
    m.growth_mean.push_back(m.mean[o]);
    m.growth_sd.push_back(m.sd[o]);
    m.average_mean.push_back(m.mean[o + 1]);
    m.average_sd.push_back(m.sd[o + 1]);
  }
  m.mean.resize(values);
  m.sd.resize(values);
  m.sketches = std::move(sketches);
  return m;
}

}  // namespace

long blockCount(long runs)
{
  return runs > 0 ? (runs + kBlockRuns - 1) / kBlockRuns : 0;
}

long blockRuns(long runs, long b)
{
  return std::max(0L, std::min(runs, (b + 1) * kBlockRuns) - b * kBlockRuns);
}

Moments combineBlocks(const CallBlocks& call, std::vector<double>* raw)
{
  const long blocks = blockCount(call.runs);
  if (static_cast<long>(call.blocks.size()) != blocks)
    throw InputError("a call of " + std::to_string(call.runs) + " runs has " + std::to_string(blocks) +
                     " blocks, found " + std::to_string(call.blocks.size()));
  std::vector<const BlockMoments*> order;
  for (long b = 0; b < blocks; ++b)
  {
    const BlockMoments& a = call.blocks[static_cast<std::size_t>(b)];
    const std::string where =
        "block " + std::to_string(a.index) + " of a call of " + std::to_string(call.runs) + " runs";
    if (a.index != b)
      throw InputError("blocks out of order: expected block " + std::to_string(b) + ", found " + where);
    if (a.count != blockRuns(call.runs, b))
      throw InputError(where + ": expected " + std::to_string(blockRuns(call.runs, b)) + " runs, found " +
                       std::to_string(a.count));
    if (a.mean.size() != call.values || a.m2.size() != call.values)
      throw InputError(where + ": expected " + std::to_string(call.values) + " values");
    if (raw && (!call.raw || a.raw.size() != static_cast<std::size_t>(a.count) * call.values))
      throw InputError(where + ": expected " + std::to_string(a.count) + " x " + std::to_string(call.values) +
                       " per-run values");
    order.push_back(&a);
  }
  if (raw)
  {
    raw->clear();
    raw->reserve(static_cast<std::size_t>(call.runs) * call.values);
    for (const BlockMoments* a : order)
      raw->insert(raw->end(), a->raw.begin(), a->raw.end());
  }
  return reduceBlocks(order, call.values);
}

BlockSession BlockSession::shard(int index, int count)
{
  BlockSession s;
  s.index_ = index;
  s.count_ = count;
  return s;
}

BlockSession BlockSession::replay(std::vector<CallBlocks> calls)
{
  BlockSession s;
  s.replay_ = true;
  s.calls_ = std::move(calls);
  return s;
}

Moments BlockSession::replayNext(long runs, std::size_t values, std::vector<double>* raw, bool quantiles,
                                 std::vector<QuantileSketch>* sketches)
{
  if (next_ >= calls_.size())
    throw InputError(
        "the experiment makes more than the " + std::to_string(calls_.size()) +
        " Monte Carlo calls recorded in the shards (were they computed by another version of montecarlo?)");
  const CallBlocks& c = calls_[next_];
  if (c.quantiles != quantiles)
    throw InputError("Monte Carlo call " + std::to_string(next_) + ": the experiment " +
                     (quantiles ? "keeps" : "keeps no") + " quantile sketches, the shards " +
                     (c.quantiles ? "hold them" : "hold none") +
                     " (were they computed by another version of montecarlo?)");
  if (sketches)
    *sketches = c.sketches;
  if (c.runs != runs || c.values != values || c.raw != (raw != nullptr))
    throw InputError("Monte Carlo call " + std::to_string(next_) + ": the experiment asks for " + std::to_string(runs) +
                     " runs x " + std::to_string(values) + " values" + (raw ? " with per-run values" : "") +
                     ", the shards hold " + std::to_string(c.runs) + " x " + std::to_string(c.values) +
                     (c.raw ? " with per-run values" : "") + " (were they computed by another version of montecarlo?)");
  ++next_;
  return combineBlocks(c, raw);
}

Moments runMonteCarlo(long runs, std::size_t values, int threads, const WorkerFactory& make_worker,
                      ProgressCounter* progress, std::vector<double>* raw, const CallStatistics* stats,
                      BlockSession* session)
{
  // Every accumulator of a run (values, then the statistics' own) goes through the blocks' Welford
  // reduction; the sketches of the values are kept per thread and added (exact) at the end.
  const std::size_t total = accumulators(values, stats);
  const bool quantiles = stats && stats->quantiles;
  const std::vector<SpanPlan> plans = planSpans(stats, values);
  std::vector<double> all_raw;
  std::vector<double>* run_raw = raw ? (total == values ? raw : &all_raw) : nullptr;
  std::vector<QuantileSketch> sketches;

  if (session && session->replaying())
  {
    Moments m = session->replayNext(runs, total, run_raw, quantiles, &sketches);
    if (quantiles && sketches.size() != values)
      throw InputError("Monte Carlo call " + std::to_string(session->replayed() - 1) + ": expected " +
                       std::to_string(values) + " quantile sketches, the shards hold " +
                       std::to_string(sketches.size()));
    return finishCall(std::move(m), values, stats, std::move(sketches), run_raw, raw);
  }
  // the blocks this process computes: all of them, or a shard's share
  std::vector<long> todo;
  long skipped = 0;
  for (long b = 0; b < blockCount(runs); ++b)
    if (!session || session->owns(b))
      todo.push_back(b);
    else
      skipped += blockRuns(runs, b);
  if (progress && skipped > 0)
    progress->add(skipped);  // other shards' runs: the progress still ends at 100 %
  const long blocks = static_cast<long>(todo.size());
  std::vector<BlockMoments> acc(todo.size());
  if (run_raw)
    run_raw->assign(static_cast<std::size_t>(runs) * total, 0.0);
  std::atomic<long> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  long error_block = -1;
  std::mutex error_mutex;
  std::vector<std::vector<QuantileSketch>> thread_sketches;  // per worker thread (added up afterwards)

  auto work = [&]()
  {
    try
    {
      RunFunction run = make_worker();
      std::vector<double> out(total);
      std::vector<QuantileSketch> sk(quantiles ? values : 0);
      // the block's values, added to the sketches value by value after the block: each sketch is then
      // touched once per block rather than once per run (a run touches every value's sketch)
      std::vector<double> block_values(quantiles ? static_cast<std::size_t>(kBlockRuns) * values : 0);
      while (!failed.load())
      {
        const long i = next.fetch_add(1);
        if (i >= blocks)
          break;
        const long b = todo[static_cast<std::size_t>(i)];
        try
        {
          BlockMoments& a = acc[static_cast<std::size_t>(i)];
          a.index = b;
          a.count = 0;
          a.mean.assign(total, 0.0);
          a.m2.assign(total, 0.0);
          const long r1 = std::min(runs, (b + 1) * kBlockRuns);
          for (long r = b * kBlockRuns; r < r1; ++r)
          {
            double* dst = run_raw ? run_raw->data() + static_cast<std::size_t>(r) * total : out.data();
            run(r, dst);
            if (stats)
              extendRun(dst, values, *stats, plans);
            addRun(a, dst);
            if (quantiles)
              std::copy(dst, dst + values,
                        block_values.begin() + static_cast<std::ptrdiff_t>((r - b * kBlockRuns) * values));
          }
          const std::size_t block_runs = static_cast<std::size_t>(r1 - b * kBlockRuns);
          for (std::size_t v = 0; v < sk.size(); ++v)
            for (std::size_t j = 0; j < block_runs; ++j)
              sk[v].add(block_values[j * values + v]);
          if (progress)
            progress->add(r1 - b * kBlockRuns);
        }
        catch (...)
        {
          std::lock_guard<std::mutex> lock(error_mutex);
          // keep the error of the lowest block: the same error whatever the thread count
          if (!error || b < error_block)
          {
            error = std::current_exception();
            error_block = b;
          }
          failed = true;
        }
      }
      if (quantiles)
      {
        std::lock_guard<std::mutex> lock(error_mutex);
        thread_sketches.push_back(std::move(sk));
      }
    }
    catch (...)
    {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error)
        error = std::current_exception();
      failed = true;
    }
  };

  const int nthreads = static_cast<int>(std::max<long>(1, std::min<long>(resolveThreads(threads), blocks)));
  if (nthreads == 1)
    work();
  else
  {
    std::vector<std::thread> pool;
    for (int t = 0; t < nthreads; ++t)
      pool.emplace_back(work);
    for (std::thread& t : pool)
      t.join();
  }
  if (error)
    std::rethrow_exception(error);
  if (quantiles)
  {
    sketches.resize(values);
    for (const std::vector<QuantileSketch>& t : thread_sketches)
      for (std::size_t v = 0; v < values; ++v)
        sketches[v].merge(t[v]);
  }

  std::vector<const BlockMoments*> order;
  for (const BlockMoments& a : acc)
    order.push_back(&a);
  const Moments m = reduceBlocks(order, total);
  if (session)
  {
    CallBlocks call;
    call.runs = runs;
    call.values = total;
    call.raw = run_raw != nullptr;
    if (run_raw)
      for (BlockMoments& a : acc)
        a.raw.assign(run_raw->begin() + static_cast<std::ptrdiff_t>(a.index * kBlockRuns * static_cast<long>(total)),
                     run_raw->begin() +
                         static_cast<std::ptrdiff_t>((a.index * kBlockRuns + a.count) * static_cast<long>(total)));
    call.blocks = std::move(acc);
    call.quantiles = quantiles;
    call.sketches = sketches;
    session->record(std::move(call));
  }
  return finishCall(m, values, stats, std::move(sketches), run_raw, raw);
}

}  // namespace networked_estimation
