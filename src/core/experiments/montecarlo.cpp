// Monte Carlo engine, result formatting and the experiment dispatch (montecarlo.hpp).
#include "networked_estimation/experiments/montecarlo.hpp"

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <sstream>
#include <sys/stat.h>
#include <thread>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/experiments/sweep.hpp"
#include "networked_estimation/io/json_writer.hpp"
#include "networked_estimation/io/atomic_file.hpp"

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Engine

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

/// The session of this thread's runMonteCarlo calls (BlockSessionScope), null: a plain run.
thread_local BlockSession* t_session = nullptr;

/// The accumulators of a run of a call: its values, one indicator per value and threshold, two per span.
std::size_t accumulators(std::size_t values, const CallStatistics* st)
{
  return st ? values + values * st->thresholds.size() + 2 * st->spans.size() : values;
}

/// A span's per-run summaries as weights over its values.
struct SpanPlan
{
  std::size_t growth_first = 0;       ///< value index of the first point of the growth fit
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
    const std::string where = "block " + std::to_string(a.index) + " of a call of " + std::to_string(call.runs) + " runs";
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
    throw InputError("the experiment makes more than the " + std::to_string(calls_.size()) +
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
    throw InputError("Monte Carlo call " + std::to_string(next_) + ": the experiment asks for " +
                     std::to_string(runs) + " runs x " + std::to_string(values) + " values" +
                     (raw ? " with per-run values" : "") + ", the shards hold " + std::to_string(c.runs) + " x " +
                     std::to_string(c.values) + (c.raw ? " with per-run values" : "") +
                     " (were they computed by another version of montecarlo?)");
  ++next_;
  return combineBlocks(c, raw);
}

BlockSessionScope::BlockSessionScope(BlockSession& session) : previous_(t_session)
{
  t_session = &session;
}

BlockSessionScope::~BlockSessionScope()
{
  t_session = previous_;
}

Moments runMonteCarlo(long runs, std::size_t values, int threads, const WorkerFactory& make_worker,
                      ProgressCounter* progress, std::vector<double>* raw, const CallStatistics* stats)
{
  // Every accumulator of a run (values, then the statistics' own) goes through the blocks' Welford
  // reduction; the sketches of the values are kept per thread and added (exact) at the end.
  const std::size_t total = accumulators(values, stats);
  const bool quantiles = stats && stats->quantiles;
  const std::vector<SpanPlan> plans = planSpans(stats, values);
  std::vector<double> all_raw;
  std::vector<double>* run_raw = raw ? (total == values ? raw : &all_raw) : nullptr;
  std::vector<QuantileSketch> sketches;

  BlockSession* const session = t_session;
  if (session && session->replaying())
  {
    Moments m = session->replayNext(runs, total, run_raw, quantiles, &sketches);
    if (quantiles && sketches.size() != values)
      throw InputError("Monte Carlo call " + std::to_string(session->replayed() - 1) + ": expected " +
                       std::to_string(values) + " quantile sketches, the shards hold " + std::to_string(sketches.size()));
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

  auto work = [&]() {
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
              std::copy(dst, dst + values, block_values.begin() + static_cast<std::ptrdiff_t>((r - b * kBlockRuns) * values));
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

// ---------------------------------------------------------------------------------------------
// Results

namespace
{

/// Why a series' mean is not estimable ("" when it is): a mean that is not finite, a standard error
/// above a fifth of the mean, or a mean above the 95th percentile (a few runs carry it).
std::string meanProblem(const CaseResult& c, const SeriesResult& s)
{
  for (std::size_t i = 0; i < s.mean.size(); ++i)
  {
    const std::string at = i < c.x.size() ? " at x = " + mc::fmt(c.x[i]) : "";
    if (!std::isfinite(s.mean[i]))
      return "the mean is not finite" + at + " (some runs overflowed)";
    if (s.n > 1 && i < s.sd.size())
    {
      const double se = s.sd[i] / std::sqrt(static_cast<double>(s.n));
      if (!(se <= 0.2 * std::abs(s.mean[i])))
        return "its standard error is " + mc::fmt(std::round(100.0 * se / std::abs(s.mean[i]))) + " % of it" + at;
    }
    if (i < s.p95.size() && std::isfinite(s.p95[i]) && s.mean[i] > s.p95[i] && s.mean[i] > 0.0)
      return "it lies above the 95th percentile" + at + " (a few runs carry it)";
  }
  return "";
}

}  // namespace

void summarise(ExperimentResult& result)
{
  for (CaseResult& c : result.cases)
    for (SeriesResult& s : c.series)
    {
      s.mean_note = s.bound ? "" : meanProblem(c, s);
      s.mean_estimable = s.mean_note.empty();
      double sum = 0.0;
      long count = 0;
      for (std::size_t i = 0; i < c.x.size() && i < s.mean.size(); ++i)
        if (c.x[i] >= s.window0 && c.x[i] <= s.window1)
        {
          sum += s.mean[i];
          ++count;
        }
      s.time_average = count > 0 ? sum / static_cast<double>(count) : std::nan("");
      s.final_value = s.mean.empty() ? std::nan("") : s.mean.back();
    }
}

namespace
{

std::string csvField(const std::string& s)
{
  if (s.find_first_of(",\"\n") == std::string::npos)
    return s;
  std::string out = "\"";
  for (char c : s)
  {
    if (c == '"')
      out += '"';
    out += c;
  }
  return out + "\"";
}

/// A list of strings, one a line, indented by `indent` (or [] when empty).
void writeLines(JsonWriter& w, const std::vector<std::string>& v, int indent)
{
  w.beginArray();
  for (const std::string& s : v)
    w.br(indent + 2).value(s);
  if (!v.empty())
    w.br(indent);
  w.endArray();
}

}  // namespace

std::string thresholdColumn(double threshold)
{
  return "P_gt_" + mc::fmt(threshold);
}

namespace
{

/// Entry i of v, or an empty cell when v holds none (not computed).
std::string cell(const std::vector<double>& v, std::size_t i)
{
  return i < v.size() ? mc::fmt(v[i]) : std::string();
}

}  // namespace

std::string experimentCsv(const ExperimentResult& result)
{
  if (result.sweep)
    return sweepCsv(*result.sweep);
  std::ostringstream os;
  os << "case,series,x,mean,sd,n,se,p5,p25,median,p75,p95";
  for (double m : result.thresholds)
    os << ',' << thresholdColumn(m);
  os << '\n';
  for (const CaseResult& c : result.cases)
    for (const SeriesResult& s : c.series)
      for (std::size_t i = 0; i < c.x.size(); ++i)
      {
        os << csvField(c.name) << ',' << csvField(s.name) << ',' << mc::fmt(c.x[i]) << ',' << mc::fmt(s.mean[i])
           << ',' << mc::fmt(s.sd[i]) << ',' << s.n << ','
           << (s.n > 0 ? mc::fmt(s.sd[i] / std::sqrt(static_cast<double>(s.n))) : std::string());
        for (const std::vector<double>* q : {&s.p5, &s.p25, &s.median, &s.p75, &s.p95})
          os << ',' << cell(*q, i);
        for (std::size_t t = 0; t < result.thresholds.size(); ++t)
          os << ',' << (t < s.exceed.size() ? cell(s.exceed[t], i) : std::string());
        os << '\n';
      }
  return os.str();
}

std::string experimentJson(const ExperimentResult& r)
{
  JsonWriter w;
  w.beginObject();
  w.br(2).member("experiment", r.experiment);
  w.br(2).member("runs", r.runs);
  w.br(2).member("steps", r.steps);
  w.br(2).member("seed", r.seed);
  w.br(2).member("threads", r.threads);
  w.br(2).member("wall_seconds", mc::rounded(r.wall_seconds));
  w.br(2).member("x_label", r.x_label);
  w.br(2).member("y_label", r.y_label);
  w.br(2).member("log_x", r.log_x);
  w.br(2).member("log_y", r.log_y);
  w.br(2).key("thresholds").value(r.thresholds);
  w.br(2).member("quantile_relative_error", QuantileSketch::kRelativeError);
  w.br(2).key("assumptions");
  writeLines(w, r.assumptions, 2);
  w.br(2).key("cases").beginArray();
  for (const CaseResult& cr : r.cases)
  {
    w.br(4).beginObject();
    w.br(6).member("name", cr.name);
    w.br(6).member("title", cr.title);
    w.br(6).key("series").beginArray();
    for (const SeriesResult& sr : cr.series)
    {
      const double rn = sr.n > 0 ? std::sqrt(static_cast<double>(sr.n)) : std::nan("");
      w.br(8).beginObject().member("name", sr.name);
      w.member("time_average", mc::rounded(sr.time_average)).member("final", mc::rounded(sr.final_value));
      w.key("window").beginArray().value(mc::rounded(sr.window0)).value(mc::rounded(sr.window1)).endArray();
      if (sr.bound)
        w.member("bound", true);
      w.br(10).member("time_average_se", mc::rounded(sr.time_average_sd / rn));
      w.member("final_se", mc::rounded(sr.sd.empty() ? std::nan("") : sr.sd.back() / rn));
      w.key("growth");
      if (std::isfinite(sr.growth))
      {
        const double half = 1.96 * sr.growth_sd / rn;  // the 95 % interval of the mean over the runs
        w.beginObject().member("rate", mc::rounded(sr.growth)).member("low", mc::rounded(sr.growth - half));
        w.member("high", mc::rounded(sr.growth + half));
        w.key("window").beginArray().value(mc::rounded(sr.growth_window0)).value(mc::rounded(sr.growth_window1));
        w.endArray().endObject();
      }
      else
        w.null();
      w.member("statistic", sr.mean_estimable ? "mean" : "median");
      if (!sr.mean_estimable)
        w.member("mean_note", "mean not estimable: " + sr.mean_note);
      w.endObject();
    }
    w.br(6).endArray();
    w.br(4).endObject();
  }
  if (!r.cases.empty())
    w.br(2);
  w.endArray();
  if (r.sweep)
  {
    w.br(2).key("sweep");
    writeSweepJson(w, *r.sweep, 2);
  }
  w.br(2).key("notes");
  writeLines(w, r.notes, 2);
  w.br(0).endObject();
  return w.text() + "\n";
}

std::string samplesCsv(const ExperimentResult& r)
{
  if (r.sample_columns.empty())
    return "";
  std::ostringstream os;
  os << "case,run";
  for (const std::string& c : r.sample_columns)
    os << ',' << csvField(c);
  os << '\n';
  const std::size_t cols = r.sample_columns.size();
  for (const SampleSet& s : r.samples)
    for (std::size_t row = 0; row * cols < s.values.size(); ++row)
    {
      os << csvField(s.case_name) << ',' << row;
      for (std::size_t j = 0; j < cols; ++j)
        os << ',' << mc::fmt(s.values[row * cols + j]);
      os << '\n';
    }
  return os.str();
}

void makeOutputDirectory(const std::string& dir)
{
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/')
    partial = "/";
  while (std::getline(ss, part, '/'))
  {
    if (part.empty())
      continue;
    partial += part;
    struct stat st;
    if (stat(partial.c_str(), &st) != 0)
    {
      if (mkdir(partial.c_str(), 0777) != 0 && errno != EEXIST)
        throw InputError(dir + ": cannot create the output directory (" + partial + ")");
    }
    else if (!S_ISDIR(st.st_mode))
      throw InputError(dir + ": not a directory (" + partial + ")");
    partial += "/";
  }
}

void writeExperiment(const ExperimentResult& result, const std::string& dir)
{
  makeOutputDirectory(dir);
  const std::string base = (dir.empty() ? std::string(".") : dir) + "/" + result.experiment;
  AtomicFile csv(base + ".csv");
  csv.stream() << experimentCsv(result);
  AtomicFile json(base + ".json");
  json.stream() << experimentJson(result);
  if (!result.sample_columns.empty())
  {
    AtomicFile samples(base + "_samples.csv");
    samples.stream() << samplesCsv(result);
    samples.commit();
  }
  csv.commit();
  json.commit();
}

// ---------------------------------------------------------------------------------------------
// Experiments

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
      {"zhou_fig1", 5000, 500, &mc::zhouFig1}, {"zhou_fig2", 5000, 500, &mc::zhouFig2},
      {"custom", 1000, 200, &mc::customExperiment}, {"sweep", 1000, 200, &mc::sweepExperiment},
      {"covariance", 1000, 1000, &mc::covarianceExperiment},
      {"lin_fig2", 1000, 30, &mc::linFig2},
      {"lin_fig3", 500, 30, &mc::linFig3},   {"lin_fig4", 1000, 30, &mc::linFig4},
      {"lin_fig5", 1000, 50, &mc::linFig5},  {"yang_fig2", 10000, 40, &mc::yangFig2},
      {"sinopoli_fig2", 1000, 100, &mc::sinopoliFig2}, {"mo_sinopoli_tail", 10000, 200, &mc::moSinopoliTail},
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
  static const std::vector<std::string> names = [] {
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
    throw ConfigError("experiment " + c.experiment + ": --covariance-only is for the experiments custom, covariance "
                      "and sweep");
  if (c.experiment == "custom" && c.covariance_only)
    c.experiment = "covariance";
  if (c.experiment == "covariance")
    c.covariance_only = true;
  return c;
}

ExperimentResult runExperiment(const MonteCarloConfig& in, ProgressCounter* progress)
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

// ---------------------------------------------------------------------------------------------
// Shared helpers

namespace mc
{

SeriesResult makeSeries(const std::string& name, const Moments& m, std::size_t first, std::size_t count,
                        double window0, double window1)
{
  SeriesResult s;
  s.name = name;
  s.mean.assign(m.mean.begin() + static_cast<std::ptrdiff_t>(first),
                m.mean.begin() + static_cast<std::ptrdiff_t>(first + count));
  s.sd.assign(m.sd.begin() + static_cast<std::ptrdiff_t>(first), m.sd.begin() + static_cast<std::ptrdiff_t>(first + count));
  s.n = m.n;
  s.window0 = window0;
  s.window1 = window1;
  resizeTails(s, count, m);
  for (std::size_t i = 0; i < count; ++i)
    setTails(s, i, m, first + i);
  for (std::size_t k = 0; k < m.spans.size(); ++k)
  {
    const SeriesSpan& sp = m.spans[k];
    if (sp.first != first || sp.x.size() != count)
      continue;
    s.growth = m.growth_mean[k];
    s.growth_sd = m.growth_sd[k];
    s.growth_window0 = sp.x[count / 2];
    s.growth_window1 = sp.x.back();
    if (sp.window0 == window0 && sp.window1 == window1)
      s.time_average_sd = m.average_sd[k];
  }
  return s;
}

void resizeTails(SeriesResult& s, std::size_t count, const Moments& m)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!m.sketches.empty())
    for (std::vector<double>* q : {&s.p5, &s.p25, &s.median, &s.p75, &s.p95})
      q->assign(count, nan);
  s.exceed.assign(m.thresholds.size(), std::vector<double>(count, nan));
}

void setTails(SeriesResult& s, std::size_t i, const Moments& m, std::size_t v)
{
  if (!m.sketches.empty())
  {
    const QuantileSketch& q = m.sketches.at(v);
    s.p5.at(i) = q.quantile(0.05);
    s.p25.at(i) = q.quantile(0.25);
    s.median.at(i) = q.quantile(0.5);
    s.p75.at(i) = q.quantile(0.75);
    s.p95.at(i) = q.quantile(0.95);
  }
  const std::size_t nt = m.thresholds.size();
  for (std::size_t t = 0; t < nt && t < s.exceed.size(); ++t)
    s.exceed[t].at(i) = m.exceed.at(v * nt + t);
}

CallStatistics callStatistics(const RunConfig& rc)
{
  CallStatistics st;
  st.quantiles = true;
  if (rc.config)
    st.thresholds = rc.config->thresholds;
  return st;
}

void addSpan(CallStatistics& st, std::size_t first, const std::vector<double>& x, double window0, double window1)
{
  SeriesSpan sp;
  sp.first = first;
  sp.x = x;
  sp.window0 = window0;
  sp.window1 = window1;
  st.spans.push_back(std::move(sp));
}

std::vector<double> stepAxis(long steps)
{
  std::vector<double> x(static_cast<std::size_t>(steps));
  for (long k = 1; k <= steps; ++k)
    x[static_cast<std::size_t>(k - 1)] = static_cast<double>(k);
  return x;
}

Model zhouExampleModel(double delta)
{
  Model m;
  m.name = "zhou_example";
  m.period = 0.01;
  m.A.resize(2, 2);
  m.A << 0.9802, 0.0196, 0.0, 0.9802;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q.resize(2, 2);
  m.Q << 1.9608, 0.0195, 0.0195, 1.9605;
  m.C.resize(1, 2);
  m.C << 1, -1;
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.x0 = Eigen::Vector2d(1, 0);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors.push_back({"y", 0, 1});
  Uncertainty u;
  u.dA = Eigen::MatrixXd::Zero(2, 2);
  u.dA(0, 1) = 0.099;
  u.dB = Eigen::MatrixXd::Zero(2, 2);
  u.dC = Eigen::MatrixXd::Zero(1, 2);
  u.range = delta;
  m.uncertainty.push_back(u);
  m.Bu.resize(2, 0);
  validateModel(m, "zhou_example");
  return m;
}

Model aoeExampleModel(double rhoA)
{
  Model m;
  m.name = "aoe_example";
  m.period = 0.01;
  m.A.resize(2, 2);
  m.A << rhoA, 0, 0, 1.005;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = 20.0 * Eigen::MatrixXd::Identity(2, 2);
  m.C.resize(2, 2);
  m.C << 1, -1, 0, 1;
  m.R = 20.0 * Eigen::MatrixXd::Identity(2, 2);
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors.push_back({"y", 0, 2});
  m.Bu.resize(2, 1);
  m.Bu << -1, 1;
  validateModel(m, "aoe_example");
  return m;
}

const std::vector<double>& yangRates()
{
  static const std::vector<double> rates = {0.2443, 0.4572, 0.7435, 0.6174, 0.1747, 0.6024, 0.8031, 0.3663};
  return rates;
}

Model yangExampleModel()
{
  Model m;
  m.name = "yang_example1";
  m.period = 1.0;
  m.A.resize(2, 2);
  m.A << -0.82, 0.53, 0.34, 0.78;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q.resize(2, 2);
  m.Q << 0.53, 0.21, 0.21, 0.50;
  const std::vector<std::vector<double>> H = {
      {-0.69, 0.67},           {1.18, -0.36, 0.70, -0.38}, {-1.58, 1.43},           {-1.71, -2.12},
      {-0.65, 0.49, -2.01, 0.46}, {1.79, 2.2, 0.59, 0.31},     {1.28, 2.07, -1.00, -0.92}, {0.18, 0.21, 2.04, 0.91},
  };
  int rows = 0;
  for (const auto& h : H)
    rows += static_cast<int>(h.size()) / 2;
  m.C.resize(rows, 2);
  int off = 0;
  for (std::size_t i = 0; i < H.size(); ++i)
  {
    const int p = static_cast<int>(H[i].size()) / 2;
    for (int r = 0; r < p; ++r)
    {
      m.C(off + r, 0) = H[i][2 * r];
      m.C(off + r, 1) = H[i][2 * r + 1];
    }
    m.sensors.push_back({"s" + std::to_string(i + 1), off, p});
    off += p;
  }
  m.R = Eigen::MatrixXd::Identity(rows, rows);
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.Bu.resize(2, 0);
  validateModel(m, "yang_example1");
  return m;
}

}  // namespace mc

}  // namespace networked_estimation
