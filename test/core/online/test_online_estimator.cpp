// OnlineEstimator: the stream-side sample assembly of the Estimator nodelet (deadlines, late
// policies, duplicates, bad input), checked against the plain estimator stepped offline.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/simulation/simulator.hpp"
#include "test_support.hpp"

namespace ne = networked_estimation;
using ne::Offer;

namespace
{

const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A simulated stream of a model: y_k per step and the commands.
struct Stream
{
  std::vector<Eigen::VectorXd> y;  // index k-1
  std::vector<Eigen::VectorXd> u;
};

Stream simulate(const ne::Model& model, int steps, std::uint64_t seed)
{
  ne::PlantSimulator sim(model, seed);
  // Online = offline on the same data: the data need not lie above the rounding floor (the unstable
  // aoe plant crosses it near k = 110; these streams run to k = 300).
  sim.setStateLimit(std::numeric_limits<double>::infinity());
  Stream s;
  for (int k = 1; k <= steps; ++k)
  {
    const ne::SimulatedSample& x = sim.step();
    s.y.push_back(x.y);
    s.u.push_back(x.u);
  }
  return s;
}

/// Offline reference: the estimator stepped on y_k where `arrived[k-1][sensor]` is true.
std::vector<Eigen::VectorXd> offline(const ne::Model& model, const ne::EstimatorSettings& st, const Stream& s,
                                     const std::vector<std::vector<bool>>& arrived,
                                     std::vector<Eigen::MatrixXd>* P = nullptr)
{
  auto est = ne::makeEstimator(model, st);
  std::vector<Eigen::VectorXd> out;
  ne::Sample smp;
  for (std::size_t k = 0; k < s.y.size(); ++k)
  {
    smp.y = s.y[k];
    bool any = false;
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
    {
      const ne::Sensor& sn = model.sensors[i];
      if (!arrived[k][i])
        smp.y.segment(sn.offset, sn.size).setConstant(kNaN);
      any = any || arrived[k][i];
    }
    smp.gamma = any;
    smp.u = s.u[k];
    est->step(smp);
    out.push_back(est->state());
    if (P)
      P->push_back(est->covariance());
  }
  return out;
}

ne::Offer offerY(ne::OnlineEstimator& on, const ne::Model& model, const Stream& s, long k, std::size_t sensor = 0)
{
  const ne::Sensor& sn = model.sensors[sensor];
  Eigen::VectorXd block = s.y[k - 1].segment(sn.offset, sn.size);
  return on.offerMeasurement({k, sensor, block.data(), block.size()}).offer;
}

ne::EstimatorSettings settingsFor(ne::Algorithm a)
{
  ne::EstimatorSettings st;
  st.algorithm = a;
  st.mu = 0.9;
  st.has_control_link = true;
  st.recovery = 0.6;
  st.failure = 0.3;
  return st;
}

}  // namespace

TEST(Clone, IsIndependentAndIdenticalForEveryAlgorithm)
{
  const ne::Model model = ne::test::aoeModel();
  const Stream s = simulate(model, 40, 3);
  for (ne::Algorithm a : {ne::Algorithm::KF, ne::Algorithm::KFIO, ne::Algorithm::RSEIO, ne::Algorithm::AOE,
                          ne::Algorithm::OE, ne::Algorithm::ACK_KF})
  {
    auto est = ne::makeEstimator(model, settingsFor(a));
    ne::Sample smp;
    smp.nu = 1;
    for (int k = 0; k < 20; ++k)
    {
      smp.y = s.y[k];
      smp.gamma = k % 3 != 0;
      smp.u = s.u[k];
      est->step(smp);
    }
    auto copy = est->clone();
    EXPECT_EQ(copy->algorithm(), a);
    EXPECT_EQ(copy->steps(), est->steps());
    // The copy continues exactly like the original.
    for (int k = 20; k < 40; ++k)
    {
      smp.y = s.y[k];
      smp.gamma = k % 4 != 0;
      smp.u = s.u[k];
      est->step(smp);
      copy->step(smp);
      ASSERT_EQ(copy->state(), est->state()) << ne::toString(a) << " k " << k;
      ASSERT_EQ(copy->covariance(), est->covariance()) << ne::toString(a);
    }
    // Stepping the copy leaves the original alone.
    const Eigen::VectorXd before = est->state();
    copy->step(smp);
    EXPECT_EQ(est->state(), before);
    EXPECT_NE(copy->state(), before);
  }
}

