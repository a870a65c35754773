// rostest: the Estimator nodelet on a real graph (PlantSimulator -> LossyChannel -> Estimator in
// one nodelet manager, or the test publishing to the estimator directly). Each .test file runs one
// scenario of this binary (selected with --gtest_filter). Private parameters of the test node:
// model (file), settings (kfio settings file), steps (plant steps).
#include <gtest/gtest.h>
#include <ros/package.h>
#include <ros/ros.h>
#include <geometry_msgs/PointStamped.h>
#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>
#include <nav_msgs/Odometry.h>
#include <nodelet/NodeletLoad.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/Twist.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/Range.h>
#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <tf2/LinearMath/Quaternion.h>
#include <std_msgs/Empty.h>
#include <yaml-cpp/yaml.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include "graph_test_support.hpp"
#include "tf_output.hpp"
#include "networked_estimation/ChannelEvent.h"
#include "networked_estimation/Estimate.h"
#include "networked_estimation/LinkStatus.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/PlantState.h"
#include "networked_estimation/ScheduleStep.h"
#include "networked_estimation/SetParameters.h"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/geodesy/local_enu.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/estimator_settings.hpp"

namespace ne = networked_estimation;
using ne::ChannelEvent;
using ne::Estimate;
using ne::Measurement;
using ne::PlantState;

namespace
{

struct Params
{
  std::string model, settings;
  int steps = 0;
};

Params params()
{
  ros::NodeHandle pnh("~");
  Params p;
  pnh.getParam("model", p.model);
  pnh.getParam("settings", p.settings);
  pnh.getParam("steps", p.steps);
  return p;
}

/// Checks the estimates of steps 1..N against kfio stepped offline on y(k) (every y in hand), u(k)
/// (models with control) and R_k = r(k) (empty: the model's R), state by state to 1e-12.
template <class Y, class U, class R = Eigen::MatrixXd (*)(long)>
void expectKfioOffline(
    const ne::Model& model, const std::map<long, Estimate>& got, long N, Y y, U u,
    R r = [](long) { return Eigen::MatrixXd(); })
{
  ne::EstimatorSettings st;
  st.algorithm = ne::Algorithm::KFIO;
  auto ref = ne::makeEstimator(model, st);
  ne::Sample smp;
  for (long k = 1; k <= N; ++k)
  {
    smp.gamma = true;
    smp.y = y(k);
    smp.u = u(k);
    smp.R = r(k);  // the step's own R_k (empty: the model's)
    ref->step(smp);
    ASSERT_EQ(got.count(k), 1u) << "step " << k;
    const Estimate& e = got.at(k);
    EXPECT_TRUE(e.gamma) << "step " << k;
    for (int j = 0; j < model.n(); ++j)
      ASSERT_NEAR(e.state[j], ref->state()(j), 1e-12) << "step " << k << " state " << j;
  }
}

/// No control input.
inline Eigen::VectorXd noInput(long)
{
  return Eigen::VectorXd();
}

/// Estimates of one estimator by step; fails the test on a repeated step.
std::map<long, Estimate> byStep(Collector<Estimate>& c)
{
  std::lock_guard<std::mutex> lock(c.mutex);
  std::map<long, Estimate> out;
  for (const Estimate& e : c.msgs)
    EXPECT_TRUE(out.emplace(static_cast<long>(e.step), e).second) << "step " << e.step << " published twice";
  return out;
}

/// The offline estimator stepped on y_k (NaN when not received), as in the replay tool.
std::vector<Estimate> offline(const ne::Model& model, const ne::EstimatorSettings& st,
                              const std::vector<std::vector<double>>& y, const std::vector<bool>& gamma)
{
  auto est = ne::makeEstimator(model, st);
  std::vector<Estimate> out;
  ne::Sample s;
  for (std::size_t k = 0; k < y.size(); ++k)
  {
    s.gamma = gamma[k];
    s.y = Eigen::Map<const Eigen::VectorXd>(y[k].data(), static_cast<Eigen::Index>(y[k].size()));
    if (!gamma[k])
      s.y.setConstant(std::numeric_limits<double>::quiet_NaN());
    est->step(s);
    Estimate e;
    e.step = k + 1;
    e.state.assign(est->state().data(), est->state().data() + est->state().size());
    const Eigen::MatrixXd& P = est->covariance();
    for (int i = 0; i < P.rows(); ++i)
      for (int j = 0; j < P.cols(); ++j)
        e.covariance.push_back(P(i, j));
    e.covariance_trace = P.trace();
    out.push_back(e);
  }
  return out;
}

double maxDiff(const std::vector<double>& a, const std::vector<double>& b)
{
  if (a.size() != b.size())
    return std::numeric_limits<double>::infinity();
  double d = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    d = std::max(d, std::abs(a[i] - b[i]) / std::max(1.0, std::abs(b[i])));
  return d;
}

/// Runs the offline `replay` tool on (k, gamma, y) and returns its rows (k, gamma, x..., P..., trace).
std::vector<std::vector<double>> runReplay(const Params& p, const std::vector<std::vector<double>>& y,
                                           const std::vector<bool>& gamma, const std::string& tag)
{
  char dir_template[] = "/tmp/ne_graph_replay_XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  const std::string in = dir + "/" + tag + "_in.csv", out = dir + "/" + tag + "_out.csv";
  {
    std::ofstream f(in);
    f << "k,gamma,y1\n";
    char buf[64];
    for (std::size_t k = 0; k < y.size(); ++k)
    {
      std::snprintf(buf, sizeof buf, "%.17g", y[k][0]);
      f << k + 1 << "," << (gamma[k] ? 1 : 0) << "," << (gamma[k] ? buf : "") << "\n";
    }
  }
  const std::string cmd = "rosrun networked_estimation replay --model '" + p.model + "' --settings '" + p.settings +
                          "' --input '" + in + "' --output '" + out + "' 2>/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::vector<std::vector<double>> rows;
  std::ifstream f(out);
  std::string line;
  std::getline(f, line);  // header
  while (std::getline(f, line))
  {
    std::vector<double> row;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ','))
      row.push_back(std::stod(cell));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

// Plant -> lossy channel (Bernoulli 0.2) -> kfio, and plant -> kfio_direct (no loss).
TEST(EstimatorGraph, EveryStepGammaReplayEqualityAndConsistency)
{
  const Params p = params();
  ros::NodeHandle nh;
  Collector<Measurement> raw(nh, "plant/measurement");
  Collector<PlantState> truth(nh, "plant/state");
  Collector<ChannelEvent> events(nh, "sensor_link/events");
  Collector<Estimate> lossy(nh, "kfio/estimate"), direct(nh, "kfio_direct/estimate");
  const long N = p.steps;
  ASSERT_TRUE(waitFor(
      [&]
      {
        return lossy.size() >= static_cast<std::size_t>(N) && direct.size() >= static_cast<std::size_t>(N) &&
               events.size() >= static_cast<std::size_t>(N) && truth.size() > static_cast<std::size_t>(N);
      },
      120.0))
      << "estimates " << lossy.size() << " / " << direct.size() << ", events " << events.size();
  ros::WallDuration(0.2).sleep();

  // The plant's y_k and stamps (the test subscribed before the plant's start delay ran out).
  std::vector<std::vector<double>> y(N);
  std::map<ros::Time, long> step_of_stamp;
  {
    std::lock_guard<std::mutex> lock(raw.mutex);
    ASSERT_GE(raw.msgs.size(), static_cast<std::size_t>(N));
    for (const Measurement& m : raw.msgs)
      if (m.step >= 1 && static_cast<long>(m.step) <= N)
      {
        y[m.step - 1] = m.y;
        step_of_stamp[m.header.stamp] = static_cast<long>(m.step);
      }
  }
  for (long k = 1; k <= N; ++k)
    ASSERT_FALSE(y[k - 1].empty()) << "the test missed y_" << k;

  // gamma_k from the channel's ground truth.
  std::vector<bool> delivered(N, false);
  {
    std::lock_guard<std::mutex> lock(events.mutex);
    for (const ChannelEvent& e : events.msgs)
    {
      auto it = step_of_stamp.find(e.input_stamp);
      ASSERT_NE(it, step_of_stamp.end()) << "event for an unknown stamp";
      if (it->second <= N)
        delivered[it->second - 1] = e.outcome == ChannelEvent::DELIVERED;
    }
  }

  const std::map<long, Estimate> L = byStep(lossy), D = byStep(direct);
  // One estimate per step, steps 1..N, stamped at the plant's rate.
  const double period = 0.02;
  for (long k = 1; k <= N; ++k)
  {
    ASSERT_TRUE(L.count(k) && D.count(k)) << "no estimate for step " << k;
    EXPECT_NEAR((L.at(k).header.stamp - L.at(1).header.stamp).toSec(), (k - 1) * period, 1e-6);
    ASSERT_EQ(L.at(k).gamma, delivered[k - 1]) << "gamma of step " << k << " differs from the channel's event";
    ASSERT_TRUE(D.at(k).gamma) << "no-loss estimator missed step " << k;
  }
  long lost = 0;
  for (bool d : delivered)
    lost += d ? 0 : 1;
  // Bernoulli(0.2) over N = 500: 100 +- 9 lost; 4 sd either way.
  EXPECT_GT(lost, 100 - 36);
  EXPECT_LT(lost, 100 + 36);

  // Offline replay (the tool) on the same inputs: bit-for-bit or 1e-12.
  for (int pass = 0; pass < 2; ++pass)
  {
    const std::vector<bool> gamma = pass == 0 ? std::vector<bool>(N, true) : delivered;
    const std::map<long, Estimate>& online = pass == 0 ? D : L;
    const auto rows = runReplay(p, y, gamma, pass == 0 ? "direct" : "lossy");
    ASSERT_EQ(rows.size(), static_cast<std::size_t>(N));
    double worst = 0.0;
    for (long k = 1; k <= N; ++k)
    {
      const std::vector<double>& r = rows[k - 1];
      const Estimate& e = online.at(k);
      const std::vector<double> x(r.begin() + 2, r.begin() + 4), P(r.begin() + 4, r.begin() + 8);
      worst = std::max({worst, maxDiff(e.state, x), maxDiff(e.covariance, P)});
    }
    EXPECT_LE(worst, 1e-12) << (pass == 0 ? "no loss" : "with loss") << ": online vs replay";
  }

  // Consistency: sum over k of (|e_k|^2 - tr P_k) against its standard deviation. For a Gaussian
  // error with covariance P, var |e|^2 = 2 tr(P^2); errors of this plant decorrelate fast (eigenvalues
  // 0.5, 0.3; lag-1 correlation of |e|^2 at most ~0.25 even across losses), so the variance of the
  // sum is inflated by at most (1 + 0.25) / (1 - 0.25) < 2: we use 2 and accept |z| < 4.
  std::map<long, std::vector<double>> X;
  {
    std::lock_guard<std::mutex> lock(truth.mutex);
    for (const PlantState& s : truth.msgs)
      X[static_cast<long>(s.step)] = s.x;
  }
  double sum = 0.0, var = 0.0, e2sum = 0.0, trsum = 0.0;
  for (long k = 20; k <= N; ++k)
  {
    const Estimate& e = L.at(k);
    ASSERT_TRUE(X.count(k));
    double e2 = 0.0;
    for (int i = 0; i < 2; ++i)
      e2 += (X[k][i] - e.state[i]) * (X[k][i] - e.state[i]);
    double trP2 = 0.0;
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j)
        trP2 += e.covariance[i * 2 + j] * e.covariance[j * 2 + i];
    sum += e2 - e.covariance_trace;
    var += 2.0 * trP2;
    e2sum += e2;
    trsum += e.covariance_trace;
  }
  const double z = sum / std::sqrt(2.0 * var);
  EXPECT_LT(std::abs(z), 4.0) << "time-averaged |e|^2 " << e2sum / (N - 19) << " vs mean tr(P) " << trsum / (N - 19);
}

