// Micro-benchmark of one estimator step (Google Benchmark).
//
// Times Estimator::step for every algorithm at n = 2, 4, 8, 20 (m = n/2, m = 1 for n = 2;
// nw = n; one uncertain parameter with non-zero dA, dB, dC; p = 1 control input) next to a
// minimal hand-written dynamic-size Eigen Kalman filter (the baseline every ratio refers to) and
// a hand-written fixed-size Eigen Kalman filter (n = 2, 4, 8). makeEstimator gives the estimators
// their fixed-size form at n = 2 and 4 and the dynamic one at n = 8 and 20; each benchmark's label
// names the form it ran. kf_dynamic, kfio_dynamic, rseio_arrival_dynamic and aoe_dynamic run the
// dynamic form at n = 2 and 4 for comparison. kfio_angle runs kfio on the same plant with state 0 an
// angle (n = 2, 4, 8): the cost of wrapping the innovation and the state (docs/algorithms.md 2.7).
//
// The benchmarks are registered normally, so every --benchmark_* flag works (filter, out, ...).
// After the run a summary table prints, per algorithm and n, the median and the minimum time per
// step over the repetitions and their ratio to the dynamic baseline at the same n, with the
// targets (for n >= 4: kfio <= 1.2x, aoe <= 2.5x, rseio arrival <= 3x, oe per component <= 1.5x)
// marked PASS / MISS; a second table gives the ratios to fixed_kf, with the targets of the
// fixed-size forms (n = 2 and 4: kfio <= 1.3x, aoe <= 2x, rseio arrival <= 3x). Timing is not a
// test: the program always exits 0 when the benchmarks ran.
//
// Flags of this program (removed before benchmark::Initialize):
//   --quick      smoke run: --benchmark_min_time=0.01 --benchmark_repetitions=1
//   --cpu-time   build the summary from CPU time per step instead of real time (steadier when
//                other processes compete for the cores; the console shows both anyway)
//   --iterations=N  run every benchmark exactly N iterations (instruction counts: run under
//                valgrind --tool=callgrind with two values of N; the difference of the totals
//                over the difference of N is the count per step, setup and warm-up cancel)
// Defaults (flags given on the command line override them): --benchmark_repetitions=5
// --benchmark_enable_random_interleaving=true (repetitions of all benchmarks run in random order,
// so a burst of load from other processes hits the baseline and the estimators alike, and the
// console lists them in completion order). The console shows the median and min aggregates only;
// --benchmark_out=FILE records every repetition.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "estimators/estimator_factory.hpp"  // private header: makeEstimator with the choice of form
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/estimator_settings.hpp"