TEST(OnlineEstimator, InOrderWithLossesEqualsOfflineForEveryAlgorithm)
{
  const ne::Model model = ne::test::aoeModel();
  const int T = 200;
  const Stream s = simulate(model, T, 11);
  ne::Rng rng(5);
  std::vector<std::vector<bool>> arrived(T, std::vector<bool>(1));
  for (auto& a : arrived)
    a[0] = rng.bernoulli(0.7);
  for (ne::Algorithm a :
       {ne::Algorithm::KF, ne::Algorithm::KFIO, ne::Algorithm::RSEIO, ne::Algorithm::AOE, ne::Algorithm::OE})
  {
    for (ne::LatePolicy lp : {ne::LatePolicy::DROP, ne::LatePolicy::REWIND})
    {
      ne::OnlineOptions o;
      o.late_policy = lp;
      o.history_length = 10;
      ne::OnlineEstimator on(model, settingsFor(a), o);
      on.start(1);
      std::vector<Eigen::MatrixXd> P;
      const auto ref = offline(model, settingsFor(a), s, arrived, &P);
      for (long k = 1; k <= T; ++k)
      {
        ASSERT_EQ(on.offerCommand({k, s.u[k - 1].data(), s.u[k - 1].size()}).offer, Offer::ACCEPTED);
        if (arrived[k - 1][0])
        {
          ASSERT_EQ(offerY(on, model, s, k), Offer::ACCEPTED);
        }
        on.process();
        ASSERT_EQ(on.lastGamma(), arrived[k - 1][0]);
        // Bit-for-bit: the same arithmetic on the same inputs.
        ASSERT_EQ(on.estimator().state(), ref[k - 1]) << ne::toString(a) << " k " << k;
        ASSERT_EQ(on.estimator().covariance(), P[k - 1]);
      }
      EXPECT_EQ(on.counters().processed, static_cast<std::uint64_t>(T));
      EXPECT_EQ(on.counters().missing_commands, 0u);
    }
  }
}

TEST(OnlineEstimator, OutOfOrderBeforeTheDeadlineIsTheSameAsInOrder)
{
  const ne::Model model = ne::test::zhouModel();
  const int T = 60;
  const Stream s = simulate(model, T, 2);
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  // Steps arrive in blocks of 3 in reverse order, each block before its first deadline.
  for (long b = 1; b <= T; b += 3)
  {
    for (long k = b + 2; k >= b; --k)
    {
      EXPECT_FALSE(on.nextComplete());  // step b is the last of its block to arrive
      ASSERT_EQ(offerY(on, model, s, k), Offer::ACCEPTED);
    }
    for (long k = b; k < b + 3; ++k)
    {
      EXPECT_TRUE(on.nextComplete());
      on.process();
    }
  }
  const std::vector<std::vector<bool>> all(T, std::vector<bool>(1, true));
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::KFIO), s, all).back());
  EXPECT_EQ(on.counters().arrivals, static_cast<std::uint64_t>(T));
}

TEST(OnlineEstimator, DuplicatesAreCountedAndIgnored)
{
  const ne::Model model = ne::test::zhouModel();
  const Stream s = simulate(model, 10, 2);
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  EXPECT_EQ(offerY(on, model, s, 1), Offer::ACCEPTED);
  // A second copy with another value must not replace the first.
  const double other = 1e6;
  EXPECT_EQ(on.offerMeasurement({1, 0, &other, 1}).offer, Offer::DUPLICATE);
  on.process();
  EXPECT_EQ(offerY(on, model, s, 1), Offer::DUPLICATE);  // after its step, still a duplicate
  EXPECT_EQ(on.counters().duplicates, 2u);
  const std::vector<std::vector<bool>> all(1, std::vector<bool>(1, true));
  Stream one{{s.y[0]}, {s.u[0]}};
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::KFIO), one, all).back());
}

TEST(OnlineEstimator, DropPolicyCountsLateDataAndLeavesItOut)
{
  const ne::Model model = ne::test::zhouModel();
  const int T = 100;
  const Stream s = simulate(model, T, 8);
  ne::OnlineOptions o;
  o.late_policy = ne::LatePolicy::DROP;
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::RSEIO), o);
  on.start(1);
  std::vector<std::vector<bool>> in_time(T, std::vector<bool>(1, true));
  for (long k = 1; k <= T; ++k)
  {
    const bool late = k % 5 == 0;
    if (!late)
    {
      ASSERT_EQ(offerY(on, model, s, k), Offer::ACCEPTED);
    }
    on.process();
    if (late)
    {
      in_time[k - 1][0] = false;
      ASSERT_EQ(offerY(on, model, s, k), Offer::LATE_DROPPED);
    }
  }
  EXPECT_EQ(on.counters().late_dropped, 20u);
  EXPECT_EQ(on.counters().rewinds, 0u);
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::RSEIO), s, in_time).back());
}

