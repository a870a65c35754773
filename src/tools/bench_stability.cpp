// Micro-benchmark of the stability analysis (Google Benchmark): what `analyze` and the live
// `link stability` diagnostic cost.
//
//   analyze_links/n/S       analyzeStability with one link per sensor (even sensors i.i.d. with
//                           arrival rates 0.6..0.95, odd sensors on/off Gilbert-Elliott chains),
//                           per-sensor verdicts and margins included: the work of
//                           `analyze --model M --channel s1=A.yaml --channel s2=B.yaml ...`
//   analyze_common/n/S      the same with one i.i.d. channel for every sensor
//   analyze_scale/n/S/U     analyze_links at scale: n = 15 ... 200, a stable (U = 0: rho(A) = 0.99)
//                           or unstable (U = 1: three unstable modes) A
//   verdict_only/n/S/U      verdictOnly, the verdict and each sensor's needed rate (analyze
//                           --verdict-only, Python verdict())
//   live_evaluate/n/S/M/C   LiveStability::evaluate on a full window (M: i.i.d. 0 or Markov 1;
//                           C: cache off 0, a second with new data, or on 1, a second without):
//                           what the Estimator nodelet spends at most once a second
//   live_second/n/S/M/F     the same after F new steps (cache on: a second of an F Hz stream)
//   live_relinearise/D      a built-in motion's live verdicts rebuilt at a moved estimate (omni_2d
//                           for D = 2, omni_3d for D = 3) and evaluated: what the Estimator spends
//                           at most once a second while the robot moves
//   live_model/NAME/MODE    from scratch, on each model given with --model FILE; live_model_second
//                           after 50 new steps
//
// Models: random, reproducible (fixed seed): A = V diag(eigenvalues) V^-1 with three unstable real
// modes (1.05..1.4), the rest stable; sensor j sees a random row (two rows for every third
// sensor); Q = I, R = I. Timing is informative only: the program always exits 0 when it ran.
// Flags: every --benchmark_* flag; --quick = --benchmark_min_time=0.01.
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/omni_model.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/stability/live_stability.hpp"
#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{
namespace
{

/// stable: every eigenvalue inside the unit circle, the largest 0.99; else three unstable real
/// modes (1.05..1.4), the rest stable.
Model randomUnstableModel(int n, int sensors, std::uint64_t seed, bool stable = false)
{
  Rng rng(seed);
  Eigen::MatrixXd V(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      V(i, j) = rng.uniform(-1.0, 1.0);
  V += 2.0 * Eigen::MatrixXd::Identity(n, n);  // well conditioned
  Eigen::VectorXd eig(n);
  for (int i = 0; i < n; ++i)
    eig[i] = stable  ? (i == 0 ? 0.99 : rng.uniform(-0.9, 0.9))
             : i < 3 ? 1.05 + 0.15 * i + 0.05 * rng.uniform()
                     : rng.uniform(-0.9, 0.9);
  Model m;
  m.name = "random_n" + std::to_string(n);
  m.period = 0.1;
  m.A = V * eig.asDiagonal() * V.partialPivLu().inverse();
  m.B = Eigen::MatrixXd::Identity(n, n);
  m.Q = Eigen::MatrixXd::Identity(n, n);
  int rows = 0;
  std::vector<int> sizes;
  for (int j = 0; j < sensors; ++j)
  {
    sizes.push_back(j % 3 == 2 ? 2 : 1);
    rows += sizes.back();
  }
  m.C.resize(rows, n);
  int r0 = 0;
  for (int j = 0; j < sensors; ++j)
  {
    for (int r = 0; r < sizes[j]; ++r)
      for (int c = 0; c < n; ++c)
        m.C(r0 + r, c) = rng.uniform(-1.0, 1.0);
    m.sensors.push_back({"s" + std::to_string(j + 1), r0, sizes[j]});
    r0 += sizes[j];
  }
  m.R = Eigen::MatrixXd::Identity(rows, rows);
  m.x0 = Eigen::VectorXd::Zero(n);
  m.P0 = Eigen::MatrixXd::Identity(n, n);
  m.Bu.resize(n, 0);
  validateModel(m, m.name);
  return m;
}

ChannelSettings iidChannel(double arrival)
{
  ChannelSettings c;
  c.model = LossModelKind::BERNOULLI;
  c.loss = 1.0 - arrival;
  return c;
}

ChannelSettings onOffChannel(double p, double r)
{
  ChannelSettings c;
  c.model = LossModelKind::GILBERT_ELLIOTT;
  c.p = p;
  c.r = r;
  c.loss_bad = 1.0;
  c.loss_good = 0.0;
  return c;
}

/// The links of analyze_links: even sensors i.i.d., odd sensors on/off Gilbert-Elliott.
std::vector<std::optional<ChannelSettings>> mixedLinks(int S)
{
  std::vector<std::optional<ChannelSettings>> links;
  for (int j = 0; j < S; ++j)
    links.push_back(j % 2 == 0 ? iidChannel(0.6 + 0.35 * j / S) : onOffChannel(0.05 + 0.02 * j, 0.5 + 0.05 * j));
  return links;
}

void analyzeLinks(benchmark::State& state)
{
  const int n = static_cast<int>(state.range(0)), S = static_cast<int>(state.range(1));
  const Model m = randomUnstableModel(n, S, 7);
  const std::vector<std::optional<ChannelSettings>> links = mixedLinks(S);
  for (auto _ : state)
  {
    const StabilityReport rep = analyzeStability(m, links);
    benchmark::DoNotOptimize(rep.model.verdict.kind);
  }
}

/// At scale: n states, S sensors, a stable (U = 0) or unstable (U = 1) A; `full` the whole report,
/// else verdictOnly (analyze --verdict-only, Python verdict()): the verdict and each sensor's needed rate.
void atScale(benchmark::State& state, bool full)
{
  const int n = static_cast<int>(state.range(0)), S = static_cast<int>(state.range(1));
  const Model m = randomUnstableModel(n, S, 7, state.range(2) == 0);
  const std::vector<std::optional<ChannelSettings>> links = mixedLinks(S);
  for (auto _ : state)
    benchmark::DoNotOptimize(full ? analyzeStability(m, links).model.verdict.kind : verdictOnly(m, links).verdict.kind);
}

void analyzeCommon(benchmark::State& state)
{
  const int n = static_cast<int>(state.range(0)), S = static_cast<int>(state.range(1));
  const Model m = randomUnstableModel(n, S, 7);
  const ChannelSettings ch = iidChannel(0.8);
  for (auto _ : state)
  {
    const StabilityReport rep = analyzeStability(m, &ch);
    benchmark::DoNotOptimize(rep.model.verdict.kind);
  }
}

/// One evaluation of the live diagnostic on a full window of i.i.d. arrivals (sensor j at
/// 0.7 + 0.1 j / S). cache off: everything from scratch (the first evaluation of a full window);
/// on: nothing new since the last evaluation (a second without input); `fresh` > 0: that many new
/// steps before each evaluation, cache on (a second of a stream at that rate; the steps themselves
/// are not timed).
void liveOn(benchmark::State& state, const Model& m, bool markov, bool cache, int fresh = 0)
{
  const int n = m.n(), S = static_cast<int>(m.sensors.size());
  EstimatorSettings settings;
  settings.algorithm = Algorithm::KFIO;
  LiveStabilityOptions o;
  o.markov = markov;
  o.cache = cache;
  LiveStability live(m, settings, o);
  Rng rng(3);
  const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n);
  const auto step = [&]
  {
    std::vector<bool> arrived(S);
    bool any = false;
    for (int j = 0; j < S; ++j)
    {
      arrived[j] = rng.bernoulli(0.7 + 0.1 * j / S);
      any = any || arrived[j];
    }
    live.add(arrived, any, P, false);
  };
  for (std::size_t k = 0; k < o.window; ++k)
    step();
  live.evaluate();
  for (auto _ : state)
  {
    if (fresh > 0)
    {
      state.PauseTiming();
      for (int k = 0; k < fresh; ++k)
        step();
      state.ResumeTiming();
    }
    const LiveStabilityReport rep = live.evaluate();
    benchmark::DoNotOptimize(rep.values.size());
  }
  state.SetLabel(std::string(markov ? "markov" : "iid") +
                 (fresh > 0 ? ", " + std::to_string(fresh) + " new steps"
                  : cache   ? ", cached"
                            : "") +
                 ": " + m.name);
}

/// A built-in motion's live verdicts along a moving estimate, as the Estimator rebuilds them once a
/// second while the robot moves: the linearisation at a new state (heading and speeds changed),
/// relinearised() on a full window, and its first evaluation. range(0): 2 for omni_2d (odometry vx,
/// vy, vyaw + IMU yaw, vyaw), 3 for omni_3d (odometry vx, vy, vz, vyaw + IMU roll, pitch, yaw and
/// rates).
void liveRelinearise(benchmark::State& state)
{
  OmniSpec spec;
  spec.rate = 50.0;
  spec.process_noise = {0.01};
  if (state.range(0) == 2)
  {
    spec.motion = "omni_2d";
    spec.sensors = {{"odom", {"vx", "vy", "vyaw"}, {0.05}}, {"imu", {"yaw", "vyaw"}, {0.02}}};
  }
  else
  {
    spec.motion = "omni_3d";
    spec.sensors = {{"odom", {"vx", "vy", "vz", "vyaw"}, {0.05}},
                    {"imu", {"roll", "pitch", "yaw", "vroll", "vpitch", "vyaw"}, {0.02}}};
  }
  const Model motion = makeOmniModel(spec);
  EstimatorSettings settings;
  settings.algorithm = Algorithm::EKFIO;
  LiveStabilityOptions o;
  LiveStability live(linearisedModel(motion, motion.x0, motion.period), settings, o);
  Rng rng(3);
  for (std::size_t k = 0; k < o.window; ++k)
    live.add({rng.bernoulli(0.9), rng.bernoulli(0.8)}, true, motion.P0, false);
  Eigen::VectorXd x = motion.x0;
  const int yaw = motion.n() == 8 ? 2 : 5, vx = motion.n() == 8 ? 3 : 6;
  for (auto _ : state)
  {
    x[yaw] += 0.3;  // the robot turned and sped up since the last second
    x[vx] += 0.1;
    const LiveStability local = live.relinearised(linearisedModel(motion, x, motion.period));
    const LiveStabilityReport rep = local.evaluate();
    benchmark::DoNotOptimize(rep.values.size());
  }
  state.SetLabel(spec.motion + ", n = " + std::to_string(motion.n()) + ", 2 sensors");
}

void liveSecond(benchmark::State& state)
{
  const int n = static_cast<int>(state.range(0)), S = static_cast<int>(state.range(1));
  liveOn(state, randomUnstableModel(n, S, 7), state.range(2) != 0, true, static_cast<int>(state.range(3)));
}

void liveEvaluate(benchmark::State& state)
{
  const int n = static_cast<int>(state.range(0)), S = static_cast<int>(state.range(1));
  liveOn(state, randomUnstableModel(n, S, 7), state.range(2) != 0, state.range(3) != 0);
}

}  // namespace
}  // namespace networked_estimation