namespace networked_estimation
{
namespace
{

constexpr int kRingSize = 1024;  // pre-generated samples; a power of two
constexpr double kSpectralRadius = 0.95;
constexpr std::size_t kOeComponents = 64;
const std::vector<int> kSizes = {2, 4, 8, 20};

constexpr int measurementCount(int n)
{
  return n == 2 ? 1 : n / 2;
}

// ---------------------------------------------------------------------------------------------
// Model and data generation
// ---------------------------------------------------------------------------------------------

Eigen::MatrixXd randomMatrix(Rng& rng, int r, int c, double scale = 1.0)
{
  Eigen::MatrixXd M(r, c);
  for (int i = 0; i < r; ++i)
  {
    for (int j = 0; j < c; ++j)
    {
      M(i, j) = scale * rng.uniform(-1.0, 1.0);
    }
  }
  return M;
}

/// Symmetric positive definite with eigenvalues in [lo, hi].
Eigen::MatrixXd randomSpd(Rng& rng, int n, double lo, double hi)
{
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(randomMatrix(rng, n, n));
  const Eigen::MatrixXd U = qr.householderQ();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i)
  {
    d[i] = rng.uniform(lo, hi);
  }
  const Eigen::MatrixXd S = U * d.asDiagonal() * U.transpose();
  return 0.5 * (S + S.transpose());
}

/// The benchmark plant: stable A (spectral radius 0.95), m = n/2 rows in one sensor, nw = n,
/// one uncertain parameter with non-zero dA, dB, dC, and one control input. `angle`: state 0 is
/// an angle (docs/algorithms.md 2.7) measured by row 0: column 0 of A is e_0 (a random walk the
/// others do not feed on), row 0 of C is e_0' and no other row, dA or dC involves state 0.
Model benchModel(int n, bool angle = false)
{
  Rng rng(deriveSeed(20240601, static_cast<std::uint64_t>(n)));
  const int m = measurementCount(n);
  const int nw = n;
  Model model;
  model.name = "bench_n" + std::to_string(n);
  model.period = 0.01;
  model.A = randomMatrix(rng, n, n);
  const double rho = Eigen::EigenSolver<Eigen::MatrixXd>(model.A, false).eigenvalues().cwiseAbs().maxCoeff();
  model.A *= kSpectralRadius / rho;
  model.B = randomMatrix(rng, n, nw, 0.5);
  model.Q = randomSpd(rng, nw, 0.2, 1.0);
  model.C = randomMatrix(rng, m, n);
  model.R = randomSpd(rng, m, 0.2, 1.0);
  model.sensors.push_back({"y", 0, m});
  model.x0 = Eigen::VectorXd::Zero(n);
  model.P0 = Eigen::MatrixXd::Identity(n, n);
  Uncertainty u;
  u.dA = randomMatrix(rng, n, n, 0.1 / std::sqrt(static_cast<double>(n)));
  u.dB = randomMatrix(rng, n, nw, 0.05);
  u.dC = randomMatrix(rng, m, n, 0.1);
  u.range = 0.5;
  model.uncertainty.push_back(u);
  model.Bu = randomMatrix(rng, n, 1);
  if (angle)
  {
    model.name += "_angle";
    model.A.col(0) = Eigen::VectorXd::Unit(n, 0);
    model.C.col(0).setZero();
    model.C.row(0) = Eigen::RowVectorXd::Unit(n, 0);
    model.uncertainty[0].dA.col(0).setZero();
    model.uncertainty[0].dC.col(0).setZero();
    model.angles = {0};
  }
  validateModel(model, model.name);
  return model;
}

/// A ring of samples (y, u) simulated from the nominal plant, u ~ N(0, 1) (non-zero).
/// arrival: gamma = 1 with every y; otherwise gamma = 0 and y empty.
std::vector<Sample> sampleRing(const Model& model, bool arrival)
{
  Rng rng(deriveSeed(77, static_cast<std::uint64_t>(model.n())));
  const Eigen::LLT<Eigen::MatrixXd> lq(model.Q);
  const Eigen::LLT<Eigen::MatrixXd> lr(model.R);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.n());
  Eigen::VectorXd w(model.nw()), v(model.m());
  std::vector<Sample> ring(kRingSize);
  for (Sample& s : ring)
  {
    s.u.resize(1);
    s.u[0] = rng.normal();
    for (int i = 0; i < w.size(); ++i)
    {
      w[i] = rng.normal();
    }
    for (int i = 0; i < v.size(); ++i)
    {
      v[i] = rng.normal();
    }
    x = model.A * x + model.Bu * s.u + model.B * (lq.matrixL() * w);
    for (const int a : model.angles)
    {
      x[a] = wrapAngle(x[a]);
    }
    s.gamma = arrival;
    if (arrival)
    {
      s.y = model.C * x + lr.matrixL() * v;
      for (const int a : model.angles)
      {
        s.y[a] = wrapAngle(s.y[a]);  // row a measures state a (benchModel)
      }
    }
  }
  return ring;
}

// ---------------------------------------------------------------------------------------------
// Baselines
// ---------------------------------------------------------------------------------------------

/// The textbook Kalman filter, dynamic-size, preallocated workspace (no allocation per step).
class DynamicKalman
{
public:
  explicit DynamicKalman(const Model& model)
    : A_(model.A), C_(model.C), R_(model.R), Bu_(model.Bu), x_(model.x0), P_(model.P0)
  {
    const Eigen::MatrixXd bqb = model.B * model.Q * model.B.transpose();
    Q_ = 0.5 * (bqb + bqb.transpose());
    const int n = model.n();
    const int m = model.m();
    xp_.resize(n);
    e_.resize(m);
    Pp_.resize(n, n);
    AP_.resize(n, n);
    IKC_.resize(n, n);
    Pn_.resize(n, n);
    CP_.resize(m, n);
    Kt_.resize(m, n);
    S_.resize(m, m);
  }