TEST(OnlineEstimator, RewindFusesLateDataWithinTheHistoryExactly)
{
  const ne::Model model = ne::test::aoeModel();
  const int T = 300;
  const Stream s = simulate(model, T, 21);
  ne::Rng rng(77);
  for (ne::Algorithm a : {ne::Algorithm::KFIO, ne::Algorithm::RSEIO, ne::Algorithm::AOE})
  {
    ne::OnlineOptions o;
    o.late_policy = ne::LatePolicy::REWIND;
    o.history_length = 8;
    ne::OnlineEstimator on(model, settingsFor(a), o);
    on.start(1);
    // Each y_k arrives after a random number of steps d in {0, ..., 12}; d = 0 is in time,
    // 1..8 is late within the history (fused), 9..12 is beyond it (dropped).
    std::vector<long> due(T + 1);
    std::vector<std::vector<long>> arrivals_at(T + 20);
    std::vector<std::vector<bool>> fused(T, std::vector<bool>(1, false));
    std::uint64_t expect_fused = 0, expect_dropped = 0;
    for (long k = 1; k <= T; ++k)
    {
      const long d = static_cast<long>(rng.uniform() * 13.0);  // 0..12
      arrivals_at[k + d].push_back(k);                         // delivered just before step k + d is processed
    }
    for (long k = 1; k <= T; ++k)
    {
      on.offerCommand({k, s.u[k - 1].data(), s.u[k - 1].size()});
      for (long j : arrivals_at[k])
      {
        const Offer r = offerY(on, model, s, j);
        if (j == k)
        {
          ASSERT_EQ(r, Offer::ACCEPTED);
        }
        else if (k - j <= 8)
        {
          ASSERT_EQ(r, Offer::LATE_FUSED) << "step " << j << " offered before " << k;
          ++expect_fused;
        }
        else
        {
          ASSERT_EQ(r, Offer::LATE_DROPPED);
          ++expect_dropped;
        }
        if (k - j <= 8)
          fused[j - 1][0] = true;
      }
      on.process();
      // The estimate of step k equals the offline filter on everything fused so far.
      std::vector<std::vector<bool>> sofar = fused;
      sofar.resize(static_cast<std::size_t>(k));
      Stream prefix{{s.y.begin(), s.y.begin() + k}, {s.u.begin(), s.u.begin() + k}};
      if (k % 37 == 0 || k == T)
      {
        const auto ref = offline(model, settingsFor(a), prefix, sofar);
        ASSERT_EQ(on.estimator().state(), ref.back()) << ne::toString(a) << " k " << k;
      }
    }
    EXPECT_EQ(on.counters().late_fused, expect_fused);
    EXPECT_EQ(on.counters().late_dropped, expect_dropped);
    EXPECT_EQ(on.counters().rewinds, expect_fused);
    EXPECT_GT(expect_fused, 100u);
    EXPECT_GT(expect_dropped, 50u);
  }
}

TEST(OnlineEstimator, MultiSensorPerSensorArrivals)
{
  ne::Rng rng(4);
  const ne::Model model = ne::test::randomModel(rng, 3, 3, {1, 2}, 0, 0);
  const int T = 80;
  const Stream s = simulate(model, T, 6);
  std::vector<std::vector<bool>> arrived(T, std::vector<bool>(2));
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  for (long k = 1; k <= T; ++k)
  {
    for (std::size_t i = 0; i < 2; ++i)
    {
      arrived[k - 1][i] = rng.bernoulli(0.6);
      if (arrived[k - 1][i])
      {
        ASSERT_EQ(offerY(on, model, s, k, i), Offer::ACCEPTED);
      }
    }
    on.process();
    EXPECT_EQ(on.lastSensorsReceived(), int(arrived[k - 1][0]) + int(arrived[k - 1][1]));
    ASSERT_EQ(on.lastArrived().size(), 2u);
    EXPECT_EQ(on.lastArrived()[0], bool(arrived[k - 1][0]));
    EXPECT_EQ(on.lastArrived()[1], bool(arrived[k - 1][1]));
  }
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::KFIO), s, arrived).back());
}

