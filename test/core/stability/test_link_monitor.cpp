// LinkMonitor (link_monitor.hpp): windowed counts, Wilson intervals and the classification.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/stability/joint_link_monitor.hpp"
#include "networked_estimation/stability/live_stability.hpp"
#include "networked_estimation/stability/link_monitor.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/kinematic_model.hpp"
#include "test_support.hpp"

#include <optional>

using namespace networked_estimation;

TEST(LinkMonitor, CountsMatchBruteForceOverTheWindow)
{
  Rng rng(5);
  const std::size_t w = 37;
  LinkMonitor mon(w);
  std::vector<bool> all;
  for (int k = 0; k < 500; ++k)
  {
    const bool a = rng.bernoulli(0.6);
    all.push_back(a);
    mon.add(a);
    const std::size_t n = std::min<std::size_t>(all.size(), w);
    std::size_t arr = 0, lost = 0, rec = 0, from_arrived = 0, failed = 0;
    for (std::size_t i = all.size() - n; i < all.size(); ++i)
    {
      arr += all[i] ? 1 : 0;
      if (i > all.size() - n && !all[i - 1])
      {
        ++lost;
        rec += all[i] ? 1 : 0;
      }
      if (i > all.size() - n && all[i - 1])
      {
        ++from_arrived;
        failed += all[i] ? 0 : 1;
      }
    }
    ASSERT_EQ(mon.samples(), n);
    ASSERT_EQ(mon.arrivals(), arr) << k;
    ASSERT_EQ(mon.lossTransitions(), lost) << k;
    ASSERT_EQ(mon.recoveries(), rec) << k;
    ASSERT_EQ(mon.arrivalTransitions(), from_arrived) << k;
    ASSERT_EQ(mon.failures(), failed) << k;
    const std::vector<bool> win = mon.window();
    ASSERT_TRUE(std::equal(win.begin(), win.end(), all.end() - static_cast<long>(n))) << k;
  }
  EXPECT_EQ(mon.total(), 500u);
  mon.clear();
  EXPECT_EQ(mon.samples(), 0u);
  EXPECT_THROW(LinkMonitor(1), std::invalid_argument);
}

TEST(LinkMonitor, WilsonInterval)
{
  // Textbook value: 8 of 10, z = 1.96 -> [0.4902, 0.9433].
  const RateEstimate e = wilsonInterval(8, 10, 1.96);
  EXPECT_NEAR(e.lower, 0.4902, 1e-4);
  EXPECT_NEAR(e.upper, 0.9433, 1e-4);
  EXPECT_TRUE(std::isnan(wilsonInterval(0, 0).value));
  EXPECT_EQ(wilsonInterval(0, 50).lower, 0.0);
}

TEST(LinkMonitor, CoverageOnMarkovChain)
{
  // Gilbert chain with recovery r = 0.4, failure p = 0.1: the stationary arrival rate is 0.8 and the
  // recovery rate 0.4. Over 200 disjoint windows of 2000 samples, a 95 % interval should miss the
  // true value in about 5 % of the windows; the arrival count is positively correlated (bursts), so
  // the nominal interval under-covers: the lag-1 correlation is 1 - p - r = 0.5, which inflates the
  // variance of the mean by (1 + 0.5) / (1 - 0.5) = 3, so the interval spans +-1.96 / sqrt(3) = +-1.13
  // true standard deviations: coverage about 74 %. We require >= 120 of 200 windows (the binomial
  // standard deviation is 6.2, so 120 is 5.8 sd below). The recovery transitions are i.i.d. given that
  // the previous sample was lost (Markov property): nominal 95 % coverage; we require >= 170 (85 %,
  // 6.5 binomial sd below 190). The failure transitions are likewise i.i.d. given that the previous
  // sample arrived: the same bound for the failure rate p = 0.1.
  Rng rng(11);
  bool arrived = true;
  int cover_a = 0, cover_r = 0, cover_p = 0;
  for (int win = 0; win < 200; ++win)
  {
    LinkMonitor mon(2000);
    for (int k = 0; k < 2000; ++k)
    {
      arrived = arrived ? !rng.bernoulli(0.1) : rng.bernoulli(0.4);
      mon.add(arrived);
    }
    const RateEstimate a = mon.arrivalRate(), r = mon.recoveryRate(), p = mon.failureRate();
    cover_a += (a.lower <= 0.8 && 0.8 <= a.upper) ? 1 : 0;
    cover_r += (r.lower <= 0.4 && 0.4 <= r.upper) ? 1 : 0;
    cover_p += (p.lower <= 0.1 && 0.1 <= p.upper) ? 1 : 0;
  }
  EXPECT_GE(cover_a, 120);
  EXPECT_GE(cover_r, 170);
  EXPECT_GE(cover_p, 170);
}