// Plant -> channel delaying every message past its deadline (but before the next one) -> two
// kfio estimators, late_policy drop and rewind.
TEST(EstimatorGraph, LatePoliciesUnderADelayingChannel)
{
  const Params p = params();
  ros::NodeHandle nh;
  Collector<Measurement> raw(nh, "plant/measurement");
  Collector<Estimate> drop(nh, "kfio_drop/estimate"), rewind(nh, "kfio_rewind/estimate");
  DiagnosticsProbe diag_drop(nh, "kfio_drop"), diag_rewind(nh, "kfio_rewind");
  const long N = p.steps;
  ASSERT_TRUE(waitFor(
      [&] { return drop.size() >= static_cast<std::size_t>(N) && rewind.size() >= static_cast<std::size_t>(N); },
      120.0));
  std::vector<std::vector<double>> y(N);
  {
    std::lock_guard<std::mutex> lock(raw.mutex);
    for (const Measurement& m : raw.msgs)
      if (m.step >= 1 && static_cast<long>(m.step) <= N)
        y[m.step - 1] = m.y;
  }
  for (long k = 1; k <= N; ++k)
    ASSERT_FALSE(y[k - 1].empty());
  const ne::Model model = ne::loadModel(p.model);
  const ne::EstimatorSettings st = ne::loadEstimatorSettings(p.settings);
  const std::map<long, Estimate> Dr = byStep(drop), Rw = byStep(rewind);

  // drop: nothing arrives by its deadline, so every step is a prediction.
  const auto pred = offline(model, st, y, std::vector<bool>(N, false));
  for (long k = 1; k <= N; ++k)
  {
    ASSERT_TRUE(Dr.count(k));
    EXPECT_FALSE(Dr.at(k).gamma);
    ASSERT_LE(maxDiff(Dr.at(k).state, pred[k - 1].state), 1e-12) << "drop, step " << k;
  }
  // rewind: y_k arrives after step k's deadline and is fused before step k+1: the estimate of step k
  // is the filter on y_1..y_{k-1} followed by a prediction.
  for (long k = 2; k <= N; k += 7)
  {
    std::vector<bool> g(k, true);
    g[k - 1] = false;
    const auto ref = offline(model, st, std::vector<std::vector<double>>(y.begin(), y.begin() + k), g);
    ASSERT_TRUE(Rw.count(k));
    EXPECT_FALSE(Rw.at(k).gamma);
    ASSERT_LE(maxDiff(Rw.at(k).state, ref.back().state), 1e-12) << "rewind, step " << k;
    ASSERT_LE(maxDiff(Rw.at(k).covariance, ref.back().covariance), 1e-12) << "rewind, step " << k;
  }
  ASSERT_TRUE(
      waitFor([&] { return diag_drop.get("late dropped") >= N - 1 && diag_rewind.get("late fused") >= N - 1; }, 5.0))
      << "late dropped " << diag_drop.get("late dropped") << ", late fused " << diag_rewind.get("late fused");
  EXPECT_EQ(diag_rewind.get("late dropped"), 0.0);
  // No silent loss: the estimator status of drop is WARN, naming the sensor that loses its messages
  // to lateness and its delay; rewind loses nothing.
  DiagnosticsProbe status_drop(nh, "kfio_drop/estimator: estimator"),
      status_rewind(nh, "kfio_rewind/estimator: estimator");
  ASSERT_TRUE(waitFor([&] { return !status_drop.lastMessage().empty() && !status_rewind.lastMessage().empty(); }, 5.0));
  EXPECT_TRUE(status_drop.levelIs(diagnostic_msgs::DiagnosticStatus::WARN)) << status_drop.lastMessage();
  EXPECT_NE(status_drop.lastMessage().find("sensor 'y': 100.0 % of its messages over the last 10 s late or refused "
                                           "(delay p99 "),
            std::string::npos)
      << status_drop.lastMessage();
  EXPECT_EQ(status_rewind.lastMessage().find("late or refused"), std::string::npos) << status_rewind.lastMessage();
  EXPECT_EQ(status_drop.get("y late dropped"), diag_drop.get("late dropped"));
}

// The test drives /clock and publishes straight to the estimator: bad messages among good ones,
// then the clock jumps back (a bag looping) and the same stream is sent again.
TEST(EstimatorGraph, BadInputIsRejectedAndATimeJumpResets)
{
  const Params p = params();
  ros::NodeHandle nh;
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  ros::Publisher meas = nh.advertise<Measurement>("measurement", 100);
  Collector<Estimate> est(nh, "kfio/estimate");
  DiagnosticsProbe diag(nh, "kfio");
  // (the manager's /clock too: a tick published before its connection is up is lost, and the
  // estimator would wait for it)
  ASSERT_TRUE(waitFor(
      [&]
      {
        return deliversTo(ros::this_node::getName(), "/clock", "/manager") && meas.getNumSubscribers() > 0 &&
               publishersDeliverHere(est.sub);
      },
      20.0));
  const double T = 0.02, t0 = 100.0;
  auto setClock = [&](double t)
  {
    rosgraph_msgs::Clock c;
    c.clock.fromSec(t);
    clock.publish(c);
  };
  auto good = [&](long k, double y)
  {
    Measurement m;
    m.header.stamp.fromSec(t0 + k * T);
    m.step = k;
    m.sensor = "y";
    m.y = {y};
    return m;
  };
  const long N = 60;
  std::vector<Estimate> first_run;
  for (int run = 0; run < 2; ++run)
  {
    est.clear();
    for (long k = 1; k <= N; ++k)
    {
      setClock(t0 + k * T);
      Measurement bad = good(k, 0.0);
      bool send_bad = true;
      switch (k % 10)
      {
        case 2:
          bad.y = {1.0, 2.0};
          break;  // wrong dimension
        case 4:
          bad.y = {std::numeric_limits<double>::quiet_NaN()};
          break;  // NaN
        case 6:
          bad.step = k + 100000;
          break;  // far future
        case 8:
          bad.sensor = "other";
          break;  // wrong sensor name
        default:
          send_bad = false;
      }
      if (send_bad)
        meas.publish(bad);
      meas.publish(good(k, std::sin(0.3 * k)));
      if (k % 10 == 5)
        meas.publish(good(k, 1e6));  // duplicate: ignored
      ASSERT_TRUE(waitFor([&] { return est.size() >= static_cast<std::size_t>(k); }, 5.0))
          << "run " << run << " step " << k;
    }
    std::lock_guard<std::mutex> lock(est.mutex);
    for (long k = 1; k <= N; ++k)
    {
      const Estimate& e = est.msgs[k - 1];
      ASSERT_EQ(static_cast<long>(e.step), k);
      EXPECT_TRUE(e.gamma);
      for (double v : e.state)
        ASSERT_TRUE(std::isfinite(v));
      if (run == 1)  // after the reset, the same stream gives the same estimates
      {
        ASSERT_EQ(e.state, first_run[k - 1].state) << "step " << k;
      }
    }
    if (run == 0)
    {
      first_run = est.msgs;
      // The clock jumps back: the estimator must reset and accept the stream from step 1 again.
      setClock(t0 - 5.0);
      ASSERT_TRUE(waitFor([&] { return diag.get("time resets") >= 1.0; }, 10.0)) << "no reset after the jump";
    }
  }
  // 4 bad kinds x 6 per run x 2 runs; 6 duplicates per run.
  ASSERT_TRUE(waitFor([&] { return diag.get("rejected") >= 48.0 && diag.get("duplicates") >= 12.0; }, 5.0));
  EXPECT_EQ(diag.get("rejected"), 48.0);
  EXPECT_EQ(diag.get("duplicates"), 12.0);
  EXPECT_EQ(diag.get("time resets"), 1.0);
}