// A periodic schedule (sensor 0 at odd steps, sensor 1 at even steps) on lossless links: a step
// is complete as soon as its scheduled sensor is in hand, the sensor that was not scheduled is
// never due and never counted as lost, and the filter equals the offline one on the transmitted
// samples. A measurement of an unscheduled sensor is fused but counted.
TEST(OnlineEstimator, PeriodicScheduleNotScheduledIsNotDueNorLost)
{
  ne::Rng rng(8);
  ne::Model model = ne::test::randomModel(rng, 3, 3, {1, 2}, 0, 0);
  model.schedule.kind = ne::Schedule::Kind::PERIODIC;
  model.schedule.pattern = {{true, false}, {false, true}};
  const int T = 60;
  const Stream s = simulate(model, T, 3);
  std::vector<std::vector<bool>> sent(T, std::vector<bool>(2));
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  for (long k = 1; k <= T; ++k)
  {
    const std::size_t scheduled = k % 2 == 1 ? 0 : 1;
    EXPECT_FALSE(on.nextComplete());
    sent[k - 1][scheduled] = true;
    ASSERT_EQ(offerY(on, model, s, k, scheduled), Offer::ACCEPTED);
    EXPECT_TRUE(on.nextComplete()) << k;
    on.process();
    EXPECT_EQ(on.lastDue()[scheduled], true);
    EXPECT_EQ(on.lastDue()[1 - scheduled], false);
    EXPECT_EQ(on.lastArrived()[scheduled], true);
  }
  EXPECT_EQ(on.counters().due, static_cast<std::uint64_t>(T));
  EXPECT_EQ(on.counters().due_arrived, static_cast<std::uint64_t>(T));
  EXPECT_EQ(on.counters().unscheduled, 0u);
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::KFIO), s, sent).back());
  // A scheduled sample that is lost is a loss; an unscheduled one that arrives is counted.
  on.process();  // k = T + 1 (odd: sensor 0 due), nothing arrived
  EXPECT_EQ(on.counters().due, static_cast<std::uint64_t>(T + 1));
  EXPECT_EQ(on.counters().due_arrived, static_cast<std::uint64_t>(T));
  ASSERT_EQ(on.offerMeasurement({T + 2, 0, s.y[0].data(), 1}).offer, Offer::ACCEPTED);  // even: not scheduled
  EXPECT_EQ(on.counters().unscheduled, 1u);
  ne::OfferResult r = on.offerSchedule(T + 2, {true, false});
  EXPECT_EQ(r.offer, Offer::REJECTED);
  EXPECT_NE(r.reason.find("periodic one is known from the step"), std::string::npos) << r.reason;
}

// A random schedule: the draw is offered per step. Until it is in hand the step is not complete;
// with it, only the drawn sensors are due. A step processed without its draw counts a sensor as
// due only when its y_k arrived (counted as schedule_missing). Bad draws are rejected by name.
TEST(OnlineEstimator, RandomScheduleDrawIsOfferedAndChecked)
{
  ne::Rng rng(9);
  ne::Model model = ne::test::randomModel(rng, 3, 3, {1, 2}, 0, 0);
  model.schedule.kind = ne::Schedule::Kind::RANDOM;
  model.schedule.subsets = {{true, false}, {false, true}, {true, true}};
  model.schedule.transition = Eigen::MatrixXd::Constant(3, 3, 1.0 / 3.0);
  model.schedule.initial = Eigen::VectorXd::Constant(3, 1.0 / 3.0);
  const Stream s = simulate(model, 10, 3);
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  ASSERT_EQ(offerY(on, model, s, 1, 1), Offer::ACCEPTED);
  EXPECT_FALSE(on.nextComplete());  // the draw is not in hand
  ASSERT_EQ(on.offerSchedule(1, {false, true}).offer, Offer::ACCEPTED);
  EXPECT_TRUE(on.nextComplete());
  EXPECT_EQ(on.offerSchedule(1, {false, true}).offer, Offer::DUPLICATE);
  on.process();
  EXPECT_EQ(on.lastDue(), (std::vector<bool>{false, true}));
  ASSERT_EQ(on.offerSchedule(2, {true, true}).offer, Offer::ACCEPTED);
  ASSERT_EQ(offerY(on, model, s, 2, 0), Offer::ACCEPTED);
  EXPECT_FALSE(on.nextComplete());  // sensor 1 is due too
  on.process();                     // its deadline: sensor 1 lost
  EXPECT_EQ(on.counters().due, 3u);
  EXPECT_EQ(on.counters().due_arrived, 2u);
  ASSERT_EQ(offerY(on, model, s, 3, 0), Offer::ACCEPTED);
  on.process();  // no draw for step 3
  EXPECT_EQ(on.counters().schedule_missing, 1u);
  EXPECT_EQ(on.lastDue(), (std::vector<bool>{true, false}));
  auto reason = [&](ne::OfferResult r)
  {
    EXPECT_EQ(r.offer, Offer::REJECTED);
    return r.reason;
  };
  EXPECT_NE(reason(on.offerSchedule(4, {false, false})).find("[] is not one of the schedule's subsets"),
            std::string::npos);
  EXPECT_NE(reason(on.offerSchedule(4, {true})).find("expected 2 flags"), std::string::npos);
  EXPECT_NE(reason(on.offerSchedule(0, {true, true})).find("expected >= 1"), std::string::npos);
  EXPECT_EQ(on.offerSchedule(2, {true, true}).offer, Offer::LATE_DROPPED);
  ne::OnlineEstimator plain(ne::test::zhouModel(), settingsFor(ne::Algorithm::KFIO), {});
  plain.start(1);
  EXPECT_NE(reason(plain.offerSchedule(1, {true})).find("has no random schedule (none)"), std::string::npos);
}