  void step(const Sample& s)
  {
    // xp = A x + Bu u
    xp_.noalias() = A_ * x_;
    xp_.noalias() += Bu_ * s.u;
    // Pp = A P A' + Q
    AP_.noalias() = A_ * P_;
    Pp_ = Q_;
    Pp_.noalias() += AP_ * A_.transpose();
    // S = C Pp C' + R
    CP_.noalias() = C_ * Pp_;
    S_ = R_;
    S_.noalias() += CP_ * C_.transpose();
    // K = Pp C' S^{-1}, held as K' = S^{-1} C Pp
    llt_.compute(S_);
    Kt_ = llt_.solve(CP_);
    // x = xp + K (y - C xp)
    e_ = s.y;
    e_.noalias() -= C_ * xp_;
    x_ = xp_;
    x_.noalias() += Kt_.transpose() * e_;
    // P = (I - K C) Pp, symmetrised
    IKC_.setIdentity();
    IKC_.noalias() -= Kt_.transpose() * C_;
    Pn_.noalias() = IKC_ * Pp_;
    P_ = 0.5 * (Pn_ + Pn_.transpose());
  }

  const Eigen::VectorXd& state() const { return x_; }
  const Eigen::MatrixXd& covariance() const { return P_; }

private:
  Eigen::MatrixXd A_, C_, R_, Bu_, Q_;
  Eigen::VectorXd x_, xp_, e_;
  Eigen::MatrixXd P_, Pp_, AP_, IKC_, Pn_, CP_, Kt_, S_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

/// The same filter with fixed-size Eigen types.
template <int N>
class FixedKalman
{
public:
  static constexpr int M = measurementCount(N);
  using MatN = Eigen::Matrix<double, N, N>;
  using MatMN = Eigen::Matrix<double, M, N>;
  using MatM = Eigen::Matrix<double, M, M>;
  using VecN = Eigen::Matrix<double, N, 1>;
  using VecM = Eigen::Matrix<double, M, 1>;

  explicit FixedKalman(const Model& model)
    : A_(model.A), C_(model.C), R_(model.R), bu_(model.Bu.col(0)), x_(model.x0), P_(model.P0)
  {
    const Eigen::MatrixXd bqb = model.B * model.Q * model.B.transpose();
    Q_ = 0.5 * (bqb + bqb.transpose());
  }

  void step(const VecM& y, double u)
  {
    const VecN xp = A_ * x_ + bu_ * u;
    const MatN Pp = A_ * P_ * A_.transpose() + Q_;
    const MatMN CP = C_ * Pp;
    const MatM S = CP * C_.transpose() + R_;
    const Eigen::LLT<MatM> llt(S);
    const MatMN Kt = llt.solve(CP);
    x_ = xp + Kt.transpose() * (y - C_ * xp);
    const MatN Pn = (MatN::Identity() - Kt.transpose() * C_) * Pp;
    P_ = 0.5 * (Pn + Pn.transpose());
  }

