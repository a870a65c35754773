// The covariance-only Monte Carlo (montecarlo --covariance-only, the experiment covariance): the
// estimators' covariance-only mode against their ordinary step, the experiment against the
// state-simulating runs (the same arrivals exactly, and E[tr P_k] = E|x_k - xhat_k|^2 for kfio),
// horizons past the rounding floor, and the refusals.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "test_support.hpp"

using namespace networked_estimation;

namespace
{

/// Input files in a scratch folder, removed on destruction.
class Files
{
public:
  Files()
  {
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    dir_ = std::filesystem::temp_directory_path() / ("test_covariance_only_" + std::to_string(stamp));
    std::filesystem::create_directories(dir_);
  }
  ~Files()
  {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::string write(const std::string& name, const std::string& text) const
  {
    std::ofstream out(dir_ / name);
    out << text;
    return (dir_ / name).string();
  }

private:
  std::filesystem::path dir_;
};

/// config/models/scheduled_example.yaml: an unstable plant, two sensors of two rows, a periodic
/// schedule.
const char* const kScheduled =
    "name: scheduled_example\nperiod: 0.1\nA: [[1.2, 1, 0], [0, 1.2, 0], [0, 0, 1.1]]\n"
    "Q: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nsensors:\n"
    "  - {name: s1, C: [[2, 1, 0], [0, 1, 0]], R: [[1, 0], [0, 1]]}\n"
    "  - {name: s2, C: [[0, 0, 1], [0, 0, 2]], R: [[1, 0], [0, 1]]}\n"
    "x0: [0, 0, 0]\nP0: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nschedule:\n  pattern: [[s1], [s2], [s1, s2]]\n";
/// Two sensors without a schedule, four states (the size of the speed benchmark).
const char* const kFourStates =
    "name: four_states\nperiod: 0.1\n"
    "A: [[1.05, 0.1, 0, 0], [0, 0.95, 0.1, 0], [0, 0, 1.02, 0.1], [0, 0, 0, 0.9]]\n"
    "Q: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\nsensors:\n"
    "  - {name: a, C: [[1, 0, 0, 0], [0, 0, 1, 0]], R: [[0.5, 0], [0, 0.5]]}\n"
    "  - {name: b, C: [[0, 1, 0, 1]], R: [[2.0]]}\n"
    "x0: [0, 0, 0, 0]\nP0: [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]\n";
const char* const kBernoulli = "model: bernoulli\nloss: 0.3\nseed: 4\n";
const char* const kGilbert = "model: gilbert_elliott\np: 0.2\nr: 0.5\nloss_bad: 1.0\nloss_good: 0.05\nseed: 2\n";

MonteCarloConfig customConfig(const std::string& experiment, const std::string& model,
                              const std::vector<std::string>& channels, const std::vector<std::string>& settings,
                              long runs, long steps)
{
  MonteCarloConfig c;
  c.experiment = experiment;
  c.model_path = model;
  c.channel_args = channels;
  c.settings_paths = settings;
  c.runs = runs;
  c.steps = steps;
  c.threads = 2;
  c.seed = 11;
  return c;
}

const SeriesResult& series(const ExperimentResult& r, const std::string& name)
{
  for (const SeriesResult& s : r.cases.at(0).series)
    if (s.name == name)
      return s;
  throw std::runtime_error("no series " + name);
}

}  // namespace

// The mode computes P by the ordinary step's code: the same P bit for bit whatever the data, and no
// state. Random models of several sizes (fixed and dynamic forms), random arrival patterns.
TEST(CovarianceOnly, EstimatorModeGivesTheOrdinaryCovariance)
{
  Rng rng(5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int n : {1, 2, 4, 7})
  {
    Model model = test::randomModel(rng, n, n, {1, 2}, 1, 1);
    model.A *= 1.6;  // unstable enough that P grows during gaps
    for (Algorithm a : {Algorithm::KF, Algorithm::KFIO, Algorithm::ACK_KF, Algorithm::RSEIO})
    {
      EstimatorSettings s;
      s.algorithm = a;
      s.mu = 0.8;
      auto ordinary = makeEstimator(model, s);
      auto only = makeEstimator(model, s);
      ASSERT_TRUE(only->setCovarianceOnly(true)) << toString(a);
      for (int k = 0; k < 60; ++k)
      {
        Sample data, pattern;
        data.gamma = rng.uniform() < 0.6;
        data.y = test::randomMatrix(rng, model.m(), 1, 5.0);
        data.u = test::randomMatrix(rng, model.p(), 1, 2.0);
        data.nu = rng.uniform() < 0.5 ? 1 : 0;
        if (rng.uniform() < 0.3)
          data.y.segment(model.sensors[0].offset, model.sensors[0].size).setConstant(nan);
        pattern.gamma = data.gamma;
        pattern.y = Eigen::VectorXd::Zero(model.m());
        for (int i = 0; i < model.m(); ++i)
          if (std::isnan(data.y[i]))
            pattern.y[i] = nan;
        ordinary->step(data);
        only->step(pattern);
        ASSERT_TRUE(ordinary->covariance() == only->covariance()) << toString(a) << " n = " << n << " k = " << k << "\n"
                                                                  << ordinary->covariance() << "\n\n"
                                                                  << only->covariance();
      }
      EXPECT_TRUE(only->state() == model.x0) << toString(a);
      EXPECT_FALSE(ordinary->state() == model.x0) << toString(a);
      // reset keeps the mode; switching it off restores the ordinary step
      only->reset();
      EXPECT_TRUE(only->setCovarianceOnly(false));
      Sample y1;
      y1.y = Eigen::VectorXd::Ones(model.m());
      only->step(y1);
      EXPECT_FALSE(only->state() == model.x0) << toString(a);
    }
  }
  // the estimators whose P depends on the data have no such mode
  const Model model = test::aoeModel();
  for (Algorithm a : {Algorithm::AOE, Algorithm::OE, Algorithm::EKFIO})
  {
    EstimatorSettings s;
    s.algorithm = a;
    s.has_control_link = true;
    auto e = makeEstimator(model, s);
    EXPECT_FALSE(e->setCovarianceOnly(true)) << toString(a);
    EXPECT_TRUE(e->setCovarianceOnly(false)) << toString(a);
  }
}

// Run r of the experiment meets exactly the losses (per-sensor Bernoulli and Gilbert-Elliott links,
// a periodic schedule) of `simulate --seed S+r`: its E[tr P_k] is the mean over the same runs of
// the tr P_k of kfio and rseio stepping LossyRun's output, bit for bit (the same engine reduces the
// same values).
TEST(CovarianceOnly, SameArrivalsAsTheStateSimulatingRuns)
{
  Files f;
  const std::string model_path = f.write("scheduled.yaml", kScheduled);
  const std::vector<std::string> channels = {"s1=" + f.write("b.yaml", kBernoulli),
                                             "s2=" + f.write("ge.yaml", kGilbert)};
  const std::vector<std::string> settings = {f.write("kfio.yaml", "algorithm: kfio\n"),
                                             f.write("rseio.yaml", "algorithm: rseio\nmu: 0.9\n")};
  const long runs = 150, T = 40;
  MonteCarloConfig cfg = customConfig("covariance", model_path, channels, settings, runs, T);
  const ExperimentResult r = runExperiment(cfg);
  EXPECT_EQ(r.experiment, "covariance");
  ASSERT_EQ(r.cases.size(), 1u);
  ASSERT_EQ(r.cases[0].series.size(), 2u);

  // custom --covariance-only is the same experiment
  MonteCarloConfig as_custom = cfg;
  as_custom.experiment = "custom";
  as_custom.covariance_only = true;
  const ExperimentResult r2 = runExperiment(as_custom);
  EXPECT_EQ(r2.experiment, "covariance");
  EXPECT_EQ(experimentCsv(r2), experimentCsv(r));

  const Model model = loadModel(model_path);
  LossyRunOptions options;
  options.sensor_links = resolveSensorLinks(model, channels).link;
  std::vector<EstimatorSettings> es = {loadEstimatorSettings(settings[0]), loadEstimatorSettings(settings[1])};
  WorkerFactory simulated = [&]() -> RunFunction
  {
    return [&](long run, double* out)
    {
      LossyRun plant(model, cfg.seed + static_cast<std::uint64_t>(run), options);
      auto kfio = makeEstimator(model, es[0]);
      auto rseio = makeEstimator(model, es[1]);
      for (long k = 1; k <= T; ++k)
      {
        plant.step();
        kfio->step(plant.received());
        rseio->step(plant.received());
        out[k - 1] = kfio->covariance().trace();
        out[T + k - 1] = rseio->covariance().trace();
      }
      out[2 * T] = out[2 * T + 1] = 0.0;
    };
  };
  const Moments m = runMonteCarlo(runs, static_cast<std::size_t>(2 * T + 2), 1, simulated);
  const SeriesResult& kfio = series(r, "kfio");
  const SeriesResult& rseio = series(r, "rseio");
  for (long k = 0; k < T; ++k)
  {
    EXPECT_EQ(kfio.mean[k], m.mean[k]) << "k = " << k + 1;
    EXPECT_EQ(kfio.sd[k], m.sd[k]) << "k = " << k + 1;
    EXPECT_EQ(rseio.mean[k], m.mean[T + k]) << "k = " << k + 1;
  }
  // the arrivals matter: the runs differ, so the sd is not 0
  EXPECT_GT(kfio.sd[T - 1], 0.0);
}

// For kfio on its own model, E|x_k - xhat_k|^2 = E[tr P_k] at every k: the custom experiment's MSE
// (the plant simulated) and the covariance experiment's mean tr P agree within the Monte Carlo error.
// Tolerance: both are means over the same 4000 runs; the SE of each is sd/sqrt(n), and since they are
// positively correlated (common arrivals) the SE of their difference is at most the root sum of
// squares; 4.5 of it makes a false failure at any one of the 50 steps about 7e-6 (normal tails, n =
// 4000 averages of finite-variance values at a stable rate), and the seed is fixed.
TEST(CovarianceOnly, MeanTraceIsTheMeanSquaredErrorOfTheStateSimulation)
{
  Files f;
  const std::string model_path = f.write("four.yaml", kFourStates);
  const std::vector<std::string> channels = {"a=" + f.write("b.yaml", kBernoulli), "b=" + f.write("ge.yaml", kGilbert)};
  const std::vector<std::string> settings = {f.write("kfio.yaml", "algorithm: kfio\n")};
  const long runs = 4000, T = 50;
  const ExperimentResult cov = runExperiment(customConfig("covariance", model_path, channels, settings, runs, T));
  const ExperimentResult mse = runExperiment(customConfig("custom", model_path, channels, settings, runs, T));
  const SeriesResult& a = series(cov, "kfio");
  const SeriesResult& b = series(mse, "kfio");
  const double n = static_cast<double>(runs);
  for (long k = 0; k < T; ++k)
  {
    const double se = std::sqrt(a.sd[k] * a.sd[k] / n + b.sd[k] * b.sd[k] / n);
    EXPECT_NEAR(a.mean[k], b.mean[k], 4.5 * se) << "k = " << k + 1;
  }
  // not trivially: the mean trace moves with k (P0 = I, then the links' stationary level)
  EXPECT_GT(std::abs(a.mean[T - 1] - a.mean[0]), 10 * std::sqrt(a.sd[0] * a.sd[0] / n));
}

// An unstable plant over a long horizon: the state simulation stops at the rounding floor, the
// covariance recursion does not (no plant), and an outage long enough to overflow P shows as
// tr P = inf from then on, counted in the notes.
TEST(CovarianceOnly, PastTheRoundingFloor)
{
  Files f;
  const std::string model_path = f.write("scalar.yaml", "name: scalar\nA: [[1.5]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\n");
  const std::vector<std::string> channels = {f.write("b.yaml", "model: bernoulli\nloss: 0.3\n")};
  const std::vector<std::string> settings = {f.write("kfio.yaml", "algorithm: kfio\n")};
  EXPECT_THROW(runExperiment(customConfig("custom", model_path, channels, settings, 64, 3000)), DivergenceError);
  const ExperimentResult r = runExperiment(customConfig("covariance", model_path, channels, settings, 64, 3000));
  const SeriesResult& s = series(r, "kfio");
  ASSERT_EQ(s.mean.size(), 3000u);
  // lambda = 0.7 > 1 - 1/1.5^2 = 0.556: bounded in the mean; no outage of ~875 steps in 64 x 3000
  for (double v : s.mean)
    ASSERT_TRUE(std::isfinite(v) && v > 0.0);
  EXPECT_EQ(r.notes.size(), 1u);

  // no arrival at all: P = 1.5^(2k) overflows near k = 875 in every run
  const std::vector<std::string> never = {f.write("never.yaml", "model: bernoulli\nloss: 1.0\n")};
  const ExperimentResult lost = runExperiment(customConfig("covariance", model_path, never, settings, 10, 1000));
  const SeriesResult& l = series(lost, "kfio");
  EXPECT_TRUE(std::isfinite(l.mean[800]));
  EXPECT_NEAR(std::log(l.mean[799]) - std::log(l.mean[798]), 2 * std::log(1.5), 1e-9);
  EXPECT_EQ(l.mean[999], std::numeric_limits<double>::infinity());
  ASSERT_EQ(lost.notes.size(), 2u);
  EXPECT_NE(lost.notes[1].find("kfio: 10 of 10 runs"), std::string::npos) << lost.notes[1];
}

TEST(CovarianceOnly, Refusals)
{
  Files f;
  const std::string model_path = f.write("four.yaml", kFourStates);
  const std::string aoe = f.write("aoe.yaml", "algorithm: aoe\n");
  try
  {
    runExperiment(customConfig("covariance", model_path, {}, {aoe}, 10, 10));
    ADD_FAILURE() << "no error";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("estimator 'aoe' (aoe)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("kf, kfio, ack_kf, rseio"), std::string::npos) << e.what();
  }
  MonteCarloConfig zhou;
  zhou.experiment = "zhou_fig1";
  zhou.covariance_only = true;
  try
  {
    runExperiment(zhou);
    ADD_FAILURE() << "no error";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("--covariance-only is for the experiments custom, covariance and sweep"),
              std::string::npos)
        << e.what();
  }
}