// Mixed rates: sensor 1 at a quarter of the model's rate is due only every 4 steps, on the phase
// of its latest sample; a step waits only for the sensors due at it, and a missed slow sample
// is a loss of a due sample (not 3 of 4 steps lost). Before its first sample it is not due, but
// a step waits for it up to its deadline (any step may be its first: its phase is unknown).
TEST(OnlineEstimator, SlowerSensorIsDueOnlyAtItsOwnSteps)
{
  ne::Rng rng(12);
  const ne::Model model = ne::test::randomModel(rng, 3, 3, {1, 2}, 0, 0);
  ne::OnlineOptions o;
  o.rate_ratio = {1.0, 4.0};
  const int T = 40;
  const Stream s = simulate(model, T, 2);
  std::vector<std::vector<bool>> sent(T, std::vector<bool>(2));
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), o);
  on.start(1);
  for (long k = 1; k <= T; ++k)
  {
    sent[k - 1][0] = true;
    ASSERT_EQ(offerY(on, model, s, k, 0), Offer::ACCEPTED);
    const bool slow_step = k >= 3 && (k - 3) % 4 == 0;  // the slow sensor's phase: 3, 7, 11, ...
    const bool slow_sent = slow_step && k != 19;        // its sample of step 19 is lost
    // Complete without the slow sensor unless it is due; before its first sample (k = 3) never.
    EXPECT_EQ(on.nextComplete(), k > 3 && !slow_step) << k;
    if (slow_sent)
    {
      sent[k - 1][1] = true;
      ASSERT_EQ(offerY(on, model, s, k, 1), Offer::ACCEPTED);
    }
    EXPECT_TRUE(k == 19 || k < 3 || on.nextComplete()) << k;
    on.process();
    EXPECT_EQ(on.lastDue()[1], k >= 3 && slow_step) << k;
  }
  // Due: 40 fast samples and the slow ones at 3, 7, ..., 39 (10), of which 19 was lost.
  EXPECT_EQ(on.counters().due, 50u);
  EXPECT_EQ(on.counters().due_arrived, 49u);
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::KFIO), s, sent).back());
  ne::OnlineOptions bad;
  bad.rate_ratio = {1.0};
  EXPECT_THROW(ne::OnlineEstimator(model, settingsFor(ne::Algorithm::KFIO), bad), ne::ConfigError);
  bad.rate_ratio = {1.0, 0.5};
  EXPECT_THROW(ne::validateOnlineOptions(bad, "o"), ne::ConfigError);
}

// The late policy changed at runtime (dynamic_reconfigure): to rewind, the history starts at the
// change (a step taken before it stays as it was); back to drop, late data is dropped again.
TEST(OnlineEstimator, LatePolicyChangesAtRuntime)
{
  ne::Rng rng(2);
  const ne::Model model = ne::test::randomModel(rng, 2, 2, {1}, 0, 0);
  const int T = 20;
  const Stream s = simulate(model, T, 4);
  std::vector<std::vector<bool>> used(T, std::vector<bool>(1, true));
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  for (long k = 1; k <= T; ++k)
  {
    if (k == 10)
      on.setLatePolicy(ne::LatePolicy::REWIND);
    if (k == 16)
      on.setLatePolicy(ne::LatePolicy::DROP);
    if (k != 9 && k != 12 && k != 17)
      ASSERT_EQ(offerY(on, model, s, k), Offer::ACCEPTED);
    on.process();
    if (k == 10)
      EXPECT_EQ(offerY(on, model, s, 9), Offer::LATE_DROPPED);  // taken before the change
    if (k == 13)
      EXPECT_EQ(offerY(on, model, s, 12), Offer::LATE_FUSED);
    if (k == 18)
      EXPECT_EQ(offerY(on, model, s, 17), Offer::LATE_DROPPED);  // drop again
  }
  used[8][0] = used[16][0] = false;
  EXPECT_EQ(on.estimator().state(), offline(model, settingsFor(ne::Algorithm::KFIO), s, used).back());
}

