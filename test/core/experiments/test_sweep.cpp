// Stability maps (sweep.hpp): the grid, the axis errors, the analytic boundary against the closed
// form of config/models/unstable_two_links.yaml, determinism across thread counts and shards, the
// bookkeeping of runs that cannot be counted, and the statistics at stable points.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/experiments/montecarlo_shards.hpp"
#include "networked_estimation/experiments/sweep.hpp"
#include "test_support.hpp"

using namespace networked_estimation;

namespace
{

/// The files of a sweep in a scratch folder, removed on destruction.
class Files
{
public:
  Files()
  {
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    dir_ = std::filesystem::temp_directory_path() / ("test_sweep_" + std::to_string(stamp));
    std::filesystem::create_directories(dir_);
    // config/models/unstable_two_links.yaml
    model = write("unstable_two_links.yaml",
                  "name: unstable_two_links\nperiod: 0.1\nA: [[1.5]]\nQ: [[1.0]]\nsensors:\n"
                  "  - {name: gnss,   C: [[1.0]], R: [[4.0]]}\n  - {name: camera, C: [[1.0]], R: [[0.25]]}\n"
                  "x0: [0]\nP0: [[1]]\n");
    kf = write("kfio.yaml", "algorithm: kfio\n");
    ge = write("ge.yaml", "model: gilbert_elliott\np: 0.3\nr: 0.5\nloss_bad: 1.0\nloss_good: 0.0\nseed: 1\n");
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
  std::string model, kf, ge;

private:
  std::filesystem::path dir_;
};

MonteCarloConfig sweepConfig(const Files& f, std::vector<std::string> axes, long runs, long steps, int threads = 1)
{
  MonteCarloConfig c;
  c.experiment = "sweep";
  c.model_path = f.model;
  c.settings_paths = {f.kf};
  c.axis_args = std::move(axes);
  c.runs = runs;
  c.steps = steps;
  c.threads = threads;
  return c;
}

void expectAxisError(const std::string& arg, const std::string& part)
{
  try
  {
    parseSweepAxis(arg);
    ADD_FAILURE() << arg << ": no error";
  }
  catch (const ConfigError& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find("--axis '" + arg + "'"), std::string::npos) << what;
    EXPECT_NE(what.find(part), std::string::npos) << what;
  }
}

/// The closed form of unstable_two_links (and of any 1-D plant x+ = 1.5 x + w seen by both
/// sensors): E[P] bounded iff 1.5^2 (1 - l1)(1 - l2) < 1, so the critical l2 is 1 - 1/(2.25 (1 - l1)),
/// and 0 (stable at every l2) once 2.25 (1 - l1) <= 1.
double closedFormCritical(double l1)
{
  return std::max(0.0, 1.0 - 1.0 / (2.25 * (1.0 - l1)));
}

std::vector<std::optional<ChannelSettings>> lossless(std::size_t n)
{
  return std::vector<std::optional<ChannelSettings>>(n);
}

}  // namespace

TEST(Sweep, GridValues)
{
  const std::vector<double> v = sweepValues(0.0, 1.0, 5);
  ASSERT_EQ(v.size(), 5u);
  EXPECT_EQ(v[0], 0.0);
  EXPECT_EQ(v[1], 0.25);
  EXPECT_EQ(v[2], 0.5);
  EXPECT_EQ(v[4], 1.0);
  // the ends exactly, whatever the rounding of the steps
  const std::vector<double> w = sweepValues(0.05, 0.95, 19);
  EXPECT_EQ(w.front(), 0.05);
  EXPECT_EQ(w.back(), 0.95);
  EXPECT_NEAR(w[9], 0.5, 1e-15);
  EXPECT_EQ(sweepValues(0.3, 0.3, 1), std::vector<double>{0.3});

  const SweepAxis a = parseSweepAxis("gnss.arrival_rate=0.1:0.9:9");
  EXPECT_EQ(a.sensor, "gnss");
  EXPECT_EQ(a.param, "arrival_rate");
  EXPECT_EQ(a.count, 9);
  EXPECT_EQ(a.values, sweepValues(0.1, 0.9, 9));
  EXPECT_EQ(a.name(), "gnss.arrival_rate");
  // a sensor name with a dot: the parameter is after the last one
  EXPECT_EQ(parseSweepAxis("front.cam.recovery_rate=0.5:0.5:1").sensor, "front.cam");
}