  const VecN& state() const { return x_; }

private:
  MatN A_;
  MatMN C_;
  MatM R_;
  VecN bu_;
  MatN Q_;
  VecN x_;
  MatN P_;
};

// ---------------------------------------------------------------------------------------------
// Benchmarks
// ---------------------------------------------------------------------------------------------

int sizeArg(const benchmark::State& state)
{
  return static_cast<int>(state.range(0));
}

void benchBaseline(benchmark::State& state)
{
  const Model model = benchModel(sizeArg(state));
  const std::vector<Sample> ring = sampleRing(model, true);
  DynamicKalman kf(model);
  std::size_t i = 0;
  for (auto _ : state)
  {
    kf.step(ring[i & (kRingSize - 1)]);
    ++i;
  }
  benchmark::DoNotOptimize(kf.state().data());
  if (!kf.covariance().allFinite())
  {
    state.SkipWithError("baseline covariance not finite");
  }
}

template <int N>
void benchFixed(benchmark::State& state)
{
  using Filter = FixedKalman<N>;
  const Model model = benchModel(N);
  const std::vector<Sample> ring = sampleRing(model, true);
  std::vector<typename Filter::VecM, Eigen::aligned_allocator<typename Filter::VecM>> ys(kRingSize);
  std::vector<double> us(kRingSize);
  for (int k = 0; k < kRingSize; ++k)
  {
    ys[k] = ring[k].y;
    us[k] = ring[k].u[0];
  }
  auto kf = std::make_unique<Filter>(model);
  std::size_t i = 0;
  for (auto _ : state)
  {
    const std::size_t k = i & (kRingSize - 1);
    kf->step(ys[k], us[k]);
    ++i;
  }
  benchmark::DoNotOptimize(kf->state().data());
  if (!kf->state().allFinite())
  {
    state.SkipWithError("fixed-size state not finite");
  }
}

struct EstimatorCase
{
  Algorithm algorithm;
  bool arrival;
  detail::SizeChoice form = detail::SizeChoice::AUTOMATIC;  ///< DYNAMIC: the general form at any size
  bool angle = false;  ///< state 0 an angle (benchModel)
};

void benchEstimator(benchmark::State& state, EstimatorCase c)
{
  const Model model = benchModel(sizeArg(state), c.angle);
  const std::vector<Sample> ring = sampleRing(model, c.arrival);
  EstimatorSettings settings;
  settings.algorithm = c.algorithm;
  settings.mu = 0.8;
  settings.has_control_link = true;
  settings.recovery = 0.6;
  settings.failure = 0.2;
  settings.max_components = kOeComponents;
  std::unique_ptr<Estimator> est;
  try
  {
    est = detail::makeEstimator(model, settings, c.form);
    // warm up: oe reaches its component cap, caches and workspaces are sized
    for (int k = 0; k < 2 * kRingSize; ++k)
    {
      est->step(ring[k & (kRingSize - 1)]);
    }
  }
  catch (const std::exception& e)
  {
    state.SkipWithError(e.what());
    return;
  }
  std::size_t i = 0;
  try
  {
    for (auto _ : state)
    {
      est->step(ring[i & (kRingSize - 1)]);
      ++i;
    }
  }
  catch (const std::exception& e)
  {
    state.SkipWithError(e.what());
    return;
  }
  benchmark::DoNotOptimize(est->state().data());
  state.SetLabel(est->implementation());
  const double comps = static_cast<double>(est->components());
  state.counters["components"] = comps;
  if (c.algorithm == Algorithm::OE)
  {
    // seconds per step and component (printed with an SI prefix, e.g. 12.3n = 12.3 ns)
    state.counters["per_component"] =
        benchmark::Counter(comps, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  }
}

double statMin(const std::vector<double>& v)
{
  return v.empty() ? 0.0 : *std::min_element(v.begin(), v.end());
}

/// --iterations=N: every benchmark runs exactly N iterations (0: Google Benchmark decides).
long g_iterations = 0;

void configure(benchmark::internal::Benchmark* b, const std::vector<int>& sizes)
{
  b->ArgName("n")->Unit(benchmark::kNanosecond)->ComputeStatistics("min", statMin);
  if (g_iterations > 0)
  {
    b->Iterations(g_iterations);
  }
  for (int n : sizes)
  {
    b->Arg(n);
  }
}

void registerBenchmarks()
{
  configure(benchmark::RegisterBenchmark("baseline_kf", benchBaseline), kSizes);
  configure(benchmark::RegisterBenchmark("fixed_kf", benchFixed<2>), {2});
  configure(benchmark::RegisterBenchmark("fixed_kf", benchFixed<4>), {4});
  configure(benchmark::RegisterBenchmark("fixed_kf", benchFixed<8>), {8});
  const std::vector<std::pair<const char*, EstimatorCase>> cases = {
    {"kf", {Algorithm::KF, true}},
    {"kfio", {Algorithm::KFIO, true}},
    {"kfio_drop", {Algorithm::KFIO, false}},
    {"rseio_arrival", {Algorithm::RSEIO, true}},
    {"rseio_drop", {Algorithm::RSEIO, false}},
    {"aoe", {Algorithm::AOE, true}},
    {"oe", {Algorithm::OE, true}},
  };
  for (const auto& c : cases)
  {
    configure(benchmark::RegisterBenchmark(c.first, benchEstimator, c.second), kSizes);
  }
  // the dynamic form where makeEstimator picks the fixed-size one
  const std::vector<std::pair<const char*, EstimatorCase>> dynamic_cases = {
    {"kf_dynamic", {Algorithm::KF, true, detail::SizeChoice::DYNAMIC}},
    {"kfio_dynamic", {Algorithm::KFIO, true, detail::SizeChoice::DYNAMIC}},
    {"rseio_arrival_dynamic", {Algorithm::RSEIO, true, detail::SizeChoice::DYNAMIC}},
    {"aoe_dynamic", {Algorithm::AOE, true, detail::SizeChoice::DYNAMIC}},
  };
  for (const auto& c : dynamic_cases)
  {
    configure(benchmark::RegisterBenchmark(c.first, benchEstimator, c.second), {2, 4});
  }
  // with an angular state (wrapped innovation and state): the cost of the wrap next to kfio
  configure(benchmark::RegisterBenchmark(
                "kfio_angle", benchEstimator,
                EstimatorCase{Algorithm::KFIO, true, detail::SizeChoice::AUTOMATIC, true}),
            {2, 4, 8});
}

// ---------------------------------------------------------------------------------------------
// Reporting
// ---------------------------------------------------------------------------------------------

struct Timing
{
  std::vector<double> reps;  ///< ns per step, one per repetition
  double agg_median = -1.0;  ///< from the aggregates (used when the repetitions were not reported)
  double agg_min = -1.0;
  double components = 1.0;
  std::string error;
};

using Key = std::pair<std::string, int>;  // (benchmark name, n)

int parseSize(const std::string& args)
{
  const std::size_t colon = args.rfind(':');
  return std::atoi(args.c_str() + (colon == std::string::npos ? 0 : colon + 1));
}

/// The console reporter, showing only the median and min aggregates when there are repetitions,
/// and collecting every run's real time per step for the summary.
class CollectingReporter : public benchmark::ConsoleReporter
{
public:
  explicit CollectingReporter(bool cpu_time)
    : benchmark::ConsoleReporter(benchmark::ConsoleReporter::OO_Tabular), cpu_time_(cpu_time)
  {
  }

  void ReportRuns(const std::vector<Run>& runs) override
  {
    std::vector<Run> shown;
    for (const Run& r : runs)
    {
      const Key key(r.run_name.function_name, parseSize(r.run_name.args));
      Timing& t = timings_[key];
      const auto comps = r.counters.find("components");
      if (comps != r.counters.end())
      {
        t.components = comps->second.value;
      }
      if (r.error_occurred)
      {
        t.error = r.error_message;
        shown.push_back(r);
        continue;
      }
      if (r.run_type == Run::RT_Iteration)
      {
        t.reps.push_back(timeOf(r));
        if (r.repetitions <= 1)
        {
          shown.push_back(r);
        }
      }
      else if (r.aggregate_name == "median" || r.aggregate_name == "min")
      {
        (r.aggregate_name == "median" ? t.agg_median : t.agg_min) = timeOf(r);
        shown.push_back(r);
      }
    }
    if (!shown.empty())
    {
      benchmark::ConsoleReporter::ReportRuns(shown);
    }
  }

  const std::map<Key, Timing>& timings() const { return timings_; }
  bool cpuTime() const { return cpu_time_; }

private:
  double timeOf(const Run& r) const { return cpu_time_ ? r.GetAdjustedCPUTime() : r.GetAdjustedRealTime(); }

  bool cpu_time_;
  std::map<Key, Timing> timings_;
};

struct Stat
{
  bool ok = false;
  double median = 0.0;
  double min = 0.0;
};

Stat summarise(const Timing& t, double divisor)
{
  Stat s;
  if (!t.error.empty())
  {
    return s;
  }
  if (!t.reps.empty())
  {
    std::vector<double> v = t.reps;
    std::sort(v.begin(), v.end());
    const std::size_t k = v.size();
    s.median = k % 2 == 1 ? v[k / 2] : 0.5 * (v[k / 2 - 1] + v[k / 2]);
    s.min = v.front();
    s.ok = true;
  }
  else if (t.agg_median >= 0.0)
  {
    s.median = t.agg_median;
    s.min = t.agg_min >= 0.0 ? t.agg_min : t.agg_median;
    s.ok = true;
  }
  s.median /= divisor;
  s.min /= divisor;
  return s;
}

struct Row
{
  std::string label;   ///< printed name
  std::string bench;   ///< benchmark name it is computed from
  bool per_component;  ///< divide by the number of components held
  double target;       ///< ratio target for the sizes of the table (0: none)
};

/// A summary table: the rows, the benchmark the ratios refer to, and the sizes the targets apply to.
struct Table
{
  std::vector<Row> rows;
  std::string reference;        ///< benchmark name of the denominator
  bool (*targeted)(int n);      ///< whether the targets apply at n
  const char* targeted_text;    ///< e.g. "n >= 4"
};

std::string formatCell(const Stat& s, const Stat& base, bool use_min, double target, bool targeted)
{
  if (!s.ok)
  {
    return "-";
  }
  const double value = use_min ? s.min : s.median;
  char buf[96];
  if (!base.ok)
  {
    std::snprintf(buf, sizeof(buf), "%.1f", value);
    return buf;
  }
  const double ratio = value / (use_min ? base.min : base.median);
  const char* verdict = "";
  if (target > 0.0 && targeted)
  {
    verdict = ratio <= target ? " PASS" : " MISS";
  }
  std::snprintf(buf, sizeof(buf), "%.1f (%.2fx)%s", value, ratio, verdict);
  return buf;
}

void printTable(const std::map<Key, Timing>& timings, const Table& table, const std::vector<int>& sizes, bool use_min)
{
  const int label_width = 18;
  const int cell_width = 24;
  std::printf("\n%s ns per step (ratio to %s at the same n, %s/%s)\n", use_min ? "Minimum" : "Median",
              table.reference.c_str(), use_min ? "min" : "median", use_min ? "min" : "median");
  std::printf("%-*s", label_width, "algorithm");
  for (int n : sizes)
  {
    std::printf(" | %-*s", cell_width, ("n = " + std::to_string(n)).c_str());
  }
  std::printf(" | target (%s)\n", table.targeted_text);
  std::printf("%s\n", std::string(label_width + sizes.size() * (cell_width + 3) + 19, '-').c_str());
  for (const Row& row : table.rows)
  {
    bool any = false;
    std::string line;
    char buf[128];
    std::snprintf(buf, sizeof(buf), "%-*s", label_width, row.label.c_str());
    line += buf;
    for (int n : sizes)
    {
      const auto it = timings.find(Key(row.bench, n));
      const auto base_it = timings.find(Key(table.reference, n));
      std::string cell = "-";
      if (it != timings.end())
      {
        any = true;
        if (!it->second.error.empty())
        {
          cell = "error";
        }
        else
        {
          const Stat s = summarise(it->second, row.per_component ? std::max(1.0, it->second.components) : 1.0);
          const Stat base = base_it != timings.end() ? summarise(base_it->second, 1.0) : Stat();
          cell = formatCell(s, base, use_min, row.target, table.targeted(n));
        }
      }
      std::snprintf(buf, sizeof(buf), " | %-*s", cell_width, cell.c_str());
      line += buf;
    }
    if (!any)
    {
      continue;
    }
    if (row.target > 0.0)
    {
      std::snprintf(buf, sizeof(buf), " | <= %.1fx", row.target);
      line += buf;
    }
    else
    {
      line += " |";
    }
    std::printf("%s\n", line.c_str());
  }
}

void printSummary(const std::map<Key, Timing>& timings, bool cpu_time)
{
  Table dynamic_table;
  dynamic_table.reference = "baseline_kf";
  dynamic_table.targeted = [](int n) { return n >= 4; };
  dynamic_table.targeted_text = "n >= 4";
  dynamic_table.rows = {
    {"baseline_kf", "baseline_kf", false, 0.0},
    {"fixed_kf", "fixed_kf", false, 0.0},
    {"kf", "kf", false, 0.0},
    {"kfio", "kfio", false, 1.2},
    {"kfio_drop", "kfio_drop", false, 0.0},
    {"rseio_arrival", "rseio_arrival", false, 3.0},
    {"rseio_drop", "rseio_drop", false, 0.0},
    {"aoe", "aoe", false, 2.5},
    {"oe (per step)", "oe", false, 0.0},
    {"oe per component", "oe", true, 1.5},
  };
  // the fixed-size forms against the hand-written fixed-size filter (which exists for n = 2, 4, 8)
  Table fixed_table;
  fixed_table.reference = "fixed_kf";
  fixed_table.targeted = [](int n) { return n == 2 || n == 4; };
  fixed_table.targeted_text = "n = 2, 4";
  fixed_table.rows = {
    {"fixed_kf", "fixed_kf", false, 0.0},
    {"kf", "kf", false, 0.0},
    {"kf_dynamic", "kf_dynamic", false, 0.0},
    {"kfio", "kfio", false, 1.3},
    {"kfio_dynamic", "kfio_dynamic", false, 0.0},
    {"rseio_arrival", "rseio_arrival", false, 3.0},
    {"rseio_arrival_dyn", "rseio_arrival_dynamic", false, 0.0},
    {"aoe", "aoe", false, 2.0},
    {"aoe_dynamic", "aoe_dynamic", false, 0.0},
  };
  std::vector<int> sizes;
  std::size_t reps = 0;
  for (const auto& kv : timings)
  {
    if (std::find(sizes.begin(), sizes.end(), kv.first.second) == sizes.end())
    {
      sizes.push_back(kv.first.second);
    }
    reps = std::max(reps, kv.second.reps.size());
  }
  std::sort(sizes.begin(), sizes.end());
  std::printf("\n==== Summary: one estimator step, m = n/2 (1 for n = 2), nw = n, p = 1, n_e = 1 ====\n");
  std::printf("%zu repetition(s) per benchmark, %s time per step. Baseline: hand-written dynamic-size Eigen "
              "Kalman filter.\n",
              reps, cpu_time ? "CPU" : "real");
  const auto oe = std::find_if(timings.begin(), timings.end(), [](const auto& kv) { return kv.first.first == "oe"; });
  if (oe != timings.end())
  {
    std::printf("oe holds %.0f components in steady state (max_components = %zu).\n", oe->second.components,
                kOeComponents);
  }
  printTable(timings, dynamic_table, sizes, false);
  printTable(timings, dynamic_table, sizes, true);
  std::vector<int> fixed_sizes;
  for (int n : sizes)
  {
    if (timings.count(Key("fixed_kf", n)) != 0)
    {
      fixed_sizes.push_back(n);
    }
  }
  if (!fixed_sizes.empty())
  {
    std::printf("\nEstimators in their fixed-size form at n = 2, 4 (dynamic at n = 8) against the hand-written "
                "fixed-size Kalman filter:\n");
    printTable(timings, fixed_table, fixed_sizes, false);
    printTable(timings, fixed_table, fixed_sizes, true);
  }
  std::printf("\nPASS/MISS compares the ratio with the target; timing is informative only (exit code 0).\n");
}

}  // namespace
}  // namespace networked_estimation