TEST(LinkMonitor, Classification)
{
  LinkThresholds t;
  t.necessary = 0.36;
  t.sufficient = 0.5;
  t.min_samples = 100;
  RateEstimate e = wilsonInterval(310, 1000);  // [0.282, 0.339] < 0.36
  LinkCondition s = classifyLink(e, t);
  EXPECT_EQ(s.level, LinkCondition::Level::ERROR);
  EXPECT_NE(s.message.find("unbounded"), std::string::npos);
  EXPECT_NE(s.message.find("0.31 < critical 0.36"), std::string::npos) << s.message;
  EXPECT_EQ(classifyLink(wilsonInterval(700, 1000), t).level, LinkCondition::Level::OK);
  const LinkCondition band = classifyLink(wilsonInterval(430, 1000), t);  // [0.399, 0.461]
  EXPECT_EQ(band.level, LinkCondition::Level::WARN);
  EXPECT_NE(band.message.find("undecided"), std::string::npos);
  const LinkCondition straddle = classifyLink(wilsonInterval(36, 100), t);
  EXPECT_EQ(straddle.level, LinkCondition::Level::WARN);
  EXPECT_NE(straddle.message.find("close"), std::string::npos);
  const LinkCondition few = classifyLink(wilsonInterval(1, 10), t);
  EXPECT_EQ(few.level, LinkCondition::Level::WARN);
  EXPECT_NE(few.message.find("not enough samples"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// JointLinkMonitor: one window per sensor and the joint verdict of the same core test as analyze.

namespace
{

Model scalarTwoSensors(double a)
{
  return test::scalarTwoSensorModel(a, "a", "b");
}

}  // namespace

// x_k = 1.5 x_{k-1} + w with two sensors y = x + v, each arriving with probability 0.3: the
// per-sensor critical rate is 1/3 (1.5^2 (1 - l)^2 < 1), so E[P] is unbounded, although "some
// sensor arrived" has rate 0.51 (what a single union window saw, and called OK). With 5000 samples
// the Wilson half-width is 1.96 sqrt(0.21 / 5000) = 0.013, so 0.3 + 0.013 < 1/3: ERROR. At 0.5 per
// sensor (1.5^2 * 0.25 = 0.56 < 1, interval +-0.014): OK. The point verdict equals analyze's at the
// same rates.
// With skipped steps (a sensor schedule), a transition is counted only between samples of
// consecutive steps: the same brute-force recount over random sequences with random gaps.
TEST(LinkMonitor, GapsBreakTransitionsAndEvictCorrectly)
{
  Rng rng(11);
  const std::size_t w = 23;
  LinkMonitor mon(w);
  std::vector<bool> all, follows;
  for (int k = 0; k < 800; ++k)
  {
    const bool a = rng.bernoulli(0.55), f = rng.bernoulli(0.7);
    all.push_back(a);
    follows.push_back(f);
    mon.add(a, f);
    const std::size_t n = std::min<std::size_t>(all.size(), w);
    std::size_t arr = 0, lost = 0, rec = 0, from_arrived = 0, failed = 0;
    for (std::size_t i = all.size() - n; i < all.size(); ++i)
    {
      arr += all[i] ? 1 : 0;
      if (i == all.size() - n || !follows[i])
        continue;
      if (!all[i - 1])
      {
        ++lost;
        rec += all[i] ? 1 : 0;
      }
      else
      {
        ++from_arrived;
        failed += all[i] ? 0 : 1;
      }
    }
    ASSERT_EQ(mon.arrivals(), arr) << k;
    ASSERT_EQ(mon.lossTransitions(), lost) << k;
    ASSERT_EQ(mon.recoveries(), rec) << k;
    ASSERT_EQ(mon.arrivalTransitions(), from_arrived) << k;
    ASSERT_EQ(mon.failures(), failed) << k;
  }
}

// A sensor that is not due (not scheduled) enters no window: on a lossless link with a periodic
// schedule it shows an arrival rate of exactly 1 over its due samples, never a loss.
TEST(JointLinkMonitor, NotDueIsNotALoss)
{
  const Model m = scalarTwoSensors(1.5);
  JointLinkMonitor mon(m, 1000, false, 10);
  for (int k = 1; k <= 300; ++k)
  {
    const bool first = k % 2 == 1;  // sensor 0 at odd steps, sensor 1 at even ones
    mon.add({first, !first}, {first, !first});
  }
  EXPECT_EQ(mon.sensor(0).samples(), 150u);
  EXPECT_EQ(mon.sensor(1).samples(), 150u);
  EXPECT_EQ(mon.sensor(0).arrivals(), 150u);
  EXPECT_EQ(mon.sensor(1).arrivals(), 150u);
  // Every due sample follows a skipped step: no transition is claimed across the gaps.
  EXPECT_EQ(mon.sensor(0).arrivalTransitions(), 0u);
  // Without the due flags the same stream reads as 50 % loss on each link.
  JointLinkMonitor naive(m, 1000, false, 10);
  for (int k = 1; k <= 300; ++k)
    naive.add({k % 2 == 1, k % 2 == 0});
  EXPECT_EQ(naive.sensor(0).arrivals(), 150u);
  EXPECT_EQ(naive.sensor(0).samples(), 300u);
  EXPECT_THROW(mon.add({true, true}, {true}), std::invalid_argument);
}

TEST(JointLinkMonitor, PerSensorRatesDecideAndUnionDoesNot)
{
  const Model m = scalarTwoSensors(1.5);
  for (double rate : {0.3, 0.5})
  {
    JointLinkMonitor mon(m, 5000, false, 100);
    LinkMonitor any(5000);
    Rng rng(17);
    for (int k = 0; k < 5000; ++k)
    {
      const bool a = rng.bernoulli(rate), b = rng.bernoulli(rate);
      mon.add({a, b});
      any.add(a || b);
    }
    const JointLinkStatus st = mon.evaluate();
    ASSERT_EQ(st.sensors.size(), 2u);
    EXPECT_NEAR(st.sensors[0].arrival.value, rate, 0.03);
    EXPECT_EQ(st.status.level, rate < 0.4 ? LinkCondition::Level::ERROR : LinkCondition::Level::OK)
        << st.status.message;
    if (rate < 0.4)
      EXPECT_GT(any.arrivalRate().lower, 0.45);  // the union rate looks healthy
    ChannelSettings ca, cb;
    ca.loss = 1.0 - st.sensors[0].arrival.value;
    cb.loss = 1.0 - st.sensors[1].arrival.value;
    const StabilityReport rep = analyzeStability(m, std::vector<std::optional<ChannelSettings>>{ca, cb});
    EXPECT_EQ(st.point.kind, rep.model.verdict.kind) << rep.model.verdict.reason;
  }
  JointLinkMonitor few(m, 500, false, 100);
  for (int k = 0; k < 50; ++k)
    few.add({true, false});
  EXPECT_EQ(few.evaluate().status.level, LinkCondition::Level::WARN);
  EXPECT_THROW(few.add({true}), std::invalid_argument);
}

// Markov links, nothing assumed: A = diag(2, -2), c = [1 1] (one sensor) with an on/off chain of
// failure rate p = 0.05 has a critical recovery rate of 0.860 (at p = 0.5 none would exist). The
// monitor estimates p and r from the sequence: r = 0.95 is OK and r = 0.6 ERROR. 40000 samples: with
// p = 0.05, about 40000 * 0.05 / (0.05 + r) losses, i.e. >= 2000 recovery trials: r's interval is
// +-0.02 at most, far from 0.860 on both sides.
TEST(JointLinkMonitor, MarkovLinksEstimatedNotAssumed)
{
  Model m;
  m.name = "diag";
  m.A = Eigen::Vector2d(2.0, -2.0).asDiagonal();
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = Eigen::MatrixXd::Identity(2, 2);
  m.C = Eigen::RowVector2d(1.0, 1.0);
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.sensors = {{"y", 0, 1}};
  m.x0 = Eigen::VectorXd::Zero(2);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.Bu = Eigen::MatrixXd(2, 0);
  validateModel(m, "diag");
  for (double r : {0.95, 0.6})
  {
    JointLinkMonitor mon(m, 40000, true, 200);
    Rng rng(23);
    bool arrived = true;
    for (int k = 0; k < 40000; ++k)
    {
      arrived = arrived ? !rng.bernoulli(0.05) : rng.bernoulli(r);
      mon.add({arrived});
    }
    const JointLinkStatus st = mon.evaluate();
    EXPECT_NEAR(st.sensors[0].failure.value, 0.05, 0.01);
    EXPECT_NEAR(st.sensors[0].recovery.value, r, 0.04);
    EXPECT_EQ(st.status.level, r > 0.86 ? LinkCondition::Level::OK : LinkCondition::Level::ERROR) << st.status.message;
  }
}

// ---------------------------------------------------------------------------------------------
// LiveStability: what the Estimator's link stability diagnostic reports.

namespace
{

std::string valueOf(const LiveStabilityReport& r, const std::string& key)
{
  for (const auto& kv : r.values)
    if (kv.first == key)
      return kv.second;
  return "<missing>";
}

}  // namespace

// One scalar sensor (x = 1.1 x + w, y = x + v) filtered by kfio at arrival rate 0.6: the joint
// verdict is OK (critical 0.1736), the critical rates are shown, Gan and Liu's excitation is
// reported, and their Theorem 1 holds along the filter's own covariances at every block (h = n = 1: 600; an
// inequality: no tolerance). With rseio the invariant does not apply, and says so.
TEST(LiveStability, SingleScalarSensorWithKfio)
{
  Model m = scalarTwoSensors(1.1);
  m.C = Eigen::MatrixXd::Ones(1, 1);
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.sensors = {{"y", 0, 1}};
  validateModel(m, "one");
  EstimatorSettings kfio;
  kfio.algorithm = Algorithm::KFIO;
  LiveStabilityOptions o;
  o.window = 500;
  LiveStability live(m, kfio, o);
  auto est = makeEstimator(m, kfio);
  Rng rng(5);
  Sample s;
  s.y.resize(1);
  for (int k = 0; k < 600; ++k)
  {
    s.gamma = rng.bernoulli(0.6);
    s.y(0) = s.gamma ? rng.normal() : std::nan("");
    est->step(s);
    live.add({s.gamma}, s.gamma, est->covariance(), false);
  }
  const LiveStabilityReport r = live.evaluate();
  EXPECT_EQ(r.status.level, LinkCondition::Level::OK) << r.status.message;
  EXPECT_NEAR(std::stod(valueOf(r, "critical (necessary)")), 1.0 - 1.0 / 1.21, 1e-6);
  EXPECT_NE(valueOf(r, "y Gan-Liu excitation"), "<missing>");
  // the rate this sensor needs: its own critical rate 1 - 1/1.1^2 = 0.1736 (to the bisection's
  // tolerance, 1e-4), with its estimate now
  const std::string need = valueOf(r, "y needs");
  ASSERT_EQ(need.rfind("arrival rate >= ", 0), 0u) << need;
  EXPECT_NEAR(std::stod(need.substr(16)), 1.0 - 1.0 / 1.21, 2e-4) << need;
  EXPECT_EQ(valueOf(r, "Gan-Liu Theorem 1 (runtime invariant)").rfind("holds over 600 blocks", 0), 0u)
      << valueOf(r, "Gan-Liu Theorem 1 (runtime invariant)");

  EstimatorSettings rseio;
  rseio.algorithm = Algorithm::RSEIO;
  rseio.mu = 0.8;
  LiveStability other(m, rseio, o);
  EXPECT_EQ(valueOf(other.evaluate(), "Gan-Liu Theorem 1 (runtime invariant)").rfind("not applicable", 0), 0u);
}

// Two sensors and Markov links: per-sensor p and r keys, no critical-rate keys (they are for one
// i.i.d. sensor), and the level of the joint monitor.
TEST(LiveStability, MarkovKeysPerSensor)
{
  const Model m = scalarTwoSensors(1.5);
  EstimatorSettings kfio;
  LiveStabilityOptions o;
  o.window = 2000;
  o.markov = true;
  LiveStability live(m, kfio, o);
  JointLinkMonitor joint(m, 2000, true, o.min_samples);
  Rng rng(9);
  bool a = true, b = true;
  for (int k = 0; k < 2000; ++k)
  {
    a = a ? !rng.bernoulli(0.1) : rng.bernoulli(0.5);
    b = b ? !rng.bernoulli(0.1) : rng.bernoulli(0.5);
    live.add({a, b}, a || b, Eigen::MatrixXd::Identity(1, 1), false);
    joint.add({a, b});
  }
  const LiveStabilityReport r = live.evaluate();
  EXPECT_EQ(valueOf(r, "a needs").rfind("recovery rate >= ", 0), 0u) << valueOf(r, "a needs");
  EXPECT_NE(valueOf(r, "a failure rate p"), "<missing>");
  EXPECT_NE(valueOf(r, "b recovery rate r"), "<missing>");
  EXPECT_EQ(valueOf(r, "critical (necessary)"), "<missing>");
  EXPECT_EQ(r.status.level, joint.evaluate().status.level);
}

// A robot's constant-velocity model (make_model: 2-D, 50 Hz, a position and a velocity sensor):
// with both links delivering everything the status is OK (the bad end of each interval is below 1,
// and on the unit circle any positive rate is stable), the position sensor needs any positive rate
// and the velocity sensor none; a position link that delivered nothing in the window is unstable at
// the estimate but WARN, not ERROR (its rate's interval reaches above 0, where any rate is stable). With the
// velocity sensor alone the positions are dead-reckoned: named, and the links are OK.
TEST(LiveStability, ConstantVelocityRobot)
{
  KinematicSpec spec;
  spec.motion = "constant_velocity";
  spec.dims = 2;
  spec.rate = 50.0;
  spec.density = 0.25;
  spec.sensors = {{"gnss", "position", 1.0}, {"odom", "velocity", 0.1}};
  const Model m = makeKinematicModel(spec);
  EstimatorSettings kfio;
  LiveStabilityOptions o;
  o.window = 1000;
  LiveStability live(m, kfio, o);
  for (int k = 0; k < 1000; ++k)
    live.add({true, true}, true, m.P0, false);
  const LiveStabilityReport r = live.evaluate();
  EXPECT_EQ(r.status.level, LinkCondition::Level::OK) << r.status.message;
  EXPECT_EQ(valueOf(r, "gnss needs").rfind("arrival rate > 0 (any positive rate", 0), 0u) << valueOf(r, "gnss needs");
  EXPECT_EQ(valueOf(r, "odom needs").rfind("arrival rate: any", 0), 0u) << valueOf(r, "odom needs");
  EXPECT_EQ(valueOf(r, "dead-reckoned"), "<missing>");

  LiveStability lost(m, kfio, o);
  for (int k = 0; k < 1000; ++k)
    lost.add({false, true}, true, m.P0, false);
  const LiveStabilityReport rl = lost.evaluate();
  EXPECT_EQ(rl.status.level, LinkCondition::Level::WARN) << rl.status.message;
  EXPECT_NE(rl.status.message.find("at the estimates unstable"), std::string::npos) << rl.status.message;
  // The status names what the silent link alone kept bounded (odom still delivers: not named).
  EXPECT_NE(rl.status.message.find("sensor 'gnss' is below the rate it needs (arrival rate > 0"), std::string::npos)
      << rl.status.message;
  EXPECT_NE(rl.status.message.find(": x, y, which only it measures, are not bounded"), std::string::npos)
      << rl.status.message;
  EXPECT_EQ(rl.status.message.find("sensor 'odom'"), std::string::npos) << rl.status.message;
  EXPECT_EQ(r.status.message.find("below the rate it needs"), std::string::npos) << r.status.message;

  KinematicSpec vel = spec;
  vel.sensors = {{"odom", "velocity", 0.1}};
  const Model mv = makeKinematicModel(vel);
  LiveStability odom_only(mv, kfio, o);
  for (int k = 0; k < 1000; ++k)
    odom_only.add({k % 10 != 0}, k % 10 != 0, mv.P0, false);
  const LiveStabilityReport rv = odom_only.evaluate();
  // The level follows the links' verdict (dead reckoning is a robot's normal setup, not a link
  // problem); the message names the dead-reckoned states by their names.
  EXPECT_EQ(rv.status.level, LinkCondition::Level::OK) << rv.status.message;
  EXPECT_NE(valueOf(rv, "dead-reckoned").find("(1, 1) of x, y that"), std::string::npos)
      << valueOf(rv, "dead-reckoned");
  EXPECT_NE(rv.status.message.find("dead-reckoned: x, y grow regardless of the links"), std::string::npos)
      << rv.status.message;
  // What the odometry needs concerns the modes it observes (the velocities): any rate, not "none".
  EXPECT_EQ(valueOf(rv, "odom needs").rfind("arrival rate > 0", 0), 0u) << valueOf(rv, "odom needs");
}

// The cache: an evaluation with no step since the last one returns the same report (also through
// a copy, as the nodelet evaluates snapshots), and a new step is seen.
TEST(LiveStability, CacheFollowsTheWindows)
{
  const Model m = scalarTwoSensors(1.5);
  EstimatorSettings kfio;
  LiveStabilityOptions o;
  o.window = 200;
  o.min_samples = 10;
  LiveStability live(m, kfio, o);
  for (int k = 0; k < 200; ++k)
    live.add({true, k % 2 == 0}, true, Eigen::MatrixXd::Identity(1, 1), false);
  const LiveStabilityReport first = live.evaluate();
  const LiveStability snapshot(live);
  const LiveStabilityReport again = snapshot.evaluate();
  ASSERT_EQ(first.values.size(), again.values.size());
  for (std::size_t i = 0; i < first.values.size(); ++i)
    EXPECT_EQ(first.values[i], again.values[i]);
  for (int k = 0; k < 200; ++k)
    live.add({false, false}, false, Eigen::MatrixXd::Identity(1, 1), false);
  const LiveStabilityReport later = live.evaluate();
  EXPECT_NE(valueOf(later, "a arrival rate"), valueOf(first, "a arrival rate"));
  EXPECT_EQ(later.status.level, LinkCondition::Level::ERROR) << later.status.message;
  LiveStabilityOptions no_cache = o;
  no_cache.cache = false;
  LiveStability fresh(m, kfio, no_cache);
  for (int k = 0; k < 200; ++k)
    fresh.add({true, k % 2 == 0}, true, Eigen::MatrixXd::Identity(1, 1), false);
  for (int k = 0; k < 200; ++k)
    fresh.add({false, false}, false, Eigen::MatrixXd::Identity(1, 1), false);
  const LiveStabilityReport fr = fresh.evaluate();
  ASSERT_EQ(fr.values.size(), later.values.size());
  for (std::size_t i = 0; i < fr.values.size(); ++i)
    EXPECT_EQ(fr.values[i], later.values[i]);
}

// A built-in motion's live verdicts follow its linearisation (the nodelet rebuilds them at the
// estimate): relinearised() keeps the windows and computes the model's part for the new model, so
// it reports exactly what a monitor of that model fed the same arrivals reports; takeWindows()
// brings later arrivals over; both own their models.
TEST(LiveStability, RelinearisedKeepsTheWindows)
{
  EstimatorSettings kfio;
  LiveStabilityOptions o;
  o.window = 400;
  o.min_samples = 50;
  const Model unstable = scalarTwoSensors(1.5);
  LiveStability fed(unstable, kfio, o);
  std::unique_ptr<LiveStability> fresh;
  {
    const Model stable = scalarTwoSensors(0.9);  // gone before the copies are used
    fresh = std::make_unique<LiveStability>(stable, kfio, o);
  }
  Rng rng(5);
  std::vector<std::vector<bool>> arrivals;
  for (int k = 0; k < 600; ++k)
    arrivals.push_back({rng.bernoulli(0.2), rng.bernoulli(0.2)});  // 0.2 + 1.96 sqrt(0.16 / 300) < 1/3
  for (int k = 0; k < 300; ++k)
  {
    fed.add(arrivals[k], arrivals[k][0] || arrivals[k][1], unstable.P0, false);
    fresh->add(arrivals[k], arrivals[k][0] || arrivals[k][1], unstable.P0, false);
  }
  std::unique_ptr<LiveStability> local;
  {
    const Model stable = scalarTwoSensors(0.9);
    local = std::make_unique<LiveStability>(fed.relinearised(stable));
  }
  const auto values = [](const LiveStabilityReport& r)
  {
    std::string out = toString(r.status.level) + " " + r.status.message + "\n";
    for (const auto& kv : r.values)
      if (kv.first.find("Theorem 1") == std::string::npos)  // kfio's invariant along the fed model's own steps
        out += kv.first + " = " + kv.second + "\n";
    return out;
  };
  EXPECT_EQ(values(local->evaluate()), values(fresh->evaluate()));
  EXPECT_NE(values(local->evaluate()), values(fed.evaluate()));  // 1.5 at arrival 0.2 each: unbounded
  EXPECT_EQ(fed.evaluate().status.level, LinkCondition::Level::ERROR);
  EXPECT_EQ(local->evaluate().status.level, LinkCondition::Level::OK);
  for (int k = 300; k < 600; ++k)
  {
    fed.add(arrivals[k], arrivals[k][0] || arrivals[k][1], unstable.P0, false);
    fresh->add(arrivals[k], arrivals[k][0] || arrivals[k][1], unstable.P0, false);
  }
  const std::string before = values(local->evaluate());
  local->takeWindows(fed);
  EXPECT_EQ(values(local->evaluate()), values(fresh->evaluate()));
  EXPECT_NE(values(local->evaluate()), before);  // the new arrivals are seen (not the cached report)
  LiveStability other(test::scalarTwoSensorModel(0.9, "a", "c"), kfio, o);
  EXPECT_THROW(other.takeWindows(fed), std::invalid_argument);
}