// Live stability diagnostics: the estimator's "link stability" status goes to ERROR when the
// channel delivers 10 % of the samples of a plant whose critical arrival rate is 1 - 1/1.1^2, and
// to OK when the channel is reconfigured to lose 2 %. (Window 200: at 0.1 the 95 % interval is
// about [0.066, 0.15], below 0.1736; at 0.98 it is about [0.95, 0.99], above it.)
TEST(EstimatorGraph, StabilityDiagnosticFlipsWithTheArrivalRate)
{
  ros::NodeHandle nh;
  // The measurements come from the test at 100 Hz (the diagnostic depends on the arrivals only):
  // a simulated open-loop x_k = 1.1 x_{k-1} + w would reach the simulator's rounding floor near
  // k = 300, before the window has refilled under load. Their values are y = 0.
  ros::Publisher source = nh.advertise<Measurement>("plant/measurement", 1000);
  ASSERT_TRUE(waitFor([&] { return source.getNumSubscribers() > 0; }, 20.0));
  PeriodicFeeder feeder(0.01,
                        [&](long k)
                        {
                          Measurement m;
                          m.header.stamp = ros::Time::now();
                          m.step = static_cast<std::uint64_t>(k);
                          m.sensor = "y";
                          m.y = {0.0};
                          source.publish(m);
                        });
  DiagnosticsProbe link(nh, "link stability");
  ASSERT_TRUE(waitFor([&] { return link.levelIs(diagnostic_msgs::DiagnosticStatus::ERROR); }, 40.0))
      << "last: " << link.lastMessage();
  EXPECT_NEAR(link.get("critical (necessary)"), 1.0 - 1.0 / 1.21, 1e-6);
  EXPECT_NE(link.lastMessage().find("unbounded"), std::string::npos) << link.lastMessage();
  ros::ServiceClient set = nh.serviceClient<ne::SetParameters>("sensor_link/set_parameters");
  ne::SetParameters srv;
  srv.request.yaml = "{loss: 0.02}";
  ASSERT_TRUE(set.call(srv) && srv.response.success) << srv.response.message;
  // A window of 200 steps at 100 Hz refills in 2 s.
  ASSERT_TRUE(waitFor([&] { return link.levelIs(diagnostic_msgs::DiagnosticStatus::OK); }, 30.0))
      << "last: " << link.lastMessage();
  // Gan and Liu's evidence for the scalar sensor, and their Theorem 1 holding along the run (kfio,
  // one scalar sensor, late data dropped: the invariant is checked at every block).
  EXPECT_FALSE(link.text("y Gan-Liu excitation").empty());
  EXPECT_EQ(link.text("Gan-Liu Theorem 1 (runtime invariant)").rfind("holds over ", 0), 0u)
      << link.text("Gan-Liu Theorem 1 (runtime invariant)");
}

/// "0.6 [0.585, 0.615] (4000 samples)": the value, the interval and the trials of a live rate.
struct DiagnosedRate
{
  double value = std::nan(""), lower = std::nan(""), upper = std::nan("");
  unsigned long trials = 0;
  bool parsed = false;
};
DiagnosedRate parseRate(const std::string& text)
{
  DiagnosedRate r;
  r.parsed = std::sscanf(text.c_str(), "%lf [%lf, %lf] (%lu", &r.value, &r.lower, &r.upper, &r.trials) == 4;
  return r;
}

/// The diagnostics print 6 significant digits (%g, liveNumber, diagnostic_updater's default
/// stream precision): a relative rounding of at most 5e-6, so 1e-5 of the value (and 1e-12 near 0).
bool sameAsPrinted(double msg, double printed)
{
  if (std::isnan(msg) || std::isnan(printed))
    return std::isnan(msg) && std::isnan(printed);
  return std::fabs(msg - printed) <= 1e-5 * std::fabs(printed) + 1e-12;
}

/// The Estimator `ns`'s ~link_status carries, per sensor, the numbers of the diagnostics of the same
/// report: the live rates with their intervals ("link stability"), the margin and what the rate
/// needs, the joint level, and the delays and late fraction ("estimator"). Both are sent from one
/// diagnostics tick, so the latest of each agree once a tick has been seen whole (waited for: the
/// topics arrive separately).
void expectLinkStatusAsDiagnosed(ros::NodeHandle& nh, const std::string& ns, const std::vector<std::string>& sensors)
{
  DiagnosticsProbe link(nh, ns + ": link stability"), estimator(nh, ns + ": estimator");
  std::mutex mutex;
  std::map<std::string, ne::LinkStatus> latest;
  ros::Subscriber sub = nh.subscribe<ne::LinkStatus>(ns + "/link_status", 100,
                                                     [&](const ne::LinkStatus::ConstPtr& m)
                                                     {
                                                       std::lock_guard<std::mutex> lock(mutex);
                                                       latest[m->sensor] = *m;
                                                     });
  std::string why;
  auto agree = [&]()
  {
    const std::map<std::string, std::string> l = link.snapshot(), e = estimator.snapshot();
    const std::string level = link.levelIs(diagnostic_msgs::DiagnosticStatus::OK)      ? "OK"
                              : link.levelIs(diagnostic_msgs::DiagnosticStatus::WARN)  ? "WARN"
                              : link.levelIs(diagnostic_msgs::DiagnosticStatus::ERROR) ? "ERROR"
                                                                                       : "?";
    std::lock_guard<std::mutex> lock(mutex);
    std::ostringstream out;
    for (const std::string& s : sensors)
    {
      if (!latest.count(s) || !l.count(s + " arrival rate") || !e.count(s + " delay p50 (s)"))
      {
        out << s << ": no message or diagnostics yet; ";
        continue;
      }
      const ne::LinkStatus& m = latest.at(s);
      const DiagnosedRate a = parseRate(l.at(s + " arrival rate")), p = parseRate(l.at(s + " failure rate p")),
                          r = parseRate(l.at(s + " recovery rate r"));
      auto check = [&](const char* what, double msg, double printed)
      {
        if (!sameAsPrinted(msg, printed))
          out << s << " " << what << ": message " << msg << ", diagnostics " << printed << "; ";
      };
      if (!a.parsed || !p.parsed || !r.parsed)
        out << s << ": unparsed rates; ";
      check("arrival rate", m.arrival_rate, a.value);
      check("arrival lower", m.arrival_rate_lower, a.lower);
      check("arrival upper", m.arrival_rate_upper, a.upper);
      check("arrival samples", static_cast<double>(m.arrival_samples), static_cast<double>(a.trials));
      check("p", m.p, p.value);
      check("p lower", m.p_lower, p.lower);
      check("p upper", m.p_upper, p.upper);
      check("p transitions", static_cast<double>(m.p_transitions), static_cast<double>(p.trials));
      check("r", m.r, r.value);
      check("r lower", m.r_lower, r.lower);
      check("r upper", m.r_upper, r.upper);
      check("r transitions", static_cast<double>(m.r_transitions), static_cast<double>(r.trials));
      check("margin", m.margin, l.count(s + " margin") ? std::stod(l.at(s + " margin")) : std::nan(""));
      check("delay p50", m.delay_p50, std::stod(e.at(s + " delay p50 (s)")));
      check("delay p99", m.delay_p99, std::stod(e.at(s + " delay p99 (s)")));
      check("late fraction", m.late_fraction,
            e.count(s + " late fraction") ? std::stod(e.at(s + " late fraction")) : std::nan(""));
      if (!l.count(s + " needs") || m.verdict != l.at(s + " needs"))
        out << s << " verdict: message '" << m.verdict << "', diagnostics '"
            << (l.count(s + " needs") ? l.at(s + " needs") : "<missing>") << "'; ";
      if (m.link_level != level)
        out << s << " level: message " << m.link_level << ", diagnostics " << level << "; ";
      if (!m.header.frame_id.empty())
        out << s << " frame_id '" << m.header.frame_id << "'; ";
    }
    why = out.str();
    return why.empty();
  };
  EXPECT_TRUE(waitFor(agree, 20.0)) << why;
  std::lock_guard<std::mutex> lock(mutex);
  for (const std::string& s : sensors)
    if (latest.count(s))  // a live link: real numbers, not defaults
    {
      EXPECT_GT(latest.at(s).arrival_samples, 0u) << s;
      EXPECT_TRUE(std::isfinite(latest.at(s).delay_p50)) << s;
      EXPECT_FALSE(latest.at(s).verdict.empty()) << s;
    }
}

// Per-sensor live verdict: each sensor's own window and the joint test of analyze. The test
// publishes straight to the estimator at 500 Hz, dropping each sensor's sample itself (fixed seed).
// 4000-step windows: a Wilson half-width of 1.96 sqrt(0.21 / 4000) = 0.014, so 0.3 + 0.014 stays
// below the critical 1/3 (ERROR even at the high ends), and at 0.6 each the low ends 0.585 give
// 2.25 * 0.415^2 = 0.39 < 1 (OK).
TEST(EstimatorGraph, StabilityVerdictPerSensor)
{
  ros::NodeHandle nh;
  ros::Publisher pa = nh.advertise<Measurement>("kfio/measurement/a", 10000);
  ros::Publisher pb = nh.advertise<Measurement>("kfio/measurement/b", 10000);
  ASSERT_TRUE(waitFor([&] { return pa.getNumSubscribers() > 0 && pb.getNumSubscribers() > 0; }, 20.0));
  DiagnosticsProbe link(nh, "link stability");
  std::atomic<double> rate{0.3};
  ne::Rng rng(31);
  const ros::Time t0 = ros::Time::now();
  PeriodicFeeder feeder(0.002,
                        [&](long k)
                        {
                          for (int s = 0; s < 2; ++s)
                          {
                            if (!rng.bernoulli(rate))
                              continue;
                            Measurement m;
                            m.header.stamp = t0 + ros::Duration(0.002 * k);
                            m.step = static_cast<std::uint64_t>(k);
                            m.sensor = s == 0 ? "a" : "b";
                            m.y = {0.0};
                            (s == 0 ? pa : pb).publish(m);
                          }
                        });
  ASSERT_TRUE(waitFor([&] { return link.levelIs(diagnostic_msgs::DiagnosticStatus::ERROR); }, 60.0))
      << "last: " << link.lastMessage();
  EXPECT_NE(link.lastMessage().find("unbounded"), std::string::npos) << link.lastMessage();
  EXPECT_FALSE(link.text("a arrival rate").empty());
  EXPECT_FALSE(link.text("b arrival rate").empty());
  rate = 0.6;
  ASSERT_TRUE(waitFor([&] { return link.levelIs(diagnostic_msgs::DiagnosticStatus::OK); }, 60.0))
      << "last: " << link.lastMessage();
  expectLinkStatusAsDiagnosed(nh, "kfio/estimator", {"a", "b"});
}