TEST(Sweep, AxisErrorsNameTheArgument)
{
  expectAxisError("gnss.arrival_rate", "expected NAME=LO:HI:N with NAME SENSOR.PARAM, ESTIMATOR.PARAM or model.ENTRY");
  expectAxisError("arrival_rate=0:1:3", "expected NAME=LO:HI:N with NAME SENSOR.PARAM, ESTIMATOR.PARAM or model.ENTRY");
  expectAxisError("gnss.arrival_rate=0:1",
                  "expected NAME=LO:HI:N with NAME SENSOR.PARAM, ESTIMATOR.PARAM or model.ENTRY");
  expectAxisError("gnss.latency=0:1:3",
                  "unknown parameter 'latency' (valid: a sensor's arrival_rate, recovery_rate, "
                  "loss, p, r, loss_good, loss_bad; an estimator's mu, recovery, failure; the "
                  "model's model.A[i][j], C[i][j], Q* or R*)");
  expectAxisError("gnss.delay=0:1:3", "delay is not simulated by the Monte Carlo");
  expectAxisError("model.B[0][0]=0:1:3", "unknown model entry 'B[0][0]'");
  expectAxisError("model.A[0]=0:1:3", "unknown model entry 'A[0]'");
  expectAxisError("model.A[x][0]=0:1:3", "unknown model entry");
  expectAxisError("model.Q*=0:1:3", "model.Q* (a factor) must be > 0");
  expectAxisError("kfio.mu=0:1:3", "mu must lie in (0, 1]");
  expectAxisError("gnss.loss_bad=0.5:1.5:3", "loss_bad must lie in [0, 1]");
  expectAxisError("schedule.period=1:4:4", "the schedule is not swept");
  expectAxisError("gnss.arrival_rate=a:1:3", "LO 'a' is not a number");
  expectAxisError("gnss.arrival_rate=0:nan:3", "HI 'nan' is not a number");
  expectAxisError("gnss.arrival_rate=0:1:0", "N '0' is not an integer in [1, 10000]");
  expectAxisError("gnss.arrival_rate=0:1:2.5", "N '2.5' is not an integer");
  expectAxisError("gnss.arrival_rate=0:1:-3", "N '-3'");
  expectAxisError("gnss.arrival_rate=0.9:0.1:3", "LO 0.9 is above HI 0.1");
  expectAxisError("gnss.arrival_rate=0.2:0.4:1", "N = 1 needs LO = HI");
  expectAxisError("gnss.arrival_rate=0:1.5:3", "arrival_rate must lie in [0, 1]");
  expectAxisError("gnss.recovery_rate=-0.1:1:3", "recovery_rate must lie in [0, 1]");

  const Model m = test::scalarTwoSensorModel(1.5, "gnss", "camera");
  auto resolveError = [&](std::vector<std::string> args, const std::string& part)
  {
    std::vector<SweepAxis> axes;
    for (const std::string& a : args)
      axes.push_back(parseSweepAxis(a));
    try
    {
      resolveSweepAxes(axes, m, lossless(2));
      ADD_FAILURE() << "no error for " << args.front();
    }
    catch (const ConfigError& e)
    {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  resolveError({"gps.arrival_rate=0:1:3"},
               "--axis 'gps.arrival_rate=0:1:3': no sensor 'gps' in model 'two' (sensors: gnss, camera)");
  resolveError({"gnss.recovery_rate=0:1:3"},
               "--axis 'gnss.recovery_rate=0:1:3': recovery_rate needs a gilbert_elliott link on sensor 'gnss'");
  resolveError({"gnss.arrival_rate=0:1:3", "gnss.arrival_rate=0:0.5:3"}, "sensor 'gnss' is already swept");
  resolveError({"gnss.arrival_rate=0:1:3", "camera.arrival_rate=0:1:3", "gnss.arrival_rate=0:1:2"},
               "expected one or two --axis options, found 3");
  resolveError({"gnss.arrival_rate=0:1:101", "camera.arrival_rate=0:1:100"},
               "--axis 'gnss.arrival_rate=0:1:101' x --axis 'camera.arrival_rate=0:1:100': 101 x 100 = 10100 grid "
               "points, at most 10000");
}

TEST(Sweep, BoundaryEqualsTheClosedFormOfUnstableTwoLinks)
{
  const Model m = test::scalarTwoSensorModel(1.5, "gnss", "camera");
  std::vector<SweepAxis> axes = {parseSweepAxis("gnss.arrival_rate=0:0.95:20"),
                                 parseSweepAxis("camera.arrival_rate=0:0.95:20")};
  resolveSweepAxes(axes, m, lossless(2));
  const SweepAnalysis an = analyseSweep(m, lossless(2), axes);
  ASSERT_EQ(an.critical.size(), 20u);
  ASSERT_EQ(an.verdicts.size(), 400u);
  for (std::size_t i = 0; i < 20; ++i)
  {
    const SweepAnalysis::Critical& c = an.critical[i];
    const double l1 = axes[0].values[i];
    EXPECT_EQ(c.at, l1);
    EXPECT_TRUE(c.half_line) << c.note;
    EXPECT_FALSE(c.undecided_band);
    // Theorem 14 is exact here: bisection to the analysis' exact tolerance (1e-7)
    EXPECT_NEAR(c.converges_at, closedFormCritical(l1), 1e-6) << "l1 = " << l1 << ": " << c.note;
    if (closedFormCritical(l1) > 0.0)
    {
      EXPECT_LE(c.diverges_at, c.converges_at);
      EXPECT_NEAR(c.diverges_at, closedFormCritical(l1), 1e-6);
      EXPECT_NEAR(1.0 - c.converges_at, 1.0 / (2.25 * (1.0 - l1)), 1e-6);  // (1 - l2) = 1/(2.25 (1 - l1))
    }
    else
    {
      EXPECT_TRUE(std::isnan(c.diverges_at));  // stable at every camera rate
    }
    for (std::size_t j = 0; j < 20; ++j)
    {
      const double growth = 2.25 * (1.0 - l1) * (1.0 - axes[1].values[j]);
      if (std::abs(growth - 1.0) > 1e-6)
      {
        EXPECT_EQ(an.verdicts[i * 20 + j], growth < 1.0 ? "stable" : "unstable") << l1 << ", " << axes[1].values[j];
      }
    }
  }
}

TEST(Sweep, RecoveryRateBoundaryOfOnOffLinks)
{
  // on/off Gilbert-Elliott links: stable iff 1.5^2 (1 - r_gnss)(1 - r_camera) < 1, whatever p
  const Model m = test::scalarTwoSensorModel(1.5, "gnss", "camera");
  ChannelSettings ge;
  ge.model = LossModelKind::GILBERT_ELLIOTT;
  ge.p = 0.3;
  ge.r = 0.5;
  const std::vector<std::optional<ChannelSettings>> links = {ge, ge};
  std::vector<SweepAxis> axes = {parseSweepAxis("gnss.recovery_rate=0.1:0.9:5"),
                                 parseSweepAxis("camera.recovery_rate=0.1:0.9:5")};
  resolveSweepAxes(axes, m, links);
  const SweepAnalysis an = analyseSweep(m, links, axes);
  ASSERT_EQ(an.critical.size(), 5u);
  for (std::size_t i = 0; i < 5; ++i)
    EXPECT_NEAR(an.critical[i].converges_at, closedFormCritical(axes[0].values[i]), 1e-6) << an.critical[i].note;
  // one axis: the critical value of that axis, the other link as given (r = 0.5)
  std::vector<SweepAxis> one = {parseSweepAxis("camera.recovery_rate=0:1:11")};
  resolveSweepAxes(one, m, links);
  const SweepAnalysis an1 = analyseSweep(m, links, one);
  ASSERT_EQ(an1.critical.size(), 1u);
  EXPECT_TRUE(std::isnan(an1.critical[0].at));
  EXPECT_NEAR(an1.critical[0].converges_at, closedFormCritical(0.5), 1e-6);
  EXPECT_EQ(an1.verdicts.size(), 11u);
}

TEST(Sweep, AxesOverAnyParameterParseAndResolve)
{
  const SweepAxis a = parseSweepAxis("model.A[0][0]=1.1:1.6:6");
  EXPECT_EQ(a.kind, SweepAxis::Kind::MODEL);
  EXPECT_EQ(a.param, "A");
  EXPECT_EQ(a.row, 0);
  EXPECT_EQ(a.col, 0);
  EXPECT_EQ(a.name(), "model.A[0][0]");
  EXPECT_EQ(parseSweepAxis("model.A[0][0]=-2:3:6").lo, -2.0);  // an entry may be any number
  EXPECT_EQ(parseSweepAxis("model.R*=0.5:8:5").name(), "model.R*");
  const SweepAxis mu = parseSweepAxis("robust.mu=0.5:1:6");
  EXPECT_EQ(mu.kind, SweepAxis::Kind::SETTINGS);
  EXPECT_EQ(mu.sensor, "robust");
  EXPECT_EQ(parseSweepAxis("gnss.loss_good=0:0.2:3").kind, SweepAxis::Kind::LINK);

  const Model m = test::scalarTwoSensorModel(1.5, "gnss", "camera");
  ChannelSettings ge;
  ge.model = LossModelKind::GILBERT_ELLIOTT;
  ge.p = 0.3;
  ge.r = 0.5;
  const std::vector<std::optional<ChannelSettings>> links = {ge, std::nullopt};
  EstimatorSettings kfio, rseio;
  rseio.algorithm = Algorithm::RSEIO;
  rseio.mu = 0.8;
  const std::vector<std::string> names = {"kfio", "robust"};
  const std::vector<EstimatorSettings> settings = {kfio, rseio};
  auto resolves = [&](std::vector<std::string> args)
  {
    std::vector<SweepAxis> axes;
    for (const std::string& arg : args)
      axes.push_back(parseSweepAxis(arg));
    resolveSweepAxes(axes, m, links, names, settings);
    return axes;
  };
  auto refused = [&](std::vector<std::string> args, const std::string& part)
  {
    try
    {
      resolves(args);
      ADD_FAILURE() << "no error for " << args.back();
    }
    catch (const ConfigError& e)
    {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  // a 2-D map of one Gilbert-Elliott link, an estimator's mu, the model's entries
  EXPECT_EQ(resolves({"gnss.p=0:0.5:3", "gnss.r=0.1:0.9:3"}).size(), 2u);
  EXPECT_EQ(resolves({"robust.mu=0.5:1:3", "model.Q*=0.5:2:3"})[0].sensor_index, 1);
  refused({"kfio.mu=0.5:1:3"}, "--axis 'kfio.mu=0.5:1:3': mu is rseio's; estimator 'kfio' is kfio");
  refused({"robust.recovery=0.2:0.8:3"}, "recovery is the control_link of aoe or oe");
  refused({"lidar.mu=0.5:1:3"}, "no estimator 'lidar' (estimators: kfio, robust)");
  refused({"camera.p=0:0.5:3"}, "p needs a gilbert_elliott link on sensor 'camera'");
  refused({"gnss.loss=0:0.5:3"}, "loss is a bernoulli link's key; sensor 'gnss' has a gilbert_elliott link");
  refused({"model.A[1][0]=0:1:3"}, "model 'two': A is 1 x 1");
  refused({"model.C[2][0]=0:1:3"}, "C is 2 x 1");
  refused({"gnss.p=0:0.5:3", "gnss.p=0:0.4:3"}, "gnss.p is already swept");
  refused({"gnss.arrival_rate=0:0.5:3", "gnss.r=0:0.4:3"}, "sensor 'gnss' is already swept");

  // the point's model, settings and links
  const std::vector<SweepAxis> axes = resolves({"model.A[0][0]=1.1:1.6:6", "robust.mu=0.5:1:3"});
  const Model pm = sweepPointModel(m, axes, {1.3, 0.75});
  EXPECT_EQ(pm.A(0, 0), 1.3);
  EXPECT_EQ(pm.Q, m.Q);
  EXPECT_EQ(sweepPointSettings(settings, axes, {1.3, 0.75})[1].mu, 0.75);
  EXPECT_EQ(sweepPointSettings(settings, axes, {1.3, 0.75})[0].algorithm, Algorithm::KFIO);
  const std::vector<SweepAxis> scales = resolves({"model.Q*=0.5:2:4", "model.R*=2:4:2"});
  const Model ps = sweepPointModel(m, scales, {2.0, 4.0});
  EXPECT_EQ(ps.Q, 2.0 * m.Q);
  EXPECT_EQ(ps.R, 4.0 * m.R);
  const std::vector<SweepAxis> lk = resolves({"gnss.loss_bad=0.5:1:3", "gnss.p=0:0.5:3"});
  const auto pl = sweepPointLinks(links, lk, {0.75, 0.25});
  EXPECT_EQ(pl[0]->loss_bad, 0.75);
  EXPECT_EQ(pl[0]->p, 0.25);
  EXPECT_EQ(pl[0]->r, 0.5);
}

// The critical curve along a model axis: a scalar plant x+ = a x + w behind an i.i.d. link is
// stable iff lambda > 1 - 1/a^2 (Sinopoli et al.), so sweeping model.A[0][0] against the arrival
// rate draws that closed form.
TEST(Sweep, CriticalCurveAlongAModelAxisIsSinopolisClosedForm)
{
  Model m = test::scalarTwoSensorModel(1.5, "gnss", "camera");
  std::vector<SweepAxis> axes = {parseSweepAxis("model.A[0][0]=1.1:1.6:6"), parseSweepAxis("gnss.arrival_rate=0:1:11")};
  // camera never arrives: gnss alone decides
  ChannelSettings never;
  never.loss = 1.0;
  const std::vector<std::optional<ChannelSettings>> links = {std::nullopt, never};
  resolveSweepAxes(axes, m, links);
  const SweepAnalysis an = analyseSweep(m, links, axes);
  ASSERT_EQ(an.critical.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i)
  {
    const double a = axes[0].values[i];
    EXPECT_EQ(an.critical[i].at, a);
    EXPECT_NEAR(an.critical[i].converges_at, 1.0 - 1.0 / (a * a), 1e-6) << an.critical[i].note;
    for (std::size_t j = 0; j < 11; ++j)
    {
      const double lambda = axes[1].values[j];
      if (std::abs(lambda - (1.0 - 1.0 / (a * a))) > 1e-6)
        EXPECT_EQ(an.verdicts[i * 11 + j], lambda > 1.0 - 1.0 / (a * a) ? "stable" : "unstable") << a << ", " << lambda;
    }
  }
  // along a parameter that is not a rate there is no critical value, and the note says why
  std::vector<SweepAxis> q = {parseSweepAxis("model.Q*=1:2:2")};
  resolveSweepAxes(q, m, links);
  EXPECT_NE(analyseSweep(m, links, q).critical.at(0).note.find("not applicable"), std::string::npos);
}

// A grid point of a model or settings axis is the run of that model or those settings: the cell
// equals, bit for bit, the cell of a sweep of the changed files (the same seeds).
TEST(Sweep, ModelAndSettingsPointsEqualTheChangedFiles)
{
  Files f;
  const std::string rseio = f.write("robust.yaml", "algorithm: rseio\nmu: 0.5\n");
  // the scalar plant with an uncertain a (eps ~ U[-1, 1] times 0.1): without uncertainty rseio is
  // kfio and mu changes nothing
  const std::string uncertain = "\nuncertainty:\n  - dA: [[0.1]]\n    range: 1.0\n";
  const std::string sensors =
      "sensors:\n  - {name: gnss,   C: [[1.0]], R: [[4.0]]}\n"
      "  - {name: camera, C: [[1.0]], R: [[0.25]]}\nx0: [0]\nP0: [[1]]";
  MonteCarloConfig a = sweepConfig(f, {"model.Q*=1:3:2", "robust.mu=0.5:0.9:2"}, 130, 25);
  a.model_path =
      f.write("q1.yaml", "name: unstable_two_links\nperiod: 0.1\nA: [[1.5]]\nQ: [[1.0]]\n" + sensors + uncertain);
  a.settings_paths = {f.kf, rseio};
  const ExperimentResult ra = runExperiment(a);
  ASSERT_EQ(ra.sweep->points, 4);
  // the point (Q* = 3, mu = 0.9) from files: Q = 3 and mu = 0.9, one point on a link axis that
  // changes nothing (gnss and camera are lossless in both)
  MonteCarloConfig b = sweepConfig(f, {"gnss.arrival_rate=1:1:1"}, 130, 25);
  b.model_path =
      f.write("q3.yaml", "name: unstable_two_links\nperiod: 0.1\nA: [[1.5]]\nQ: [[3.0]]\n" + sensors + uncertain);
  b.settings_paths = {f.kf, f.write("robust2.yaml", "algorithm: rseio\nmu: 0.9\n")};
  const ExperimentResult rb = runExperiment(b);
  for (std::size_t j = 0; j < 2; ++j)
  {
    const SweepCell& ca = ra.sweep->cells[3 * 2 + j];
    const SweepCell& cb = rb.sweep->cells[j];
    EXPECT_EQ(ca.trP_mean, cb.trP_mean) << j;
    EXPECT_EQ(ca.err_mean, cb.err_mean) << j;
    EXPECT_EQ(ca.trP_median, cb.trP_median) << j;
    EXPECT_EQ(ca.floored, 0);
  }
  // and the points differ: Q and mu matter
  EXPECT_NE(ra.sweep->cells[0].trP_mean, ra.sweep->cells[3 * 2].trP_mean);
  EXPECT_NE(ra.sweep->cells[1].trP_mean, ra.sweep->cells[1 * 2 + 1].trP_mean);

  // covariance only over a model axis past the rounding floor (the plant a = 2 would cross it near
  // k = 45): 400 steps, both sensors lossless, so P stays bounded at every a
  MonteCarloConfig c = sweepConfig(f, {"model.A[0][0]=1.2:2:3"}, 64, 400);
  c.covariance_only = true;
  const ExperimentResult rc = runExperiment(c);
  for (const SweepCell& cell : rc.sweep->cells)
  {
    EXPECT_EQ(cell.floored, 0);
    EXPECT_EQ(cell.diverged, 0);
    EXPECT_TRUE(std::isfinite(cell.trP_mean) && cell.trP_mean > 0.0);
  }
  EXPECT_LT(rc.sweep->cells[0].trP_mean, rc.sweep->cells[2].trP_mean);  // a larger a: a larger P
}

TEST(Sweep, PointLinks)
{
  ChannelSettings ge;
  ge.model = LossModelKind::GILBERT_ELLIOTT;
  ge.p = 0.3;
  ge.r = 0.5;
  ge.seed = 7;
  std::vector<SweepAxis> axes = {parseSweepAxis("a.arrival_rate=0:1:3"), parseSweepAxis("b.recovery_rate=0:1:3")};
  axes[0].sensor_index = 0;
  axes[1].sensor_index = 1;
  const auto l = sweepPointLinks({std::nullopt, ge}, axes, {0.25, 0.75});
  ASSERT_TRUE(l[0].has_value());
  EXPECT_EQ(l[0]->model, LossModelKind::BERNOULLI);
  EXPECT_EQ(l[0]->loss, 0.75);
  EXPECT_EQ(l[1]->model, LossModelKind::GILBERT_ELLIOTT);
  EXPECT_EQ(l[1]->r, 0.75);
  EXPECT_EQ(l[1]->p, 0.3);
  EXPECT_EQ(l[1]->seed, 7u);
}

TEST(Sweep, ThreadCountAndShardsDoNotChangeResults)
{
  Files f;
  const MonteCarloConfig c =
      sweepConfig(f, {"gnss.arrival_rate=0.3:0.9:3", "camera.arrival_rate=0.2:0.8:4"}, 150, 20, 1);
  const ExperimentResult one = runExperiment(c);
  MonteCarloConfig c3 = c;
  c3.threads = 3;
  const ExperimentResult three = runExperiment(c3);
  ASSERT_TRUE(one.sweep);
  EXPECT_EQ(one.sweep->points, 12);
  EXPECT_EQ(experimentCsv(one), experimentCsv(three));
  // sharded 3 ways and merged: bit for bit
  std::vector<ShardFile> shards;
  for (int k = 1; k <= 3; ++k)
    shards.push_back(parseShard(shardJson(runShard(c, k, 3)), "sweep.shard-" + std::to_string(k) + "-of-3.json"));
  ExperimentResult merged = mergeShards(std::move(shards));
  EXPECT_EQ(experimentCsv(merged), experimentCsv(one));
  merged.threads = one.threads;
  merged.wall_seconds = one.wall_seconds;
  EXPECT_EQ(experimentJson(merged), experimentJson(one));
}

TEST(Sweep, RunsThatCannotBeCountedAreRecordedNotAveraged)
{
  Files f;
  // The plant x+ = 1.5 x + w crosses the rounding floor (2.25e12 here: 1e-3 sqrt(0.25) / 2^-52)
  // near k = 70 whatever the links (its sd is about 1.34 1.5^k). 100 steps: every run floors at
  // both points, yet the sweep completes and writes no statistic.
  const ExperimentResult r = runExperiment(sweepConfig(f, {"gnss.arrival_rate=0:1:2"}, 70, 100));
  ASSERT_TRUE(r.sweep);
  ASSERT_EQ(r.sweep->cells.size(), 2u);
  for (const SweepCell& c : r.sweep->cells)
  {
    EXPECT_EQ(c.n, 70);
    EXPECT_EQ(c.floored, 70);
    EXPECT_EQ(c.diverged, 0);
    EXPECT_TRUE(std::isnan(c.trP_mean));
    EXPECT_TRUE(std::isnan(c.err_avg_sd));
  }
  const std::string csv = experimentCsv(r);
  EXPECT_NE(csv.find(",kfio,70,0,70,,,,,,,,,stable,,,,,,,,,,,\n"), std::string::npos) << csv;
  EXPECT_NE(experimentJson(r).find("\"incomplete_cells\": 2"), std::string::npos);
  EXPECT_EQ(csv.find("nan"), std::string::npos);
  EXPECT_EQ(csv.find("inf"), std::string::npos);

  // An estimator that diverges before the plant reaches the floor: x+ = 10 x + w with Q = R = 1e295
  // (the floor is 1e-3 sqrt(1e295) / 2^-52, about 1e160, x_10 about 3e157), and kfio without
  // arrivals: P_k = 100 P_k-1 + Q overflows near k = 7. Every run diverges at arrival rate 0, some
  // at 0.5 (7 consecutive losses), none at 1.
  MonteCarloConfig huge = sweepConfig(f, {"y.arrival_rate=0:1:3"}, 100, 10);
  huge.model_path = f.write("huge.yaml",
                            "name: huge_noise\nA: [[10.0]]\nQ: [[1e295]]\n"
                            "sensors:\n  - {name: y, C: [[1.0]], R: [[1e295]]}\nx0: [0]\nP0: [[1]]\n");
  const ExperimentResult d = runExperiment(huge);
  ASSERT_EQ(d.sweep->cells.size(), 3u);
  EXPECT_EQ(d.sweep->cells[0].diverged, 100);
  EXPECT_EQ(d.sweep->cells[0].floored, 0);
  EXPECT_TRUE(std::isnan(d.sweep->cells[0].trP_mean));
  EXPECT_GT(d.sweep->cells[1].diverged, 0);
  EXPECT_LT(d.sweep->cells[1].diverged, 100);
  EXPECT_TRUE(std::isnan(d.sweep->cells[1].err_mean));
  EXPECT_EQ(d.sweep->cells[2].diverged, 0);
  EXPECT_TRUE(std::isfinite(d.sweep->cells[2].trP_mean));
  EXPECT_NE(experimentCsv(d).find("\n0,0,0,0,,kfio,100,100,0,,,,,,,,,"), std::string::npos) << experimentCsv(d);

  // 69 steps: some runs cross the floor (about a quarter) and some do not: counted, still no mean
  const ExperimentResult partial = runExperiment(sweepConfig(f, {"gnss.arrival_rate=0:0:1"}, 200, 69));
  const SweepCell& c = partial.sweep->cells.at(0);
  EXPECT_GT(c.floored, 0);
  EXPECT_LT(c.floored, 200);
  EXPECT_TRUE(std::isnan(c.trP_mean));
}

TEST(Sweep, StatisticsAtStablePoints)
{
  Files f;
  const long runs = 4000, T = 30;
  const ExperimentResult r =
      runExperiment(sweepConfig(f, {"gnss.arrival_rate=1:1:1", "camera.arrival_rate=0.6:0.6:1"}, runs, T, 2));
  ASSERT_EQ(r.sweep->cells.size(), 1u);
  const SweepCell& c = r.sweep->cells[0];
  ASSERT_EQ(c.n, runs);
  ASSERT_EQ(c.floored + c.diverged, 0);
  EXPECT_EQ(r.sweep->analysis.verdicts[0], "stable");
  // The Kalman filter of the true model: given the arrivals, x_T - xhat_T ~ N(0, P_T), so
  // E|x_T - xhat_T|^2 = E[tr P_T]. The difference of the two sample means has a standard error of at
  // most (sd_err + sd_trP) / sqrt(n) (Cauchy-Schwarz on the covariance of the two); 5 of them
  // leave a chance below 1e-6 of a false failure for a correct filter (and the seed is fixed).
  EXPECT_NEAR(c.err_mean, c.trP_mean, 5.0 * (c.err_sd + c.trP_sd) / std::sqrt(static_cast<double>(runs)));
  EXPECT_GT(c.trP_sd, 0.0);  // the camera's losses make P random

  // Both links lossless: P_T is the Riccati recursion's, the same in every run (sd 0), and
  // |e_T|^2 = P_T chi^2_1 has sd sqrt(2) P_T: the mean error within 5 standard errors of P_T.
  const ExperimentResult l =
      runExperiment(sweepConfig(f, {"gnss.arrival_rate=1:1:1", "camera.arrival_rate=1:1:1"}, runs, T, 2));
  const SweepCell& d = l.sweep->cells[0];
  double P = 1.0;  // P_0|0 = 1; y = [x; x] + v, R = diag(4, 0.25): information 1/4 + 4 per step
  for (long k = 1; k <= T; ++k)
  {
    const double Pp = 2.25 * P + 1.0;
    P = 1.0 / (1.0 / Pp + 0.25 + 4.0);
  }
  EXPECT_NEAR(d.trP_mean, P, 1e-12);
  EXPECT_EQ(d.trP_sd, 0.0);
  EXPECT_NEAR(d.err_mean, P, 5.0 * std::sqrt(2.0) * P / std::sqrt(static_cast<double>(runs)));
}
