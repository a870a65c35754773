// Monte Carlo engine, result formatting and the experiment dispatch (montecarlo.hpp).
#include "networked_estimation/experiments/montecarlo.hpp"

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <exception>
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

/// Welford step: adds the run's values `v` to the block.
void addRun(BlockMoments& a, const double* v)
{
  ++a.count;
  const double inv = 1.0 / static_cast<double>(a.count);
  for (std::size_t i = 0; i < a.mean.size(); ++i)
  {
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
      m.sd[i] = std::sqrt(std::max(0.0, total.m2[i] / static_cast<double>(total.count - 1)));
  return m;
}

/// The session of this thread's runMonteCarlo calls (BlockSessionScope), null: a plain run.
thread_local BlockSession* t_session = nullptr;

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

Moments BlockSession::replayNext(long runs, std::size_t values, std::vector<double>* raw)
{
  if (next_ >= calls_.size())
    throw InputError("the experiment makes more than the " + std::to_string(calls_.size()) +
                     " Monte Carlo calls recorded in the shards (were they computed by another version of montecarlo?)");
  const CallBlocks& c = calls_[next_];
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
                      ProgressCounter* progress, std::vector<double>* raw)
{
  BlockSession* const session = t_session;
  if (session && session->replaying())
    return session->replayNext(runs, values, raw);
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
  if (raw)
    raw->assign(static_cast<std::size_t>(runs) * values, 0.0);
  std::atomic<long> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  long error_block = -1;
  std::mutex error_mutex;

  auto work = [&]() {
    try
    {
      RunFunction run = make_worker();
      std::vector<double> out(values);
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
          a.mean.assign(values, 0.0);
          a.m2.assign(values, 0.0);
          const long r1 = std::min(runs, (b + 1) * kBlockRuns);
          for (long r = b * kBlockRuns; r < r1; ++r)
          {
            double* dst = raw ? raw->data() + static_cast<std::size_t>(r) * values : out.data();
            run(r, dst);
            addRun(a, dst);
          }
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

  std::vector<const BlockMoments*> order;
  for (const BlockMoments& a : acc)
    order.push_back(&a);
  const Moments m = reduceBlocks(order, values);
  if (session)
  {
    CallBlocks call;
    call.runs = runs;
    call.values = values;
    call.raw = raw != nullptr;
    if (raw)
      for (BlockMoments& a : acc)
        a.raw.assign(raw->begin() + static_cast<std::ptrdiff_t>(a.index * kBlockRuns * static_cast<long>(values)),
                     raw->begin() + static_cast<std::ptrdiff_t>((a.index * kBlockRuns + a.count) * static_cast<long>(values)));
    call.blocks = std::move(acc);
    session->record(std::move(call));
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Results

void summarise(ExperimentResult& result)
{
  for (CaseResult& c : result.cases)
    for (SeriesResult& s : c.series)
    {
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

std::string experimentCsv(const ExperimentResult& result)
{
  if (result.sweep)
    return sweepCsv(*result.sweep);
  std::ostringstream os;
  os << "case,series,x,mean,sd,n\n";
  for (const CaseResult& c : result.cases)
    for (const SeriesResult& s : c.series)
      for (std::size_t i = 0; i < c.x.size(); ++i)
        os << csvField(c.name) << ',' << csvField(s.name) << ',' << mc::fmt(c.x[i]) << ',' << mc::fmt(s.mean[i])
           << ',' << mc::fmt(s.sd[i]) << ',' << s.n << '\n';
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
      w.br(8).beginObject().member("name", sr.name);
      w.member("time_average", mc::rounded(sr.time_average)).member("final", mc::rounded(sr.final_value));
      w.key("window").beginArray().value(mc::rounded(sr.window0)).value(mc::rounded(sr.window1)).endArray();
      if (sr.bound)
        w.member("bound", true);
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
      {"lin_fig2", 1000, 30, &mc::linFig2},
      {"lin_fig3", 500, 30, &mc::linFig3},   {"lin_fig4", 1000, 30, &mc::linFig4},
      {"lin_fig5", 1000, 50, &mc::linFig5},  {"yang_fig2", 10000, 40, &mc::yangFig2},
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

ExperimentResult runExperiment(const MonteCarloConfig& config, ProgressCounter* progress)
{
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
  return s;
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