// Sensor schedules (estimator_schedule.test): each PlantSimulator publishes exactly the sensors its
// schedule lets transmit (periodic: a at odd steps, b at even ones; random: the subset it also
// publishes on `schedule`), and the Estimator behind lossless links sees every due sample arrive:
// gamma = 1 at every step, a due arrival rate of exactly 1, and per-sensor live arrival rates of
// 1 over the due samples only (a sensor that was not scheduled is never counted as lost).
TEST(EstimatorGraph, ScheduledSensorsAreNotDueNorLost)
{
  ros::NodeHandle nh;
  struct Seen
  {
    std::mutex mutex;
    std::map<long, std::vector<bool>> sent, drawn;  // per step: which sensors published / were drawn
    std::map<long, bool> gamma;
  };
  std::map<std::string, Seen> seen;
  std::vector<ros::Subscriber> subs;
  const long T = 300;
  for (const std::string ns : {"periodic", "random"})
  {
    Seen& z = seen[ns];
    for (int s = 0; s < 2; ++s)
      subs.push_back(nh.subscribe<Measurement>(ns + "/measurement/" + (s == 0 ? "a" : "b"), 1000,
                                               [&z, s](const Measurement::ConstPtr& m)
                                               {
                                                 std::lock_guard<std::mutex> lock(z.mutex);
                                                 auto& v = z.sent[static_cast<long>(m->step)];
                                                 v.resize(2);
                                                 v[s] = true;
                                               }));
    subs.push_back(nh.subscribe<ne::ScheduleStep>(ns + "/schedule", 1000,
                                                  [&z](const ne::ScheduleStep::ConstPtr& m)
                                                  {
                                                    std::lock_guard<std::mutex> lock(z.mutex);
                                                    z.drawn[static_cast<long>(m->step)] = std::vector<bool>(
                                                        m->transmitting.begin(), m->transmitting.end());
                                                  }));
    subs.push_back(nh.subscribe<Estimate>(ns + "/estimate", 1000,
                                          [&z](const Estimate::ConstPtr& e)
                                          {
                                            std::lock_guard<std::mutex> lock(z.mutex);
                                            z.gamma[static_cast<long>(e->step)] = e->gamma;
                                          }));
  }
  ASSERT_TRUE(waitFor(
      [&]
      {
        for (const ros::Subscriber& sub : subs)
          if (sub.getNumPublishers() == 0)
            return false;
        return true;
      },
      30.0));
  DiagnosticsProbe periodic(nh, "periodic/estimator: estimator"), random(nh, "random/estimator: estimator");
  DiagnosticsProbe periodic_link(nh, "periodic/estimator: link stability");
  ros::Publisher start = nh.advertise<std_msgs::Empty>("/start_plants", 1, true);
  start.publish(std_msgs::Empty());
  // The plants run on; the estimators' statuses are read once both have taken T steps.
  ASSERT_TRUE(waitFor([&] { return periodic.get("steps") >= T && random.get("steps") >= T; }, 60.0))
      << periodic.get("steps") << " " << random.get("steps");
  for (const std::string ns : {"periodic", "random"})
  {
    const std::map<std::string, std::string> d = (ns == "periodic" ? periodic : random).snapshot();
    const long S = std::stol(d.at("steps"));
    Seen& z = seen[ns];
    ASSERT_TRUE(waitFor(
        [&]
        {
          std::lock_guard<std::mutex> lock(z.mutex);
          return z.drawn.size() >= static_cast<std::size_t>(S) && z.gamma.size() >= static_cast<std::size_t>(S);
        },
        10.0))
        << ns;
    std::lock_guard<std::mutex> lock(z.mutex);
    std::size_t due = 0, both = 0;
    for (long k = 1; k <= S; ++k)
    {
      ASSERT_EQ(z.gamma.count(k), 1u) << ns << " step " << k;
      EXPECT_TRUE(z.gamma[k]) << ns << " step " << k;
      const std::vector<bool> expect = ns == "periodic" ? std::vector<bool>{k % 2 == 1, k % 2 == 0} : z.drawn[k];
      EXPECT_EQ(z.drawn[k], expect) << ns << " step " << k;
      EXPECT_EQ(z.sent[k], expect) << ns << " step " << k;
      due += (expect[0] ? 1 : 0) + (expect[1] ? 1 : 0);
      both += k <= T && expect[0] && expect[1] ? 1 : 0;
    }
    EXPECT_EQ(std::stod(d.at("due samples")), static_cast<double>(due)) << ns;
    EXPECT_EQ(std::stod(d.at("due arrival rate")), 1.0) << ns;
    EXPECT_EQ(std::stod(d.at("unscheduled measurements")), 0.0) << ns;
    if (ns == "random")
    {
      EXPECT_EQ(std::stod(d.at("steps without schedule")), 0.0);
      // The subsets are drawn i.i.d. with probabilities 0.4 / 0.4 / 0.2: both sensors at about 60
      // of the first 300 steps (binomial sd sqrt(300 * 0.2 * 0.8) = 6.9; +-28 is 4 sd).
      EXPECT_NEAR(static_cast<double>(both), 60.0, 28.0);
    }
  }
  // The live windows hold the due samples only, all arrived (without the schedule each link
  // would read 0.5).
  ASSERT_TRUE(waitFor([&] { return periodic_link.text("a arrival rate").rfind("1 [", 0) == 0; }, 10.0))
      << periodic_link.text("a arrival rate");
  EXPECT_EQ(periodic_link.text("b arrival rate").rfind("1 [", 0), 0u) << periodic_link.text("b arrival rate");
}