TEST(OnlineEstimator, BadInputIsRejectedWithAReasonAndCounted)
{
  ne::Rng rng(4);
  const ne::Model model = ne::test::randomModel(rng, 2, 2, {2}, 0, 1);
  ne::OnlineOptions o;
  o.max_future_steps = 50;
  o.max_past_steps = 200;
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), o);
  const double y[2] = {1.0, 2.0};
  const double bad[2] = {1.0, kNaN};
  const double inf[2] = {std::numeric_limits<double>::infinity(), 0.0};
  auto reason = [&](ne::OfferResult r)
  {
    EXPECT_EQ(r.offer, Offer::REJECTED);
    return r.reason;
  };
  EXPECT_NE(reason(on.offerMeasurement({1, 0, y, 2})).find("not started"), std::string::npos);
  on.start(1);
  EXPECT_NE(reason(on.offerMeasurement({1, 0, y, 1})).find("expects 2 values, found 1"), std::string::npos);
  EXPECT_NE(reason(on.offerMeasurement({1, 0, bad, 2})).find("y[1]"), std::string::npos);
  EXPECT_NE(reason(on.offerMeasurement({1, 0, inf, 2})).find("not finite"), std::string::npos);
  EXPECT_NE(reason(on.offerMeasurement({1, 3, y, 2})).find("sensor index 3"), std::string::npos);
  EXPECT_NE(reason(on.offerMeasurement({0, 0, y, 2})).find("expected >= 1"), std::string::npos);
  EXPECT_NE(reason(on.offerMeasurement({51, 0, y, 2})).find("far future"), std::string::npos);
  EXPECT_EQ(on.offerMeasurement({50, 0, y, 2}).offer, Offer::ACCEPTED);
  EXPECT_NE(reason(on.offerCommand({1, y, 2})).find("u: expected 1 values, found 2"), std::string::npos);
  EXPECT_NE(reason(on.offerCommand({1, bad + 1, 1})).find("u[0]"), std::string::npos);
  for (int k = 0; k < 300; ++k)
    on.process();
  EXPECT_NE(reason(on.offerMeasurement({101, 0, y, 2})).find("far past"), std::string::npos);
  EXPECT_EQ(on.offerMeasurement({102, 0, y, 2}).offer, Offer::LATE_DROPPED);
  EXPECT_EQ(on.counters().rejected, 10u);  // the ten REJECTED offers above
  EXPECT_EQ(on.counters().missing_commands, 300u);
  EXPECT_TRUE(on.estimator().state().allFinite());

  ne::OnlineEstimator no_control(ne::test::zhouModel(), settingsFor(ne::Algorithm::KFIO), {});
  no_control.start(1);
  EXPECT_NE(reason(no_control.offerCommand({1, y, 1})).find("has no control input"), std::string::npos);
}

TEST(OnlineEstimator, OverflowResetsTheFilterInsteadOfPublishingNaN)
{
  ne::Model model = ne::test::zhouModel(0.0);
  model.uncertainty.clear();
  model.A = Eigen::Matrix2d::Identity() * 1e3;  // P grows by 1e6 per step: overflows in ~52 steps
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(1);
  for (int k = 0; k < 120; ++k)
  {
    on.process();  // nothing ever arrives
    ASSERT_TRUE(on.estimator().covariance().allFinite());
    ASSERT_TRUE(on.estimator().state().allFinite());
  }
  EXPECT_GE(on.counters().divergence_resets, 1u);
}

TEST(OnlineEstimator, ResetStartsOver)
{
  const ne::Model model = ne::test::zhouModel();
  const Stream s = simulate(model, 20, 2);
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  on.start(5);
  EXPECT_EQ(on.nextStep(), 5);
  offerY(on, model, s, 5);
  on.process();
  on.reset();
  EXPECT_FALSE(on.started());
  EXPECT_EQ(on.estimator().state(), model.x0);
  EXPECT_EQ(on.estimator().steps(), 0);
  EXPECT_EQ(on.counters().processed, 1u);  // counters count since construction
}

