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
// ekfio_omni runs ekfio on the robot motions (n = 8: omni_2d with odometry vx, vy, vyaw and an IMU
// yaw, vyaw, ax, ay, m = 7; n = 15: omni_3d with odometry vx, vy, vz, vyaw and an IMU of the three
// angles, rates and accelerations, m = 13; each sensor lost with probability 0.2) next to
// kfio_omni, kfio on the motion's linearisation at x0: the same n, m and data, target ekfio <= 2x.
// fixed_riccati (n = 2, 4, 8) is the covariance recursion alone, hand-written with fixed-size Eigen
// types, one step in five lost, and kfio_covariance_only the Estimator's covariance-only step
// (setCovarianceOnly) on the same arrivals: the floor of a covariance-only Monte Carlo step
// (montecarlo --experiment covariance) and what the estimator takes for it. online_ekfio and
// online_ekfio_gated (n = 15) time the OnlineEstimator's step (offer every sensor, process) with
// ekfio on the omni_3d motion, without and with rejection thresholds (the gate's prior).
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
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bench_estimators_fixtures.hpp"
#include "bench_estimators_report.hpp"
#include "estimators/estimator_factory.hpp"  // private header: makeEstimator with the choice of form
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/omni_model.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/simulation/simulator.hpp"

namespace networked_estimation
{
namespace
{

using namespace bench;

constexpr std::size_t kOeComponents = 64;
const std::vector<int> kSizes = {2, 4, 8, 20};

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

/// fixed_riccati: FixedKalman's covariance recursion alone (no mean), arrivals as in sampleRing with
/// one step in five lost: the floor of a covariance-only Monte Carlo step at this n (the estimators'
/// own covariance-only step, kfio_covariance_only, adds the Estimator's checks and bookkeeping).
template <int N>
void benchFixedRiccati(benchmark::State& state)
{
  const Model model = benchModel(N);
  auto kf = std::make_unique<FixedKalman<N>>(model);
  std::size_t i = 0;
  for (auto _ : state)
  {
    kf->covarianceStep(i % 5 != 4);
    ++i;
  }
  benchmark::DoNotOptimize(kf->covariance().data());
  if (!kf->covariance().allFinite())
  {
    state.SkipWithError("fixed-size covariance not finite");
  }
}

struct EstimatorCase
{
  Algorithm algorithm;
  bool arrival;
  detail::SizeChoice form = detail::SizeChoice::AUTOMATIC;  ///< DYNAMIC: the general form at any size
  bool angle = false;                                       ///< state 0 an angle (benchModel)
  bool covariance_only = false;  ///< Estimator::setCovarianceOnly: P alone (one step in five lost)
};

void benchEstimator(benchmark::State& state, EstimatorCase c)
{
  const Model model = benchModel(sizeArg(state), c.angle);
  std::vector<Sample> ring = sampleRing(model, c.arrival);
  if (c.covariance_only)
  {
    // what a covariance-only run gives the estimator: y 0 where it arrived, NaN where it was lost
    for (std::size_t k = 0; k < ring.size(); ++k)
    {
      ring[k].gamma = k % 5 != 4;
      ring[k].y = Eigen::VectorXd::Constant(model.m(), ring[k].gamma ? 0.0 : std::numeric_limits<double>::quiet_NaN());
      ring[k].u.resize(0);
    }
  }
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
    if (c.covariance_only && !est->setCovarianceOnly(true))
    {
      state.SkipWithError("no covariance-only mode");
      return;
    }
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

/// The robot of ekfio_omni / kfio_omni: omni_2d (n = 8) or omni_3d (n = 15), driving forward and turning.
Model omniBenchModel(int n)
{
  OmniSpec spec;
  spec.name = "bench_omni_n" + std::to_string(n);
  spec.rate = 50;
  spec.p0 = {0.01};
  if (n == 8)
  {
    spec.motion = "omni_2d";
    spec.process_noise = {1e-4, 1e-4, 1e-4, 0.01, 0.01, 0.01, 0.1, 0.1};
    spec.sensors = {{"odom", {"vx", "vy", "vyaw"}, {0.05}},
                    {"imu", {"yaw", "vyaw", "ax", "ay"}, {0.02, 0.01, 0.1, 0.1}}};
    spec.x0 = {0, 0, 0.5, 1.0, 0, 0.3, 0, 0};
  }
  else
  {
    spec.motion = "omni_3d";
    spec.process_noise = {1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.1, 0.1, 0.1};
    spec.sensors = {{"odom", {"vx", "vy", "vz", "vyaw"}, {0.05}},
                    {"imu",
                     {"roll", "pitch", "yaw", "vroll", "vpitch", "vyaw", "ax", "ay", "az"},
                     {0.02, 0.02, 0.02, 0.01, 0.01, 0.01, 0.1, 0.1, 0.1}}};
    spec.x0 = {0, 0, 0, 0.05, -0.05, 0.5, 1.0, 0, 0, 0, 0, 0.3, 0, 0, 0};
  }
  return makeOmniModel(spec);
}

/// ekfio on the motion (EKFIO) or kfio on its linearisation at x0 (KFIO), on the same simulated data.
void benchOmni(benchmark::State& state, Algorithm algorithm)
{
  const Model omni = omniBenchModel(sizeArg(state));
  const Model model = algorithm == Algorithm::EKFIO ? omni : linearisedModel(omni, omni.x0, omni.period);
  PlantSimulator sim(omni, 17);
  Rng rng(23);
  std::vector<Sample> ring(kRingSize);
  for (Sample& s : ring)
  {
    s.y = sim.step().y;
    for (const Sensor& sn : omni.sensors)
      if (rng.bernoulli(0.2))
        s.y.segment(sn.offset, sn.size).setConstant(std::numeric_limits<double>::quiet_NaN());
    s.gamma = s.y.array().isFinite().any();
  }
  EstimatorSettings settings;
  settings.algorithm = algorithm;
  std::unique_ptr<Estimator> est;
  std::size_t i = 0;
  try
  {
    est = makeEstimator(model, settings);
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
}

/// The OnlineEstimator's cost per step (ekfio on the robot motion): every sensor's sample offered,
/// then process(). `gated`: every sensor has a rejection threshold (1e6: nothing is refused), so
/// that each step also forms the prior the gate tests the innovations on.
void benchOnline(benchmark::State& state, bool gated)
{
  const Model omni = omniBenchModel(sizeArg(state));
  PlantSimulator sim(omni, 17);
  std::vector<Eigen::VectorXd> ys(kRingSize);
  for (Eigen::VectorXd& y : ys)
    y = sim.step().y;
  OnlineOptions options;
  if (gated)
    options.rejection_threshold.assign(omni.sensors.size(), 1e6);
  EstimatorSettings settings;
  settings.algorithm = Algorithm::EKFIO;
  try
  {
    OnlineEstimator online(omni, settings, options);
    online.start(1);
    long k = 1;
    for (auto _ : state)
    {
      const Eigen::VectorXd& y = ys[static_cast<std::size_t>(k) & (kRingSize - 1)];
      for (std::size_t i = 0; i < omni.sensors.size(); ++i)
        online.offerMeasurement(
            {k, i, y.data() + omni.sensors[i].offset, static_cast<std::size_t>(omni.sensors[i].size)});
      online.process();
      ++k;
    }
    benchmark::DoNotOptimize(online.estimator().state().data());
    state.SetLabel(gated ? "rejection thresholds on" : "no thresholds");
  }
  catch (const std::exception& e)
  {
    state.SkipWithError(e.what());
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
  // the covariance recursion alone: the hand-written floor and the estimator's covariance-only step
  configure(benchmark::RegisterBenchmark("fixed_riccati", benchFixedRiccati<2>), {2});
  configure(benchmark::RegisterBenchmark("fixed_riccati", benchFixedRiccati<4>), {4});
  configure(benchmark::RegisterBenchmark("fixed_riccati", benchFixedRiccati<8>), {8});
  configure(
      benchmark::RegisterBenchmark("kfio_covariance_only", benchEstimator,
                                   EstimatorCase{Algorithm::KFIO, true, detail::SizeChoice::AUTOMATIC, false, true}),
      {2, 4, 8});
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
  configure(benchmark::RegisterBenchmark("kfio_angle", benchEstimator,
                                         EstimatorCase{Algorithm::KFIO, true, detail::SizeChoice::AUTOMATIC, true}),
            {2, 4, 8});
  // robot motions: ekfio next to kfio at the same n, m and data
  configure(benchmark::RegisterBenchmark("ekfio_omni", benchOmni, Algorithm::EKFIO), {8, 15});
  configure(benchmark::RegisterBenchmark("kfio_omni", benchOmni, Algorithm::KFIO), {8, 15});
  // the OnlineEstimator's step (offers and process) on the robot motion, with and without the gate
  configure(benchmark::RegisterBenchmark("online_ekfio", benchOnline, false), {15});
  configure(benchmark::RegisterBenchmark("online_ekfio_gated", benchOnline, true), {15});
}

}  // namespace
}  // namespace networked_estimation

int main(int argc, char** argv)
{
  using networked_estimation::bench::CollectingReporter;
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
    networked_estimation::bench::printSummary(reporter.timings(), reporter.cpuTime(),
                                              networked_estimation::kOeComponents);
  }
  return 0;
}