// Standard types at mixed rates (estimator_standard_inputs.test): Odometry every step, Imu every
// 5th and NavSatFix every 25th (with its own covariance: covariance: message), stamped on the grid. Every step is estimated as soon as the
// sensors due at it are in hand; the estimates equal the filter stepped offline on the selected
// fields (the fix converted about the pinned datum) to 1e-12; every due sample arrived (a 2 Hz
// GNSS that delivers every fix shows an arrival rate of 1, not 0.04), and the datum is latched.
TEST(EstimatorGraph, StandardTypesAtMixedRates)
{
  ros::NodeHandle nh;
  const Params p = params();
  const ne::Model model = ne::loadModel(p.model);
  ros::Publisher odom = nh.advertise<nav_msgs::Odometry>("/odom", 1000);
  ros::Publisher imu = nh.advertise<sensor_msgs::Imu>("/imu", 1000);
  ros::Publisher fix = nh.advertise<sensor_msgs::NavSatFix>("/fix", 1000);
  Collector<Estimate> est(nh, "robot/estimate");
  Collector<sensor_msgs::NavSatFix> datum(nh, "robot/estimator/datum");
  Collector<nav_msgs::Odometry> filtered(nh, "robot/odometry/filtered");
  ASSERT_TRUE(waitFor(
      [&]
      {
        return odom.getNumSubscribers() > 0 && imu.getNumSubscribers() > 0 && fix.getNumSubscribers() > 0 &&
               publishersDeliverHere(est.sub) && publishersDeliverHere(datum.sub) &&
               publishersDeliverHere(filtered.sub);
      },
      20.0));
  DiagnosticsProbe diag(nh, "robot/estimator: estimator"), link(nh, "robot/estimator: link stability");
  const ne::LocalEnu enu(48.137, 11.575, 520.0);
  const int N = 150;
  std::vector<Eigen::VectorXd> y(N + 1, Eigen::VectorXd::Constant(5, std::nan("")));
  std::vector<Eigen::MatrixXd> R(N + 1);
  auto truth = [](long k)
  { return Eigen::Vector3d(3.0 * std::sin(0.05 * k), 2.0 * std::cos(0.03 * k), 0.01 * k - 0.5); };
  // Values published by the feeder thread, written for step k before k is published.
  std::mutex mutex;
  const ros::Time t0 = ros::Time::now() + ros::Duration(0.1);
  std::optional<nav_msgs::Odometry> previous;
  PeriodicFeeder feeder(0.02, [&](long k) {  // runs on past N, so every due sample keeps arriving
    const ros::Time stamp = t0 + ros::Duration(0.02 * (k - 1));
    const Eigen::Vector3d x = truth(k);
    Eigen::VectorXd row = Eigen::VectorXd::Constant(5, std::nan(""));
    nav_msgs::Odometry o;
    o.header.stamp = stamp;
    o.header.frame_id = "odom";
    o.pose.pose.position.x = x(0) + 0.01 * std::sin(7.0 * k);
    o.pose.pose.position.y = x(1) - 0.01 * std::cos(5.0 * k);
    o.pose.pose.orientation.w = 1.0;
    row(0) = o.pose.pose.position.x;
    row(1) = o.pose.pose.position.y;
    sensor_msgs::Imu i;
    i.header.stamp = stamp;
    tf2::Quaternion q;
    q.setRPY(0.0, 0.0, x(2));
    i.orientation.x = q.x();
    i.orientation.y = q.y();
    i.orientation.z = q.z();
    i.orientation.w = q.w();
    sensor_msgs::NavSatFix f;
    f.header.stamp = stamp;
    f.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
    const Eigen::Vector3d lla = enu.reverse(Eigen::Vector3d(x(0) + 0.5, x(1) - 0.5, 0.0));
    f.latitude = lla(0);
    f.longitude = lla(1);
    f.altitude = lla(2);
    // covariance: message: a fix's own ENU covariance, changing from fix to fix.
    const double var_e = 1.0 + 0.1 * static_cast<double>(k % 7), var_n = 2.0 + 0.05 * static_cast<double>(k % 5);
    f.position_covariance = {var_e, 0.3, 0, 0.3, var_n, 0, 0, 0, 9.0};
    f.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_KNOWN;
    const bool with_imu = (k - 1) % 5 == 0, with_fix = (k - 1) % 25 == 0;
    if (with_imu)
    {
      double roll, pitch, yaw;
      tf2::Matrix3x3(q).getRPY(roll, pitch, yaw);
      row(2) = yaw;
    }
    Eigen::MatrixXd Rk;
    if (with_fix)
    {
      const Eigen::Vector3d e = enu.forward(f.latitude, f.longitude, f.altitude);  // what the estimator computes
      row(3) = e(0);
      row(4) = e(1);
      Rk = model.R;  // the model's R with the fix's block (no cross-terms: the model has none)
      Rk.block(3, 3, 2, 2) << var_e, 0.3, 0.3, var_n;
    }
    if (k <= N)
    {
      std::lock_guard<std::mutex> lock(mutex);
      y[k] = row;
      R[k] = Rk;
    }
    // Odometry (due at every step) leaves one tick after the slow sensors of its step, so that a
    // step is never complete before them: a slow sensor's phase is unknown until its first sample.
    if (with_imu)
      imu.publish(i);
    if (with_fix)
      fix.publish(f);
    if (previous)
      odom.publish(*previous);
    previous = o;
  });
  ASSERT_TRUE(waitFor([&] { return diag.get("steps") >= N; }, 30.0)) << diag.get("steps");
  const std::map<long, Estimate> got = byStep(est);
  std::lock_guard<std::mutex> lock(mutex);
  expectKfioOffline(
      model, got, N, [&](long k) { return y[k]; }, noInput, [&](long k) { return R[k]; });
  // odometry/filtered: the same estimates, state_mapping {x: 0, y: 1, yaw: 2}, REP-105 frames.
  {
    std::lock_guard<std::mutex> fl(filtered.mutex);
    ASSERT_GE(filtered.msgs.size(), static_cast<std::size_t>(N));
    for (const nav_msgs::Odometry& o : filtered.msgs)
    {
      const long k = std::lround((o.header.stamp - got.begin()->second.header.stamp).toSec() / 0.02) + 1;
      if (k > N)
        continue;
      const Estimate& e = got.at(k);
      EXPECT_EQ(o.header.frame_id, "odom");  // world_frame
      EXPECT_EQ(o.child_frame_id, "base_link");
      EXPECT_EQ(o.pose.pose.position.x, e.state[0]) << k;
      EXPECT_EQ(o.pose.pose.position.y, e.state[1]) << k;
      EXPECT_NEAR(2.0 * std::atan2(o.pose.pose.orientation.z, o.pose.pose.orientation.w), e.state[2], 1e-12) << k;
      EXPECT_EQ(o.pose.covariance[0], e.covariance[0]) << k;  // var x
      EXPECT_EQ(o.pose.covariance[5], e.covariance[2]) << k;  // cov(x, yaw)
      EXPECT_EQ(o.pose.covariance[14], 1e6) << k;             // z: not estimated
    }
  }
  // Every due sample arrived: the slow sensors' windows hold their own samples only.
  const std::map<std::string, std::string> d = diag.snapshot();
  EXPECT_EQ(std::stod(d.at("due arrival rate")), 1.0);
  EXPECT_EQ(std::stod(d.at("rejected")), 0.0);
  // Stamps exactly on the grid (t0 + 0.02 (k - 1), anchored on the first): offsets of rounding only.
  EXPECT_LT(std::stod(d.at("stamp offset max (s)")), 1e-6);
  EXPECT_TRUE(waitFor([&] { return link.text("gps arrival rate").rfind("1 [", 0) == 0; }, 10.0))
      << link.text("gps arrival rate");
  EXPECT_EQ(link.text("imu arrival rate").rfind("1 [", 0), 0u) << link.text("imu arrival rate");
  EXPECT_EQ(link.text("odom arrival rate").rfind("1 [", 0), 0u) << link.text("odom arrival rate");
  ASSERT_TRUE(waitFor([&] { return datum.size() >= 1; }, 5.0));
  std::lock_guard<std::mutex> dl(datum.mutex);
  EXPECT_DOUBLE_EQ(datum.msgs.back().latitude, 48.137);
  EXPECT_DOUBLE_EQ(datum.msgs.back().longitude, 11.575);
}

// transport: udp (estimator_transport.test): the test node's odometry (roscpp) comes over UDPROS;
// the IMU of `rostopic pub` (rospy, which cannot serve UDPROS) falls back to TCPROS, and the
// Estimator and the LossyChannel reading it each say so once in the log (not again at the next
// check of their connections) and in their diagnostics (WARN, naming the input and the
// publisher); the tcp input says tcp. Every input's messages arrive either way.
TEST(EstimatorGraph, UdpInputsAndTheirFallback)
{
  ros::NodeHandle nh;
  ros::Publisher odom = nh.advertise<nav_msgs::Odometry>("/odom", 1000);
  ros::Publisher fix = nh.advertise<sensor_msgs::NavSatFix>("/fix", 1000);
  std::mutex log_mutex;
  std::map<std::string, int> told;  // fallback warnings by the nodelet that logged them
  ros::Subscriber rosout = nh.subscribe<rosgraph_msgs::Log>(
      "/rosout", 1000,
      [&](const rosgraph_msgs::Log::ConstPtr& m)
      {
        if (m->msg.find("transport udp, but the connection from") == std::string::npos)
          return;
        std::lock_guard<std::mutex> lock(log_mutex);
        ++told[m->msg.find("sensor 'imu' (/imu)") != std::string::npos         ? "estimator imu"
               : m->msg.find("LossyChannel input (/imu)") != std::string::npos ? "channel"
                                                                               : m->msg];
      });
  auto toldCount = [&](const std::string& who)
  {
    std::lock_guard<std::mutex> lock(log_mutex);
    return told.count(who) ? told.at(who) : 0;
  };
  ASSERT_TRUE(waitFor([&] { return odom.getNumSubscribers() > 0 && fix.getNumSubscribers() > 0; }, 20.0));
  DiagnosticsProbe diag(nh, "transport/estimator: estimator"), channel(nh, "transport/imu_link: input transport");
  const ne::LocalEnu enu(48.137, 11.575, 520.0);
  const ros::Time t0 = ros::Time::now();
  PeriodicFeeder feeder(0.02,
                        [&](long k)
                        {
                          const ros::Time stamp = t0 + ros::Duration(0.02 * static_cast<double>(k));
                          nav_msgs::Odometry o;
                          o.header.stamp = stamp;
                          o.header.frame_id = "odom";
                          o.pose.pose.position.x = 0.01 * static_cast<double>(k);
                          o.pose.pose.orientation.w = 1.0;
                          odom.publish(o);
                          if (k % 25 == 0)
                          {
                            sensor_msgs::NavSatFix f;
                            f.header.stamp = stamp;
                            f.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
                            const Eigen::Vector3d lla =
                                enu.reverse(Eigen::Vector3d(0.01 * static_cast<double>(k), 0.0, 0.0));
                            f.latitude = lla(0);
                            f.longitude = lla(1);
                            f.altitude = lla(2);
                            fix.publish(f);
                          }
                        });
  // The Estimator: udp from roscpp is UDPROS, udp from rospy fell back, tcp is tcp (TCP_NODELAY off).
  ASSERT_TRUE(waitFor(
      [&]
      {
        return diag.text("odom transport") == "udp: UDPROS from 1 publisher" &&
               diag.text("imu transport").rfind("udp: TCPROS fallback from http://", 0) == 0;
      },
      30.0))
      << diag.text("odom transport") << " | " << diag.text("imu transport");
  EXPECT_NE(diag.text("imu transport")
                .find("(the publisher cannot serve UDPROS, e.g. rospy, or another subscription "
                      "of /imu in this process asked for TCPROS first)"),
            std::string::npos)
      << diag.text("imu transport");
  EXPECT_EQ(diag.text("gps transport"), "tcp (tcp_nodelay: false)");
  ASSERT_TRUE(waitFor(
      [&] { return diag.lastMessage().find("sensor 'imu' (/imu): udp fell back to TCPROS") != std::string::npos; },
      5.0))
      << diag.lastMessage();
  EXPECT_TRUE(diag.levelIs(diagnostic_msgs::DiagnosticStatus::WARN)) << diag.lastMessage();
  // The LossyChannel's input (~transport: udp) from the same rospy publisher.
  ASSERT_TRUE(waitFor([&] { return channel.levelIs(diagnostic_msgs::DiagnosticStatus::WARN); }, 20.0))
      << channel.lastMessage();
  EXPECT_EQ(channel.lastMessage(), "LossyChannel input (/imu): udp fell back to TCPROS");
  EXPECT_EQ(channel.text("transport").rfind("udp: TCPROS fallback from http://", 0), 0u) << channel.text("transport");
  // Said once each: still once after the next periodic check of the connections (every 10 s).
  ASSERT_TRUE(waitFor([&] { return toldCount("estimator imu") >= 1 && toldCount("channel") >= 1; }, 10.0));
  ros::WallDuration(12.0).sleep();
  EXPECT_EQ(toldCount("estimator imu"), 1);
  EXPECT_EQ(toldCount("channel"), 1);
  {
    std::lock_guard<std::mutex> lock(log_mutex);
    EXPECT_EQ(told.size(), 2u) << "an unexpected fallback warning: " << told.rbegin()->first;
  }
  // The data arrived over all three.
  const std::map<std::string, std::string> d = diag.snapshot();
  EXPECT_GT(std::stod(d.at("odom messages")), 500.0);
  EXPECT_GT(std::stod(d.at("imu messages")), 50.0);
  EXPECT_GT(std::stod(d.at("gps messages")), 10.0);
}