TEST(OnlineEstimator, OptionsAreValidated)
{
  ne::OnlineOptions o;
  o.history_length = 0;
  EXPECT_THROW(ne::validateOnlineOptions(o, "x"), ne::ConfigError);
  o = {};
  o.max_future_steps = 0;
  EXPECT_THROW(ne::validateOnlineOptions(o, "x"), ne::ConfigError);
  o = {};
  o.history_length = 500;
  o.max_past_steps = 100;
  try
  {
    ne::validateOnlineOptions(o, "est");
    FAIL();
  }
  catch (const ne::ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("max_past_steps"), std::string::npos);
  }
  EXPECT_EQ(ne::latePolicyFromString("rewind", "x"), ne::LatePolicy::REWIND);
  EXPECT_THROW(ne::latePolicyFromString("later", "x"), ne::ConfigError);
}

TEST(StepClock, StampsDeadlinesAndNearestStep)
{
  ne::StepClock c(0.01, 0.004);
  c.anchor(3, 100.03);
  EXPECT_NEAR(c.stamp(10), 100.10, 1e-12);
  EXPECT_NEAR(c.deadline(10), 100.104, 1e-12);
  EXPECT_EQ(c.stepAt(100.1049), 10);
  EXPECT_EQ(c.stepAt(100.0951), 10);
  EXPECT_EQ(c.stepAt(100.0949), 9);
}

TEST(PlantSimulator, StepAppliedUsesOnlyTheDeliveredCommand)
{
  const ne::Model model = ne::test::aoeModel();
  ne::PlantSimulator a(model, 9), b(model, 9);
  Eigen::VectorXd u(1);
  u << 2.0;
  const Eigen::VectorXd x_applied = a.stepApplied(&u).x;
  EXPECT_TRUE(a.stepApplied(&u).nu);
  const Eigen::VectorXd x_lost = b.stepApplied(nullptr).x;
  EXPECT_FALSE(b.stepApplied(nullptr).nu);
  // Same noise streams: the states differ by exactly Bu u.
  EXPECT_LT((x_applied - x_lost - model.Bu * u).norm(), 1e-12);
  Eigen::VectorXd wrong(2);
  EXPECT_THROW(a.stepApplied(&wrong), ne::InputError);
}

// A sensor's own R_k block (the message's covariance): the step's input is the model's R with that
// block replaced and its cross-blocks zero; the result equals the estimator stepped offline with
// that R_k, and a step without own blocks uses the model's R.
TEST(OnlineEstimator, OwnRBlocksMakeTheStepsR)
{
  ne::Rng rng(13);
  const ne::Model model = ne::test::randomModel(rng, 3, 3, {1, 2}, 0, 0);
  const int T = 40;
  const Stream s = simulate(model, T, 8);
  ne::OnlineEstimator on(model, settingsFor(ne::Algorithm::KFIO), {});
  auto ref = ne::makeEstimator(model, settingsFor(ne::Algorithm::KFIO));
  on.start(1);
  for (long k = 1; k <= T; ++k)
  {
    const bool own = k % 3 != 0;
    const Eigen::MatrixXd R1 = ne::test::randomSpd(rng, 2, 0.2, 3.0);
    Eigen::Matrix<double, 2, 2, Eigen::RowMajor> rm = R1;
    ASSERT_EQ(offerY(on, model, s, k, 0), Offer::ACCEPTED);
    ASSERT_EQ(on.offerMeasurement({k, 1, s.y[k - 1].data() + 1, 2, own ? rm.data() : nullptr}).offer, Offer::ACCEPTED);
    on.process();
    ne::Sample smp;
    smp.y = s.y[k - 1];
    if (own)
    {
      smp.R = model.R;
      smp.R.row(0).tail(2).setZero();
      smp.R.col(0).tail(2).setZero();
      smp.R.bottomRightCorner(2, 2) = R1;
    }
    ref->step(smp);
    ASSERT_EQ(on.estimator().state(), ref->state()) << k;
    ASSERT_EQ(on.estimator().covariance(), ref->covariance()) << k;
  }
}