int main(int argc, char** argv)
{
  using namespace networked_estimation;
  std::vector<std::string> args = {argv[0]};
  for (int i = 1; i < argc; ++i)
    args.emplace_back(std::string(argv[i]) == "--quick" ? "--benchmark_min_time=0.01" : argv[i]);
  std::vector<char*> cargs;
  for (std::string& a : args)
    cargs.push_back(&a[0]);
  cargs.push_back(nullptr);
  int cargc = static_cast<int>(args.size());
  benchmark::RegisterBenchmark("analyze_links", analyzeLinks)
      ->Args({4, 2})
      ->Args({10, 8})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("analyze_scale", [](benchmark::State& st) { atScale(st, true); })
      ->Args({15, 4, 0})
      ->Args({15, 4, 1})
      ->Args({50, 4, 0})
      ->Args({50, 4, 1})
      ->Args({100, 4, 0})
      ->Args({100, 4, 1})
      ->Args({200, 4, 0})
      ->Args({200, 4, 1})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("verdict_only", [](benchmark::State& st) { atScale(st, false); })
      ->Args({2, 1, 1})
      ->Args({4, 2, 1})
      ->Args({6, 3, 1})
      ->Args({6, 3, 0})
      ->Args({15, 4, 1})
      ->Unit(benchmark::kMicrosecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("analyze_common", analyzeCommon)
      ->Args({10, 8})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("live_evaluate", liveEvaluate)
      ->Args({6, 3, 0, 0})
      ->Args({6, 3, 1, 0})
      ->Args({15, 4, 0, 0})
      ->Args({15, 4, 1, 0})
      ->Args({15, 4, 0, 1})
      ->Unit(benchmark::kMicrosecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("live_relinearise", liveRelinearise)
      ->Arg(2)
      ->Arg(3)
      ->Unit(benchmark::kMicrosecond)
      ->UseRealTime();
  benchmark::RegisterBenchmark("live_second", liveSecond)
      ->Args({6, 3, 0, 50})
      ->Args({15, 4, 0, 50})
      ->Args({15, 4, 1, 50})
      ->Args({15, 4, 0, 200})
      ->Unit(benchmark::kMicrosecond)
      ->UseRealTime();
  // --model FILE (repeatable): the live evaluation on that model, i.i.d. and Markov, from scratch,
  // and after a second of a 50 Hz stream.
  static std::vector<Model> models;
  for (int i = 1; i + 1 < cargc; ++i)
    if (std::string(cargs[i]) == "--model")
    {
      try
      {
        models.push_back(loadModel(cargs[i + 1]));
      }
      catch (const std::exception& e)
      {
        std::fprintf(stderr, "bench_stability: %s\n", e.what());
        return 2;
      }
      for (int j = i; j + 2 <= cargc; ++j)
        cargs[j] = cargs[j + 2];
      cargc -= 2;
      --i;
    }
  for (const Model& m : models)
    for (int markov = 0; markov <= 1; ++markov)
    {
      benchmark::RegisterBenchmark(("live_model/" + m.name + (markov ? "/markov" : "/iid")).c_str(),
                                   [&m, markov](benchmark::State& st) { liveOn(st, m, markov != 0, false); })
          ->Unit(benchmark::kMicrosecond)
          ->UseRealTime();
      benchmark::RegisterBenchmark(("live_model_second/" + m.name + (markov ? "/markov" : "/iid")).c_str(),
                                   [&m, markov](benchmark::State& st) { liveOn(st, m, markov != 0, true, 50); })
          ->Unit(benchmark::kMicrosecond)
          ->UseRealTime();
    }
  benchmark::Initialize(&cargc, cargs.data());
  if (benchmark::ReportUnrecognizedArguments(cargc, cargs.data()))
    return 1;
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