// Commands from /cmd_vel (estimator_cmd_vel.test): a geometry_msgs/Twist every 5th step, its
// linear.x as u; an unstamped command goes to the step nearest its arrival (published in the same
// tick as that step's measurement) and holds until the next one. The estimates equal kfio stepped
// offline with the held commands to 1e-12, and no step is without a command.
TEST(EstimatorGraph, TwistCommandsAreHeld)
{
  ros::NodeHandle nh;
  const Params p = params();
  const ne::Model model = ne::loadModel(p.model);
  ros::Publisher meas = nh.advertise<Measurement>("base/measurement", 1000);
  ros::Publisher cmd = nh.advertise<geometry_msgs::Twist>("/cmd_vel", 1000);
  Collector<Estimate> est(nh, "base/estimate");
  ASSERT_TRUE(waitFor(
      [&] { return meas.getNumSubscribers() > 0 && cmd.getNumSubscribers() > 0 && publishersDeliverHere(est.sub); },
      20.0));
  DiagnosticsProbe diag(nh, "base/estimator: estimator");
  const int N = 30;
  auto speed = [](long k) { return 0.5 + 0.4 * std::sin(0.3 * static_cast<double>(k)); };
  auto value = [](long k) { return 0.02 * static_cast<double>(k) + 0.01 * std::cos(1.7 * static_cast<double>(k)); };
  // A Twist has no stamp: a command goes to the step nearest its arrival (+-100 ms at this model's
  // 0.2 s step). The feeder runs 90 ms ahead of the steps' stamps: a command sent with its step's
  // measurement arrives for that step even when a busy machine delays it by up to 190 ms.
  const ros::Time t0 = ros::Time::now() + ros::Duration(0.09);
  PeriodicFeeder feeder(0.2,
                        [&](long k)
                        {
                          if ((k - 1) % 5 == 0)
                          {
                            geometry_msgs::Twist t;
                            t.linear.x = speed(k);
                            cmd.publish(t);
                          }
                          Measurement m;
                          m.header.stamp = t0 + ros::Duration(0.2 * static_cast<double>(k - 1));
                          m.step = static_cast<std::uint64_t>(k);
                          m.y = {value(k)};
                          meas.publish(m);
                        });
  ASSERT_TRUE(waitFor([&] { return est.size() >= static_cast<std::size_t>(N); }, 30.0));
  expectKfioOffline(
      model, byStep(est), N, [&](long k) { return Eigen::VectorXd::Constant(1, value(k)); },
      [&](long k) { return Eigen::VectorXd::Constant(1, speed(k - (k - 1) % 5)); });  // the latest command, held
  EXPECT_EQ(diag.get("missing commands"), 0.0);

  // dynamic_reconfigure (base/estimator/reconfigure): a trace bound below trace(P) turns the
  // estimator status to WARN; the late policy and latency budget are taken.
  ros::ServiceClient dyn =
      nh.serviceClient<dynamic_reconfigure::Reconfigure>("base/estimator/reconfigure/set_parameters");
  ASSERT_TRUE(dyn.waitForExistence(ros::Duration(10.0)));
  dynamic_reconfigure::Reconfigure rc;
  dynamic_reconfigure::DoubleParameter bound, budget;
  bound.name = "trace_bound";
  bound.value = 1e-9;
  budget.name = "latency_budget";
  budget.value = 0.1;
  dynamic_reconfigure::StrParameter policy;
  policy.name = "late_policy";
  policy.value = "rewind";
  rc.request.config.doubles = {bound, budget};
  rc.request.config.strs = {policy};
  ASSERT_TRUE(dyn.call(rc));
  ASSERT_TRUE(waitFor([&] { return diag.lastMessage().find("above trace_bound 1e-09") != std::string::npos; }, 10.0))
      << diag.lastMessage();
  EXPECT_EQ(diag.get("trace bound"), 1e-9);
}

// A sensor topic advertised with another type than the sensor's (ROS would connect nothing and the
// sensor would just look silent): the estimator status says so, naming sensor, topic and types.
TEST(EstimatorGraph, WrongTypeOnASensorTopic)
{
  ros::NodeHandle nh;
  ros::Publisher wrong = nh.advertise<sensor_msgs::Imu>("/wheel_odom", 10);
  DiagnosticsProbe diag(nh, "wrong_type/estimator: estimator");
  ASSERT_TRUE(waitFor([&] { return diag.get("wrong type inputs") == 1.0; }, 20.0)) << diag.lastMessage();
  EXPECT_NE(diag.lastMessage().find("wrong message type: sensor 'y': /wheel_odom is sensor_msgs/Imu, expected "
                                    "nav_msgs/Odometry"),
            std::string::npos)
      << diag.lastMessage();
}

// Frames (tf2): a PointStamped in "cam" reaches the world frame "map" through the static
// transform map <- cam (x + 2): the estimates equal kfio on y = x_cam + 2 to 1e-12; a point in a
// frame without a transform is refused and counted, naming both frames.
TEST(EstimatorGraph, MeasurementsIntoTheWorldFrame)
{
  ros::NodeHandle nh;
  tf2_ros::StaticTransformBroadcaster statics;
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros::Time::now();
  t.header.frame_id = "map";
  t.child_frame_id = "cam";
  t.transform.translation.x = 2.0;
  t.transform.rotation.w = 1.0;
  statics.sendTransform(t);
  ros::Publisher pub = nh.advertise<geometry_msgs::PointStamped>("/cam_point", 100);
  Collector<Estimate> est(nh, "framed/estimate");
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() > 0 && publishersDeliverHere(est.sub); }, 20.0));
  ros::WallDuration(1.0).sleep();  // the estimator's tf listener receives the static transform
  DiagnosticsProbe diag(nh, "framed/estimator: estimator");
  const ne::Model model =
      ne::loadModel(ros::package::getPath("networked_estimation") + "/test/rostest/models/scalar_unstable.yaml");
  const int N = 10;
  const ros::Time t0 = ros::Time::now();
  for (int k = 1; k <= N; ++k)
  {
    geometry_msgs::PointStamped m;
    m.header.stamp = t0 + ros::Duration(0.05 * (k - 1));
    m.header.frame_id = "cam";
    m.point.x = 0.1 * k;
    pub.publish(m);
    ros::WallDuration(0.05).sleep();
  }
  ASSERT_TRUE(waitFor([&] { return est.size() >= static_cast<std::size_t>(N); }, 10.0));
  expectKfioOffline(
      model, byStep(est), N, [](long k) { return Eigen::VectorXd::Constant(1, 0.1 * static_cast<double>(k) + 2.0); },
      noInput);
  geometry_msgs::PointStamped lost;
  lost.header.stamp = t0 + ros::Duration(0.05 * N);
  lost.header.frame_id = "nowhere";
  pub.publish(lost);
  ASSERT_TRUE(waitFor([&] { return diag.get("rejected") == 1.0; }, 10.0)) << diag.get("rejected");
}

// tf when the estimate drives base_link (estimator_tf.test): the test plays the robot's odometry,
// odom -> base_link at x = 1.5; the Estimator (world_frame map) publishes map -> odom such that
// map -> base_link is the estimate, and base_link keeps its one parent, odom.
TEST(EstimatorGraph, MapToOdomNeverASecondParent)
{
  ros::NodeHandle nh;
  tf2_ros::Buffer buffer;
  tf2_ros::TransformListener listener(buffer);
  tf2_ros::TransformBroadcaster odom;
  ros::Publisher pub = nh.advertise<Measurement>("loc/measurement", 100);
  Collector<Estimate> est(nh, "loc/estimate");
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() > 0 && publishersDeliverHere(est.sub); }, 20.0));
  const ros::Time t0 = ros::Time::now();
  PeriodicFeeder feeder(0.05,
                        [&](long k)
                        {
                          geometry_msgs::TransformStamped t;
                          t.header.stamp = ros::Time::now();
                          t.header.frame_id = "odom";
                          t.child_frame_id = "base_link";
                          t.transform.translation.x = 1.5;
                          t.transform.rotation.w = 1.0;
                          odom.sendTransform(t);
                          Measurement m;
                          m.header.stamp = t0 + ros::Duration(0.05 * static_cast<double>(k - 1));
                          m.step = static_cast<std::uint64_t>(k);
                          m.y = {0.2};
                          pub.publish(m);
                        });
  ASSERT_TRUE(waitFor([&] { return buffer.canTransform("map", "odom", ros::Time(0)); }, 20.0));
  ros::WallDuration(1.0).sleep();
  for (int i = 0; i < 5; ++i)
  {
    const YAML::Node frames = YAML::Load(buffer.allFramesAsYAML());
    ASSERT_TRUE(frames["base_link"] && frames["base_link"]["parent"]);
    EXPECT_EQ(frames["base_link"]["parent"].as<std::string>(), "odom");
    const geometry_msgs::TransformStamped map_base = buffer.lookupTransform("map", "base_link", ros::Time(0));
    double x_est;
    {
      std::lock_guard<std::mutex> lock(est.mutex);
      x_est = est.msgs.back().state[0];
    }
    // The estimate moves little per step (y is constant): within 0.05 of the latest one.
    EXPECT_NEAR(map_base.transform.translation.x, x_est, 0.05);
    ros::WallDuration(0.2).sleep();
  }
}