int main(int argc, char** argv)
{
  using networked_estimation::CollectingReporter;
  std::vector<std::string> args;
  args.emplace_back(argv[0]);
  bool quick = false;
  bool cpu_time = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    quick = quick || a == "--quick";
    cpu_time = cpu_time || a == "--cpu-time";
    if (a.rfind("--iterations=", 0) == 0)
    {
      networked_estimation::g_iterations = std::atol(a.c_str() + 13);
    }
  }
  // defaults first, so that flags given on the command line override them
  if (quick)
  {
    args.emplace_back("--benchmark_min_time=0.01");
    args.emplace_back("--benchmark_repetitions=1");
  }
  else
  {
    args.emplace_back("--benchmark_repetitions=5");
    args.emplace_back("--benchmark_enable_random_interleaving=true");
  }
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (a != "--quick" && a != "--cpu-time" && a.rfind("--iterations=", 0) != 0)
    {
      args.emplace_back(argv[i]);
    }
  }
  std::vector<char*> cargs;
  for (std::string& a : args)
  {
    cargs.push_back(&a[0]);
  }
  cargs.push_back(nullptr);
  int cargc = static_cast<int>(args.size());

  networked_estimation::registerBenchmarks();
  benchmark::Initialize(&cargc, cargs.data());
  if (benchmark::ReportUnrecognizedArguments(cargc, cargs.data()))
  {
    return 1;
  }
  CollectingReporter reporter(cpu_time);
  benchmark::RunSpecifiedBenchmarks(&reporter);
  if (!reporter.timings().empty())
  {
    networked_estimation::printSummary(reporter.timings(), reporter.cpuTime());
  }
  return 0;
}