// rejection_threshold, for every algorithm: a gross outlier of sensor 1 (+1e3) is not fused (the
// estimate equals the filter stepped without it), counts as not arrived and is counted; the
// ordinary samples pass (the threshold of 10 is far above their innovations: with y simulated by
// the model, d^2 is chi-square with 2 degrees of freedom, P(d > 10) = exp(-50)).
TEST(OnlineEstimator, RejectionThresholdForEveryAlgorithm)
{
  for (ne::Algorithm a :
       {ne::Algorithm::KF, ne::Algorithm::KFIO, ne::Algorithm::RSEIO, ne::Algorithm::AOE, ne::Algorithm::OE})
  {
    const ne::Model model = ne::test::aoeModel();  // control, two rows of y
    const int T = 60;
    const Stream s = simulate(model, T, 5);
    ne::OnlineOptions o;
    o.rejection_threshold = {10.0};
    ne::OnlineEstimator on(model, settingsFor(a), o);
    on.start(1);
    std::vector<std::vector<bool>> used(T, std::vector<bool>(1, true));
    for (long k = 1; k <= T; ++k)
    {
      on.offerCommand({k, s.u[k - 1].data(), s.u[k - 1].size()});
      Eigen::VectorXd y = s.y[k - 1];
      if (k == 30)
        y.array() += 1e3;
      ASSERT_EQ(on.offerMeasurement({k, 0, y.data(), y.size()}).offer, Offer::ACCEPTED);
      on.process();
      EXPECT_EQ(on.lastArrived()[0], k != 30) << ne::toString(a) << " k " << k;
    }
    used[29][0] = false;
    EXPECT_EQ(on.counters().gated, 1u) << ne::toString(a);
    EXPECT_EQ(on.counters().gated_per_sensor[0], 1u);
    EXPECT_EQ(on.counters().due_arrived, static_cast<std::uint64_t>(T - 1));
    const auto ref = offline(model, settingsFor(a), s, used);
    EXPECT_LT((on.estimator().state() - ref.back()).norm(), 1e-9 * (1.0 + ref.back().norm())) << ne::toString(a);
  }
  ne::OnlineOptions bad;
  bad.rejection_threshold = {0.0};
  EXPECT_THROW(ne::OnlineEstimator(ne::test::aoeModel(), settingsFor(ne::Algorithm::KFIO), bad), ne::ConfigError);
}

// The rejection threshold of aoe and oe gates on their own prior, the moments of the predicted
// mixture over the command's outcome (docs/algorithms.md 2.8), not on kfio's A x + Bu u. Scalar
// plant x_k = x_{k-1} + nu_k u_k + w_k, y = x + v, x0 = 0, P0 = 1/2, Q = 1/2, R = 1, a command
// link with P(nu = 1) = 1/2 at every step (q1 = q2 = 1/2), u_1 = 10: the mixture
// 1/2 N(0, 1) + 1/2 N(10, 1) has mean 5 and variance 1 + 1/4 * 10^2 = 26, so S = 27, where kfio's
// prior would have mean 10 and S = 2. A reading d sqrt(S) away from the mixture's mean is fused
// for d = 0 and 2.9 and refused for d = 3.1 (threshold 3); on kfio's prior the first two are 3.5
// and 7.1 of its sigmas away and would be refused.
TEST(OnlineEstimator, AoeAndOeGateOnTheMixturesPrior)
{
  ne::Model m;
  m.name = "scalar_command";
  m.period = 0.1;
  m.A = Eigen::MatrixXd::Identity(1, 1);
  m.B = Eigen::MatrixXd::Identity(1, 1);
  m.Q = Eigen::MatrixXd::Constant(1, 1, 0.5);
  m.Bu = Eigen::MatrixXd::Identity(1, 1);
  m.C = Eigen::MatrixXd::Identity(1, 1);
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.sensors.push_back({"y", 0, 1});
  m.x0 = Eigen::VectorXd::Zero(1);
  m.P0 = Eigen::MatrixXd::Constant(1, 1, 0.5);
  ne::validateModel(m, "test");
  ne::EstimatorSettings st;
  st.has_control_link = true;
  st.recovery = 0.5;
  st.failure = 0.5;
  ne::OnlineOptions o;
  o.rejection_threshold = {3.0};
  const double u = 10.0;
  const double mean = 0.5 * u, S = 0.5 + 0.5 + 0.25 * u * u + 1.0;
  for (ne::Algorithm a : {ne::Algorithm::AOE, ne::Algorithm::OE})
    for (const double d : {0.0, 2.9, 3.1})
    {
      st.algorithm = a;
      ne::OnlineEstimator on(m, st, o);
      on.start(1);
      on.offerCommand({1, &u, 1});
      const double y = mean + d * std::sqrt(S);
      ASSERT_EQ(on.offerMeasurement({1, 0, &y, 1}).offer, Offer::ACCEPTED);
      on.process();
      const bool refused = d > 3.0;
      EXPECT_EQ(on.counters().gated, refused ? 1u : 0u) << ne::toString(a) << " d " << d;
      EXPECT_EQ(static_cast<bool>(on.lastArrived()[0]), !refused) << ne::toString(a) << " d " << d;
      EXPECT_EQ(on.estimator().lastUpdated(), !refused) << ne::toString(a) << " d " << d;
    }
}