// predict_to_current_time (estimator_predict.test): two ekfio Estimators of an omni_2d robot at
// 10 Hz on the same wheel odometry (vx = 1, vyaw = 0). `grid` (the default) publishes
// odometry/filtered once per step, stamped on the step grid; `now` publishes it at 50 Hz, each the
// last step's estimate predicted to the ROS time of the tick: stamped then (off the grid), its x the
// step's x + vx dt and its x variance f P f' + Q_xx dt, f the motion's row of x (f = [1 0 0 dt 0 0
// dt^2/2 0] with yaw, vy and the accelerations at 0, which the filter holds exactly here: every
// innovation is 0, the odometry saying vx = 1 and vyaw = 0 as x0 does),
// and the filter itself untouched (both Estimators' steps equal).
// Bounds, none of them tight timing: a message is at most 0.5 s old on receipt (it is stamped when
// published, and delivery on one machine takes milliseconds); 50 Hz against 10 Hz gives about 5
// predictions per step, of which we ask more than 1; the budget 0.3 s is 100 times the delivery of
// a message on one machine, so neither Estimator drops one as late.
TEST(EstimatorGraph, PredictToCurrentTime)
{
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<Measurement>("odom_measurement", 100);
  Collector<Estimate> now_steps(nh, "now/estimate"), grid_steps(nh, "grid/estimate");
  Collector<nav_msgs::Odometry> now_odom(nh, "now/odometry/filtered"), grid_odom(nh, "grid/odometry/filtered");
  ASSERT_TRUE(waitFor(
      [&]
      {
        // (both Estimators are in one manager: one subscriber connection)
        return pub.getNumSubscribers() > 0 && publishersDeliverHere(now_odom.sub) &&
               publishersDeliverHere(grid_odom.sub) && publishersDeliverHere(now_steps.sub) &&
               publishersDeliverHere(grid_steps.sub);
      },
      20.0));
  const double T = 0.1, q_xx = 1e-4;
  const ros::Time t0 = ros::Time::now();
  std::vector<Estimate> steps, grid;
  std::vector<nav_msgs::Odometry> predicted, on_grid;
  std::vector<ros::Time> received;
  {
    PeriodicFeeder feeder(T,
                          [&](long k)
                          {
                            Measurement m;
                            m.header.stamp = t0 + ros::Duration(T * static_cast<double>(k - 1));
                            m.step = static_cast<std::uint64_t>(k);
                            m.sensor = "odom";
                            m.y = {1.0, 0.0};
                            pub.publish(m);
                          });
    ASSERT_TRUE(waitFor([&] { return now_steps.size() >= 30 && grid_steps.size() >= 30; }, 60.0));
    // (copied while the steps still come: after the feeder stops, the predictions go on from the
    // last step, as robot_localization's do)
    std::lock_guard<std::mutex> l1(now_steps.mutex), l2(grid_steps.mutex), l3(now_odom.mutex), l4(grid_odom.mutex);
    steps = now_steps.msgs;
    grid = grid_steps.msgs;
    predicted = now_odom.msgs;
    received = now_odom.received_at;
    on_grid = grid_odom.msgs;
  }
  auto gridOffset = [&](const ros::Time& t)
  {
    const double r = (t - t0).toSec() / T;
    return std::fabs(r - std::round(r)) * T;
  };
  // The default: on the grid, one per step.
  ASSERT_FALSE(on_grid.empty());
  for (const nav_msgs::Odometry& o : on_grid)
    EXPECT_LT(gridOffset(o.header.stamp), 1e-6) << o.header.stamp;
  // The filter is not fed the predictions: the same steps as without them.
  std::size_t compared = 0;
  for (const Estimate& a : steps)
    for (const Estimate& b : grid)
      if (a.step == b.step)
      {
        ++compared;
        ASSERT_EQ(a.state.size(), b.state.size());
        for (std::size_t i = 0; i < a.state.size(); ++i)
          EXPECT_NEAR(a.state[i], b.state[i], 1e-12) << "step " << a.step << " state " << i;
      }
  EXPECT_GE(compared, 20u);
  // The predictions: stamped at their tick, more of them than steps, each from one of the steps.
  const ros::Time first = steps.front().header.stamp, last = steps.back().header.stamp;
  std::size_t within = 0, off_grid = 0;
  for (std::size_t i = 0; i < predicted.size(); ++i)
  {
    const nav_msgs::Odometry& o = predicted[i];
    const double age = (received[i] - o.header.stamp).toSec();
    EXPECT_GE(age, 0.0) << "stamped in the future: " << o.header.stamp;
    EXPECT_LE(age, 0.5) << o.header.stamp;
    if (o.header.stamp < first || o.header.stamp > last)
      continue;
    ++within;
    off_grid += gridOffset(o.header.stamp) > 1e-4 ? 1 : 0;
    // The step it was predicted from: the one whose x + vx dt and variance it carries.
    bool found = false;
    for (auto e = steps.rbegin(); e != steps.rend() && !found; ++e)
    {
      const double dt = (o.header.stamp - e->header.stamp).toSec();
      if (dt < 0.0)
        continue;
      const std::size_t n = e->state.size();
      auto P = [&](std::size_t r, std::size_t c) { return e->covariance[r * n + c]; };
      // x' = x + vx dt + ax dt^2 / 2 at yaw = vy = ay = 0: the row of F is [1 0 0 dt 0 0 h 0]
      const double h = 0.5 * dt * dt;
      const double var = P(0, 0) + dt * dt * P(3, 3) + h * h * P(6, 6) + 2.0 * dt * P(0, 3) + 2.0 * h * P(0, 6) +
                         2.0 * dt * h * P(3, 6) + q_xx * dt;
      found = std::fabs(o.pose.pose.position.x - (e->state[0] + e->state[3] * dt)) < 1e-6 &&
              std::fabs(o.twist.twist.linear.x - e->state[3]) < 1e-9 &&
              std::fabs(o.pose.covariance[0] - var) < 1e-6 * var;
    }
    EXPECT_TRUE(found) << "odometry at " << o.header.stamp << " (x " << o.pose.pose.position.x
                       << ") is no step's estimate predicted to its stamp";
  }
  EXPECT_GT(within, static_cast<std::size_t>((last - first).toSec() / T)) << within;
  EXPECT_GE(off_grid + 1, within) << off_grid << " of " << within << " off the step grid";
}

// Foreign input types: PointStamped (two 2-row position sensors) and Range (one scalar sensor)
// carry no step number; the estimator matches them to the nearest step by stamp. The estimates equal
// the offline filter on the same values. Bad parameters make an estimator's load fail, with a FATAL
// message naming the key (or the file).
TEST(EstimatorGraph, ForeignTypesAndBadParameters)
{
  const Params p = params();
  ros::NodeHandle nh;
  std::mutex log_mutex;
  std::vector<std::string> fatal;
  ros::Subscriber logs = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000,
                                                          [&](const rosgraph_msgs::Log::ConstPtr& l)
                                                          {
                                                            if (l->level == rosgraph_msgs::Log::FATAL)
                                                            {
                                                              std::lock_guard<std::mutex> lock(log_mutex);
                                                              fatal.push_back(l->msg);
                                                            }
                                                          });
  ros::Publisher gnss = nh.advertise<geometry_msgs::PointStamped>("point/measurement/gnss", 100);
  ros::Publisher camera = nh.advertise<geometry_msgs::PointStamped>("point/measurement/camera", 100);
  ros::Publisher range = nh.advertise<sensor_msgs::Range>("range/measurement", 100);
  Collector<Estimate> point_est(nh, "point/estimate"), range_est(nh, "range/estimate");
  ASSERT_TRUE(waitFor(
      [&]
      {
        return gnss.getNumSubscribers() > 0 && camera.getNumSubscribers() > 0 && range.getNumSubscribers() > 0 &&
               publishersDeliverHere(point_est.sub) && publishersDeliverHere(range_est.sub);
      },
      30.0));

  // Stamps on the model's grid (tracking_2d: 0.05 s) with up to +-5 ms of jitter; published at
  // their stamp so that each arrives before its deadline (stamp + 200 ms).
  const double T = 0.05;
  const long N = 40;
  ne::Rng rng(3);
  std::vector<std::vector<double>> y(N);
  std::vector<double> r(N);
  const ros::Time start = ros::Time::now() + ros::Duration(0.2);
  for (long k = 1; k <= N; ++k)
  {
    const ros::Time stamp = start + ros::Duration(k * T + rng.uniform(-0.005, 0.005));
    while (ros::Time::now() < stamp)
      ros::WallDuration(0.0005).sleep();
    geometry_msgs::PointStamped a, b;
    a.header.stamp = b.header.stamp = stamp;
    a.point.x = 0.1 * k + rng.normal();
    a.point.y = -0.05 * k + rng.normal();
    a.point.z = 99.0;  // beyond the sensor's two rows: ignored
    b.point.x = 0.1 * k + 0.1 * rng.normal();
    b.point.y = -0.05 * k + 0.1 * rng.normal();
    y[k - 1] = {a.point.x, a.point.y, b.point.x, b.point.y};
    gnss.publish(a);
    camera.publish(b);
    sensor_msgs::Range m;
    m.header.stamp = stamp;
    m.range = static_cast<float>(std::pow(1.1, k) + rng.normal());
    r[k - 1] = m.range;
    range.publish(m);
  }
  ASSERT_TRUE(waitFor(
      [&]
      { return point_est.size() >= static_cast<std::size_t>(N) && range_est.size() >= static_cast<std::size_t>(N); },
      10.0));
  const std::map<long, Estimate> P = byStep(point_est), R = byStep(range_est);
  const ne::Model tracking = ne::loadModel(p.model);
  const ne::EstimatorSettings kfio = ne::loadEstimatorSettings(p.settings);
  const auto ref = offline(tracking, kfio, y, std::vector<bool>(N, true));
  std::vector<std::vector<double>> ry;
  for (double v : r)
    ry.push_back({v});
  ros::NodeHandle pnh("~");
  std::string scalar_model;
  ASSERT_TRUE(pnh.getParam("scalar_model", scalar_model));
  const auto rref = offline(ne::loadModel(scalar_model), kfio, ry, std::vector<bool>(N, true));
  for (long k = 1; k <= N; ++k)
  {
    ASSERT_TRUE(P.count(k) && R.count(k)) << "step " << k;
    EXPECT_TRUE(P.at(k).gamma && R.at(k).gamma) << "step " << k;
    ASSERT_LE(maxDiff(P.at(k).state, ref[k - 1].state), 1e-12) << "PointStamped, step " << k;
    ASSERT_LE(maxDiff(R.at(k).state, rref[k - 1].state), 1e-12) << "Range, step " << k;
  }

  // The five refused estimators (their parameters are in the launch file), loaded through the
  // manager now that this test listens to /rosout: each load fails, with one FATAL naming the
  // problem. A FATAL logged before this test's /rosout connection to the manager was up is not
  // heard: such a load is made again (at most 6 times, 5 s each), so a busy machine that starts
  // this test late cannot hide a message, and a message that is never logged still fails.
  auto logged = [&](const std::string& what)
  {
    std::lock_guard<std::mutex> lock(log_mutex);
    for (const std::string& m : fatal)
      if (m.find("Estimator not started") != std::string::npos && m.find(what) != std::string::npos)
        return true;
    return false;
  };
  ros::ServiceClient load = nh.serviceClient<nodelet::NodeletLoad>("/manager/load_nodelet");
  ASSERT_TRUE(load.waitForExistence(ros::Duration(30.0)));
  const std::vector<std::pair<std::string, std::vector<std::string>>> refused = {
      {"/bad_policy/estimator", {"late_policy: expected drop or rewind, found 'later'"}},
      {"/bad_key/estimator", {"unknown parameter(s): latency_budjet"}},
      {"/bad_model/estimator", {"model: ", "no_such_model.yaml: cannot open file"}},
      {"/bad_mu/estimator", {"mu"}},
      {"/bad_datum/estimator", {"datum[0] (latitude): expected a finite number of degrees in [-90, 90], found nan"}}};
  for (const auto& r : refused)
  {
    auto heard = [&]
    {
      for (const std::string& what : r.second)
        if (!logged(what))
          return false;
      return true;
    };
    for (int attempt = 0; attempt < 6 && !heard(); ++attempt)
    {
      nodelet::NodeletLoad srv;
      srv.request.name = r.first;
      srv.request.type = "networked_estimation/Estimator";
      // (The manager's service fails the call, or answers success = false, when onInit throws.)
      if (load.call(srv))
        EXPECT_FALSE(srv.response.success) << r.first << " was loaded";
      waitFor(heard, 5.0);
    }
    EXPECT_TRUE(heard()) << r.first << ": no FATAL naming " << r.second.front();
  }
  for (const char* t :
       {"bad_policy/estimate", "bad_key/estimate", "bad_model/estimate", "bad_mu/estimate", "bad_datum/estimate"})
  {
    Collector<Estimate> none(nh, t);
    ros::WallDuration(0.2).sleep();
    EXPECT_EQ(none.sub.getNumPublishers(), 0u) << t;
  }
  // The refused estimators' loads failed (onInit threw): the manager holds only the two good ones.
  const std::vector<std::string> loaded = loadedNodelets("/manager");
  EXPECT_TRUE(isLoaded(loaded, "/point/estimator")) << loaded.size();
  EXPECT_TRUE(isLoaded(loaded, "/range/estimator")) << loaded.size();
  for (const char* n : {"/bad_policy/estimator", "/bad_key/estimator", "/bad_model/estimator", "/bad_mu/estimator",
                        "/bad_datum/estimator"})
    EXPECT_FALSE(isLoaded(loaded, n)) << n;
}

// A bag recorded with `rosbag record` from a running graph replays (`rosbag play --clock`) into a
// second estimator with identical results: same gamma_k, state and covariance at every step.
TEST(EstimatorGraph, RecordedBagReplaysIdentically)
{
  ros::NodeHandle nh;
  Collector<Estimate> live(nh, "live/estimate"), replayed(nh, "replayed/estimate");
  Collector<Measurement> delivered(nh, "measurement");
  Collector<PlantState> truth(nh, "plant/state");
  char dir_template[] = "/tmp/ne_graph_bag_XXXXXX";
  const std::string dir = mkdtemp(dir_template);
  const std::string bag = dir + "/demo.bag";
  // The recorder runs before the plant starts (start_delay 6 s).
  ASSERT_EQ(
      std::system(("rosbag record -q -O " + bag + " /measurement __name:=bag_recorder > " + dir + "/record.log 2>&1 &")
                      .c_str()),
      0);
  // The plant stops after step 300 and so does its clock: lost steps of the last 200 ms (the
  // budget, 10 steps) may never be finalised, live or replayed. Compared: steps up to the last
  // delivered one minus 11.
  ASSERT_TRUE(waitFor([&] { return truth.size() >= 301; }, 90.0)) << "plant states: " << truth.size();
  ros::WallDuration(1.0).sleep();  // the last deliveries
  ASSERT_EQ(std::system("rosnode kill /bag_recorder > /dev/null 2>&1"), 0);
  ASSERT_TRUE(waitFor([&] { return std::ifstream(bag).good(); }, 20.0)) << "no closed bag at " << bag;
  long last_step = 0;
  {
    std::lock_guard<std::mutex> lock(delivered.mutex);
    for (const Measurement& m : delivered.msgs)
      last_step = std::max(last_step, static_cast<long>(m.step));
  }
  ASSERT_GT(last_step, 250);
  const long K = last_step - 11;
  ASSERT_GE(live.size(), static_cast<std::size_t>(K));
  // --keep-alive: a player that exits at the end of the bag may take its last messages with it.
  ASSERT_EQ(std::system(("rosbag play -q --keep-alive --clock --hz=1000 -d 2 " + bag +
                         " /measurement:=/replay/measurement __name:=bag_player > " + dir + "/play.log 2>&1 &")
                            .c_str()),
            0);
  const bool replayed_all = waitFor([&] { return replayed.size() >= static_cast<std::size_t>(K); }, 40.0);
  std::system("rosnode kill /bag_player > /dev/null 2>&1");
  ASSERT_TRUE(replayed_all) << "replayed " << replayed.size() << " of " << K;
  const std::map<long, Estimate> L = byStep(live), R = byStep(replayed);
  long lost = 0;
  for (long k = 1; k <= K; ++k)
  {
    ASSERT_TRUE(L.count(k) && R.count(k)) << "step " << k;
    ASSERT_EQ(R.at(k).gamma, L.at(k).gamma) << "step " << k;
    ASSERT_EQ(R.at(k).state, L.at(k).state) << "step " << k;
    ASSERT_EQ(R.at(k).covariance, L.at(k).covariance) << "step " << k;
    lost += L.at(k).gamma ? 0 : 1;
  }
  // Gilbert-Elliott p = 0.1, r = 0.5: stationary loss 1/6, about 50 of 300; the comparison covers losses.
  EXPECT_GT(lost, 10);
}

// estimator_mixed_publishers.test: BenchSource in the Estimator's manager and this process publish
// to the same input topic at 2 kHz each: BenchSource the steps (the Estimator's period is its),
// this process messages naming another sensor (refused). The in-process publisher delivers
// holding roscpp's publication lock; this process's messages are refused in roscpp's receive
// thread, holding the subscription's lock and then the filter's. Were a step published under the
// filter's lock, the three would wait for each other and the estimates would stop.
TEST(EstimatorGraph, InProcessAndRemotePublishersOnOneTopic)
{
  ros::NodeHandle nh;
  std::mutex mutex;
  std::vector<double> arrivals;  // wall time of each estimate
  ros::Subscriber sub = nh.subscribe<Estimate>("/mixed/estimate", 10000,
                                               [&](const Estimate::ConstPtr&)
                                               {
                                                 std::lock_guard<std::mutex> lock(mutex);
                                                 arrivals.push_back(ros::WallTime::now().toSec());
                                               });
  ros::Publisher pub = nh.advertise<Measurement>("/mixed_measurement", 1000);
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() >= 1 && sub.getNumPublishers() >= 1; }, 20.0));
  // Both publishers at once: BenchSource publishes for 15 s from 2 s after its load; its steps are
  // estimated from then on.
  ASSERT_TRUE(waitFor(
      [&]
      {
        std::lock_guard<std::mutex> lock(mutex);
        return arrivals.size() > 100;
      },
      20.0));
  const double start = ros::WallTime::now().toSec();
  const double seconds = 8.0, period = 0.0005;
  long sent = 0;
  for (ros::WallTime next = ros::WallTime::now(); ros::WallTime::now().toSec() - start < seconds;)
  {
    auto m = boost::make_shared<Measurement>();
    m->header.stamp = ros::Time::now();
    m->step = static_cast<std::uint64_t>(sent + 1);
    m->sensor = "not_in_the_model";
    m->y.assign(1, static_cast<double>(sent % 7));
    pub.publish(m);
    ++sent;
    next += ros::WallDuration(period);
    const ros::WallDuration wait = next - ros::WallTime::now();
    if (wait > ros::WallDuration(0))
      wait.sleep();
  }
  const double end = ros::WallTime::now().toSec();
  // The in-process publisher ran throughout: it writes ~sent when its 15 s are over.
  EXPECT_FALSE(ros::param::has("/source/sent")) << "BenchSource finished while this process published";
  int source_sent = 0;
  ASSERT_TRUE(waitFor([&] { return ros::param::get("/source/sent", source_sent); }, 30.0))
      << "BenchSource did not finish";
  EXPECT_EQ(source_sent, 30000);
  EXPECT_GT(sent, 8000);
  // Still stepping afterwards: a stalled thread would not come back.
  std::size_t before = 0;
  {
    std::lock_guard<std::mutex> lock(mutex);
    before = arrivals.size();
  }
  ASSERT_TRUE(waitFor(
      [&]
      {
        std::lock_guard<std::mutex> lock(mutex);
        return arrivals.size() > before + 10;
      },
      10.0))
      << "no estimate after both publishers stopped";
  // And throughout: 2 kHz steps, so gaps of 0.5 ms; a second allows for a loaded machine.
  std::lock_guard<std::mutex> lock(mutex);
  double last = start, largest = 0.0;
  std::size_t during = 0;
  for (double t : arrivals)
    if (t >= start && t <= end)
    {
      largest = std::max(largest, t - last);
      last = t;
      ++during;
    }
  largest = std::max(largest, end - last);
  EXPECT_LT(largest, 1.0) << during << " estimates while both published";
  EXPECT_GT(during, 100u);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "estimator_graph_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int r = RUN_ALL_TESTS();
  spinner.stop();
  return r;
}
