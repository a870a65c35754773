// The Estimator's input side without ROS: the Timeline (which stamps are believed, anchors,
// restarts, the catch-up work bound) and the OnlineStream that joins it with the latency budget and
// the sample assembly. Time is simulated: ROS time and wall time advance in 1 ms ticks.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "networked_estimation/online/online_stream.hpp"
#include "networked_estimation/online/timeline.hpp"
#include "test_support.hpp"

namespace ne = networked_estimation;
using ne::Offer;
using V = ne::Timeline::Verdict;

namespace
{

constexpr double kT = 0.02;

bool has(const std::string& text, const std::string& part)
{
  return text.find(part) != std::string::npos;
}

ne::TimelineOptions timelineOptions()
{
  ne::TimelineOptions o;
  o.period = kT;
  o.max_ahead = 10.0;
  o.max_behind = 3.0;
  return o;
}

/// An OnlineStream on x_k = 0.9 x_{k-1} + w seen by sensors a and b at the model's rate (kfio),
/// recording every step it takes with its stamp.
struct Stream
{
  ne::OnlineStream s;
  std::vector<std::pair<long, double>> steps;  ///< (k, stamp_k)
  std::vector<std::string> restarts;

  explicit Stream(const ne::RuntimeSettings& rt = ne::RuntimeSettings())
    : s(ne::test::scalarTwoSensorModel(0.9, "a", "b"), settings(), ne::OnlineOptions(), timelineOptions(), rt)
  {
    s.after_step = [this](long k) { steps.emplace_back(k, s.timeline().clock().stamp(k)); };
    s.on_restart = [this](const std::string& why) { restarts.push_back(why); };
  }
  static ne::EstimatorSettings settings()
  {
    ne::EstimatorSettings st;
    st.algorithm = ne::Algorithm::KFIO;
    return st;
  }
  Offer offer(std::size_t sensor, double stamp, double now, long step = -1)
  {
    const double y = 0.1;
    return s.measurement({step, sensor, &y, 1, nullptr, stamp}, clocks(now)).offer;
  }
  static ne::Clocks clocks(double now, double wall = -1.0)
  {
    ne::Clocks c;
    c.ros = now;
    c.wall = wall < 0.0 ? now : wall;
    return c;
  }
};

ne::RuntimeSettings adaptiveSettings()
{
  ne::RuntimeSettings rt;
  rt.adaptive_latency = true;
  rt.latency_budget_min = 0.5 * kT;
  rt.latency_budget_max = 1.0;
  return rt;
}

/// Runs `stream` from ROS time t0 for `seconds` in 1 ms ticks (ROS time = wall time): at every
/// tick the deadlines, and every 20 ms from t0 + 0.1 both sensors' samples stamped 5 ms earlier
/// (named steps when `named`: step 1 stamped t0 + 0.095). `poison` runs first, at t0.
/// Returns the stamp of the latest step taken 1 s after the good stream began.
double run(Stream& stream, double t0, double seconds, const std::function<void()>& poison, bool named = false)
{
  poison();
  double at_one_second = -1.0;
  const long ticks = std::lround(seconds * 1000.0);
  for (long i = 0; i <= ticks; ++i)
  {
    const double now = t0 + 0.001 * static_cast<double>(i);
    if (i >= 100 && (i - 100) % 20 == 0)
    {
      const long k = (i - 100) / 20 + 1;
      const double stamp = t0 + 0.095 + kT * static_cast<double>(k - 1);
      for (std::size_t s = 0; s < 2; ++s)
        stream.offer(s, stamp, now, named ? k : -1);
    }
    stream.s.deadlines(Stream::clocks(now));
    if (i == 1100)
      at_one_second = stream.steps.empty() ? -1.0 : stream.steps.back().second;
  }
  return at_one_second;
}

}  // namespace

// Every stamp is checked against ROS time: 0, more than max_stamp_ahead ahead or max_stamp_behind
// behind is refused with a reason naming the bound; without a clock (ROS time 0) only the 0.
TEST(Timeline, StampsAreCheckedAgainstRosTime)
{
  ne::Timeline t(timelineOptions(), 0.01);
  ne::Timeline::Admission a = t.admit(0.0, -1, 1000.0);
  EXPECT_EQ(a.verdict, V::REFUSE);
  EXPECT_TRUE(has(a.reason, "stamp 0: not a sample time")) << a.reason;
  a = t.admit(1010.5, -1, 1000.0);
  EXPECT_EQ(a.verdict, V::REFUSE);
  EXPECT_TRUE(has(a.reason, "is 10.5 s ahead of ROS time 1000 (max_stamp_ahead 10 s)")) << a.reason;
  a = t.admit(996.5, -1, 1000.0);
  EXPECT_EQ(a.verdict, V::REFUSE);
  EXPECT_TRUE(has(a.reason, "is 3.5 s behind ROS time 1000 (max_stamp_behind 3 s)")) << a.reason;
  EXPECT_EQ(t.admit(1e6, -1, 0.0).verdict, V::ANCHOR);  // no clock yet
  EXPECT_EQ(t.admit(0.0, 1, 0.0).verdict, V::REFUSE);
  EXPECT_EQ(t.admit(1009.9, -1, 1000.0).verdict, V::ANCHOR);
  EXPECT_EQ(t.admit(997.1, -1, 1000.0).verdict, V::ANCHOR);
}

// A first message within the bounds anchors the timeline only provisionally: a later message that
// contradicts it restarts the timeline on itself. Once confirmed, a message whose stamp does not
// fit its step (here by 5 s) is refused, and only five of them in a row restart it. An anchor that
// lies ahead of ROS time is confirmed by nothing, and a message in the present contradicts it when
// more than kAhead (0.25 s) off it.
TEST(Timeline, NoSingleMessageAnchorsOrMovesIt)
{
  ne::Timeline t(timelineOptions(), 0.01);
  t.anchor(1, 1005.0);  // stamped 5 s ahead
  EXPECT_EQ(t.admit(1000.02, -1, 1000.02).verdict, V::RESTART);
  t.anchor(1, 1005.0);
  ne::Timeline::Admission a = t.admit(1000.04, 2, 1000.04);
  EXPECT_EQ(a.verdict, V::RESTART);
  EXPECT_TRUE(has(a.reason, "whose anchor nothing confirmed yet")) << a.reason;
  // A good anchor, confirmed by the next message; then a stamp 50 s off its step.
  t.anchor(1, 1000.0);
  EXPECT_EQ(t.admit(1000.02, 2, 1000.03).verdict, V::ACCEPT);
  for (int i = 0; i < 4; ++i)
  {
    a = t.admit(1005.0, 3, 1000.05);
    EXPECT_EQ(a.verdict, V::REFUSE) << i;
  }
  EXPECT_TRUE(has(a.reason, "stamp 1005 of step 3 is 4.96 s off that step's time on the timeline")) << a.reason;
  EXPECT_EQ(t.admit(1000.06, 4, 1000.07).verdict, V::ACCEPT);  // a good one in between: the count starts over
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(t.admit(1005.0, 5, 1000.09).verdict, V::REFUSE) << i;
  a = t.admit(1005.0, 5, 1000.09);
  EXPECT_EQ(a.verdict, V::RESTART);
  EXPECT_TRUE(has(a.reason, "the 5th such message in a row")) << a.reason;
  // An anchor 0.5 s ahead of ROS time: a message 0.4 s before it (named or not) contradicts it, and
  // one just after it does not confirm it.
  t.anchor(1, 1000.5);
  EXPECT_EQ(t.admit(1000.52, -1, 1000.1).verdict, V::ACCEPT);
  EXPECT_FALSE(t.confirmed());
  EXPECT_EQ(t.admit(1000.1, -1, 1000.1).verdict, V::RESTART);
  a = t.admit(1000.1, 1, 1000.1);
  EXPECT_EQ(a.verdict, V::RESTART);
  EXPECT_TRUE(has(a.reason, "stamp 1000.1 of step 1 is -0.4 s off that step's time")) << a.reason;
  EXPECT_EQ(t.admit(1000.3, 1, 1000.1).verdict, V::ACCEPT);  // within 0.25 s
  EXPECT_FALSE(t.confirmed());
  // Stamp-only: a message well before an anchor that is not ahead of ROS time is no contradiction
  // (the anchor was a plausible, older message); before one ahead of ROS time it is, even when a
  // step was taken on the anchor (a single sensor's message completes its step at once).
  t.anchor(1, 1000.0);
  t.stepped();
  EXPECT_EQ(t.admit(998.5, -1, 1000.1).verdict, V::ACCEPT);
  t.anchor(1, 1005.0);
  t.stepped();
  EXPECT_EQ(t.admit(1000.02, -1, 1000.03).verdict, V::RESTART);
}

// Catching up is bounded: a next deadline more than max_stamp_behind behind ROS time is stale (the
// timeline restarts instead of grinding), and the steps per wall second are a token bucket of
// twice the rate ROS time needs plus one max_stamp_behind backlog.
TEST(Timeline, CatchingUpIsBoundedPerWallSecond)
{
  ne::Timeline t(timelineOptions(), 0.01);
  t.anchor(1, 1000.0);
  EXPECT_FALSE(t.stale(1, 1002.9));
  EXPECT_TRUE(t.stale(1, 1003.1));
  // Burst: 3 s / 0.02 + one second at 2 x 50 steps.
  const long burst = t.allowance(0.0, 1.0);
  EXPECT_EQ(burst, 250);
  t.spend(burst);
  long total = burst;
  for (int i = 1; i <= 1000; ++i)  // 10 wall seconds in 10 ms ticks, always spending all
  {
    const long n = t.allowance(0.01 * i, 1.0);
    t.spend(n);
    total += n;
  }
  EXPECT_LE(total, 250 + 10 * 100);
  EXPECT_GE(total, 250 + 10 * 100 - 1);
  // A clock running 4 times as fast as wall time gets 4 times the rate.
  ne::Timeline fast(timelineOptions(), 0.01);
  fast.spend(fast.allowance(0.0, 4.0));
  EXPECT_EQ(fast.allowance(1.0, 4.0), 400);
}

// A fresh stream fed one poisoned first message, then a good stream, publishes present-time
// estimates within a second, and takes no more steps than the time covered (no grinding): stamp 0
// and 1e6 s ahead are refused; 5 s ahead anchors provisionally, the good stream restarts the
// timeline and the poison counts as refused then; 2 s behind is caught up at once (100 steps,
// within the work bound), the poison itself late.
TEST(OnlineStream, APoisonedFirstMessageCannotHoldTheTimeline)
{
  const double t0 = 2e6;
  struct Case
  {
    const char* name;
    double stamp;
    bool named;
    std::uint64_t refused, restarts, late;
  };
  // The poison 2 s behind is itself late: older than latency_budget_max (1 s).
  const Case cases[] = {{"stamp 0", 0.0, false, 1, 0, 0},
                        {"1e6 s ahead", t0 + 1e6, false, 1, 0, 0},
                        {"5 s ahead", t0 + 5.0, false, 1, 1, 0},
                        {"2 s behind", t0 - 2.0, false, 0, 0, 1},
                        {"named, 5 s ahead", t0 + 5.0, true, 1, 1, 0},
                        {"named, 1e6 s ahead", t0 + 1e6, true, 1, 0, 0}};
  for (const Case& c : cases)
  {
    Stream st(adaptiveSettings());
    const double latest = run(
        st, t0, 2.0, [&] { st.offer(0, c.stamp, t0, c.named ? 1 : -1); }, c.named);
    const double now = t0 + 1.1;
    EXPECT_GE(latest, now - 0.1) << c.name << ": the estimate 1 s after the good stream began is stale";
    EXPECT_LE(latest, now) << c.name;
    EXPECT_EQ(st.s.refusedPerSensor()[0], c.refused) << c.name;
    EXPECT_EQ(st.s.restarts(), c.restarts) << c.name;
    // Steps: at most the 2 s run at 50 Hz plus the poison's 2 s behind (100 steps).
    EXPECT_LE(st.steps.size(), 100u + 100u + 5u) << c.name;
    EXPECT_EQ(st.s.online().counters().late_dropped, c.late) << c.name;
  }
}

/// x_k = 0.9 x_{k-1} + w seen by one sensor "y" at the model's rate: each message completes its
/// step at once.
ne::Model oneSensorModel()
{
  ne::Model m = ne::test::scalarTwoSensorModel(0.9, "y", "unused");
  m.C = Eigen::MatrixXd::Ones(1, 1);
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.sensors = {{"y", 0, 1}};
  ne::validateModel(m, "one");
  return m;
}

/// An OnlineStream that records, for every step, its stamp, the ROS time it was taken at and x.
struct Recorder
{
  struct Step
  {
    long k;
    double stamp, now, x;
  };
  ne::OnlineStream s;
  double now = 0.0;  ///< ROS time of the call in progress
  std::vector<Step> steps;

  explicit Recorder(const ne::Model& m)
    : s(m, Stream::settings(), ne::OnlineOptions(), timelineOptions(), adaptiveSettings())
  {
    s.after_step = [this](long k) {
      steps.push_back({k, s.timeline().clock().stamp(k), now, s.online().estimator().state()(0)});
    };
  }
  void offer(std::size_t sensor, double stamp, double at, long step, double y)
  {
    now = at;
    s.measurement({step, sensor, &y, 1, nullptr, stamp}, Stream::clocks(at));
  }
  /// A good stream from ROS time t0 for `seconds` in 1 ms ticks: every 20 ms from t0 + 0.1 each of
  /// `sensors` sensors' sample (y_k = sin(0.3 k)) stamped 5 ms earlier, naming its step when
  /// `named`. Returns the stamp of the latest step 1 s after the stream began (-1: none).
  double good(double t0, double seconds, std::size_t sensors, bool named)
  {
    double at_one_second = -1.0;
    const long ticks = std::lround(seconds * 1000.0);
    for (long i = 0; i <= ticks; ++i)
    {
      now = t0 + 0.001 * static_cast<double>(i);
      if (i >= 100 && (i - 100) % 20 == 0)
      {
        const long k = (i - 100) / 20 + 1;
        for (std::size_t j = 0; j < sensors; ++j)
          offer(j, t0 + 0.095 + kT * static_cast<double>(k - 1), now, named ? k : -1, std::sin(0.3 * k));
      }
      s.deadlines(Stream::clocks(now));
      if (i == 1100)
        at_one_second = steps.empty() ? -1.0 : steps.back().stamp;
    }
    return at_one_second;
  }
};

// Issue 37 item 5: after a poisoned first message, the first good messages start the timeline. A
// fresh stream on one sensor (whose message completes its step at once) and on two is fed one
// poisoned first message, then 2 s of a good stream:
// - no step is ever taken before ROS time reaches its stamp minus Timeline::kAhead (0.25 s): no
//   estimate is stamped further ahead of ROS time;
// - the steps are exactly those of the same good stream without the poison (stamps and x), so
//   within 1 s of good input the estimates are in the present and on track;
// - the poison is counted per sensor with its reason: refused at once (stamp 0, beyond
//   max_stamp_ahead / max_stamp_behind), or when the good stream contradicts the anchor it made
//   (ahead of ROS time within max_stamp_ahead, or any stamp that came before the clock: ROS time
//   0 under sim time), then with a timeline restart.
// A poison behind ROS time within max_stamp_behind is the one that keeps the timeline (a late
// stream looks the same): its steps up to the present are taken at once, as losses, stamped in
// the past (at most max_stamp_behind / period of them), and the estimates are in the present.
TEST(OnlineStream, APoisonedFirstMessageNeverStartsTheTimeline)
{
  const double t0 = 2e6;
  struct Case
  {
    const char* name;
    double stamp, at;  ///< the poison's stamp, and ROS time when it arrives (0: no clock yet)
    bool named;
    std::uint64_t refused, restarts;
    const char* reason;
    bool same = true;  ///< the steps equal the reference's
  };
  const char* const contradicted = "anchored the timeline, and a later message contradicted it (stamp 2000000.095";
  const Case cases[] = {{"stamp 0", 0.0, t0, false, 1, 0, "stamp 0: not a sample time"},
                        {"1e6 s ahead", t0 + 1e6, t0, false, 1, 0, "(max_stamp_ahead 10 s)"},
                        {"5 s ahead", t0 + 5.0, t0, false, 1, 1, contradicted},
                        {"2.9 s ahead", t0 + 2.9, t0, false, 1, 1, contradicted},
                        {"0.9 s ahead", t0 + 0.9, t0, false, 1, 1, contradicted},
                        {"5 s behind", t0 - 5.0, t0, false, 1, 0, "(max_stamp_behind 3 s)"},
                        {"2.9 s behind", t0 - 2.9, t0, false, 0, 0, "", false},
                        {"named, 5 s ahead", t0 + 5.0, t0, true, 1, 1, contradicted},
                        {"named, 0.9 s ahead", t0 + 0.9, t0, true, 1, 1, contradicted},
                        {"1e6 s ahead, before the clock", t0 + 1e6, 0.0, false, 1, 1, contradicted},
                        {"0.5 s ahead, before the clock", t0 + 0.5, 0.0, false, 1, 1, contradicted},
                        {"named, 1e6 s ahead, before the clock", t0 + 1e6, 0.0, true, 1, 1, contradicted},
                        {"named, 0.5 s ahead, before the clock", t0 + 0.5, 0.0, true, 1, 1, contradicted}};
  for (const std::size_t sensors : {std::size_t(1), std::size_t(2)})
  {
    const ne::Model model = sensors == 1 ? oneSensorModel() : ne::test::scalarTwoSensorModel(0.9, "a", "b");
    for (const bool named : {false, true})
    {
      Recorder reference(model);
      const double latest = reference.good(t0, 2.0, sensors, named);
      EXPECT_GE(latest, t0 + 1.1 - 0.1) << "the reference's estimates are not in the present";
      ASSERT_GE(reference.steps.size(), 95u);
      for (const Case& c : cases)
      {
        if (c.named != named)
          continue;
        const std::string name = std::string(c.name) + ", " + std::to_string(sensors) + " sensor(s)";
        Recorder r(model);
        r.offer(0, c.stamp, c.at, named ? 1 : -1, 1e3);
        const double at_one_second = r.good(t0, 2.0, sensors, named);
        // (The first failure of each case is reported, then the next case runs.)
        for (const Recorder::Step& st : r.steps)
          if (!(st.stamp <= st.now + ne::Timeline::kAhead))
          {
            ADD_FAILURE() << name << ": step " << st.k << " stamped " << st.stamp - st.now << " s ahead of ROS time";
            break;
          }
        EXPECT_GE(at_one_second, t0 + 1.1 - 0.1) << name << ": the estimate 1 s after the good stream began is stale";
        if (c.same)
        {
          EXPECT_EQ(r.steps.size(), reference.steps.size()) << name;
          for (std::size_t i = 0; i < std::min(r.steps.size(), reference.steps.size()); ++i)
            if (r.steps[i].k != reference.steps[i].k ||
                !(std::fabs(r.steps[i].stamp - reference.steps[i].stamp) <= 1e-9) ||
                !(std::fabs(r.steps[i].x - reference.steps[i].x) <= 1e-12))
            {
              ADD_FAILURE() << name << ": step #" << i << " is step " << r.steps[i].k << " stamped " << std::fixed
                            << r.steps[i].stamp - t0 << " s after t0, x = " << r.steps[i].x
                            << "; without the poison: step " << reference.steps[i].k << " stamped "
                            << reference.steps[i].stamp - t0 << ", x = " << reference.steps[i].x;
              break;
            }
        }
        else
        {
          const auto past =
              std::count_if(r.steps.begin(), r.steps.end(), [&](const Recorder::Step& st) { return st.stamp < t0; });
          EXPECT_LE(past, 150) << name << ": more steps before the good stream than max_stamp_behind holds";
          EXPECT_LE(r.steps.size(), reference.steps.size() + 150u) << name;
        }
        EXPECT_EQ(r.s.refusedPerSensor()[0], c.refused) << name;
        EXPECT_EQ(r.s.restarts(), c.restarts) << name;
        EXPECT_TRUE(has(r.s.lastRefused(0).reason, c.reason)) << name << ": " << r.s.lastRefused(0).reason;
        EXPECT_EQ(r.s.lastRefused(0).reason.empty(), c.refused == 0) << name;
        EXPECT_EQ(r.s.lastRestart().reason.empty(), c.restarts == 0) << name;
      }
    }
  }
}

// The diagnostics say what was refused, naming the sensor, with the count and the reason, for
// kRecentSeconds of wall time after the last such message (then only the counters keep it); a
// command refused for its stamp and a timeline restart likewise.
TEST(OnlineStream, TheDiagnosticsSayWhatWasRefused)
{
  const double t0 = 2e6;
  Stream st(adaptiveSettings());
  EXPECT_TRUE(st.s.stampWarnings(100.0).empty());
  const double y = 0.1;
  st.s.measurement({-1, 1, &y, 1, nullptr, 0.0}, Stream::clocks(t0, 100.0));
  st.s.measurement({-1, 1, &y, 1, nullptr, t0 + 20.0}, Stream::clocks(t0, 101.0));
  std::vector<std::string> w = st.s.stampWarnings(101.5);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0],
            "sensor 'b': 2 messages refused for their stamp, the last 0.5 s ago: stamp 2000020 is 20 s ahead of "
            "ROS time 2000000 (max_stamp_ahead 10 s)");
  EXPECT_EQ(st.s.refusedPerSensor()[1], 2u);
  EXPECT_TRUE(st.s.stampWarnings(111.5).empty());  // 10.5 s later
  // A command stamped 0 (no header stamp), once the timeline runs.
  st.offer(0, t0, t0);
  st.s.heldCommand({-1, &y, 1, 0.0}, Stream::clocks(t0, 102.0));
  w = st.s.stampWarnings(103.0);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[1],
            "commands and schedules: 1 message refused for its stamp, the last 1 s ago: command: stamp 0: not "
            "a sample time (an unset header stamp?)");
  // A restart: an anchor taken before the clock (ROS time 0), 1e6 s ahead of the first message
  // that arrives with one.
  Stream r(adaptiveSettings());
  r.s.measurement({-1, 0, &y, 1, nullptr, t0 + 1e6}, Stream::clocks(0.0, 200.0));
  r.s.measurement({-1, 0, &y, 1, nullptr, t0}, Stream::clocks(t0, 201.0));
  w = r.s.stampWarnings(203.0);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_TRUE(has(w[0],
                  "sensor 'a': 1 message refused for its stamp, the last 2 s ago: stamp 3000000 anchored the "
                  "timeline, and a later message contradicted it (stamp 2000000 is 1000000 s before"))
      << w[0];
  EXPECT_TRUE(has(w[1],
                  "timeline restarted 2 s ago: stamp 2000000 is 1000000 s before the stamp 3000000 that anchored "
                  "the timeline ahead of ROS time"))
      << w[1];
}

// The receive thread takes the steps its messages complete and never calls deadlines(): the time it
// notes (observe) is what a jump back is measured from. Here deadlines() last looked at t0, the
// stream ran on to t0 + 2 s, and the clock went back to t0 + 1 s.
TEST(OnlineStream, AJumpBackIsMeasuredFromTheLastObservedTime)
{
  const double t0 = 5000.0;
  for (const bool observed : {false, true})
  {
    Stream st(adaptiveSettings());
    st.offer(0, t0, t0);
    st.offer(1, t0, t0);
    st.s.deadlines(Stream::clocks(t0));
    for (int k = 1; k <= 100; ++k)  // 2 s of steps completed by their messages
    {
      const double now = t0 + kT * k;
      st.offer(0, now, now);
      st.offer(1, now, now);
      if (observed)
        st.s.observe(Stream::clocks(now));
    }
    st.s.deadlines(Stream::clocks(t0 + 1.0));
    EXPECT_EQ(st.s.timeResets(), observed ? 1u : 0u) << (observed ? "observed" : "not observed");
    EXPECT_EQ(st.s.online().started(), !observed);
  }
}

// ROS time jumping forward by a day restarts the timeline at once (no step taken for the gap); a
// jump of 2 s (less than max_stamp_behind) is caught up, within the work bound; a clock that runs
// 100 times faster than it says (rate 1) gets at most the bound per wall second, and restarts
// rather than grinding further behind.
TEST(OnlineStream, TimeJumpsAndAFastClockDoNotGrind)
{
  Stream st(adaptiveSettings());
  const double t0 = 5000.0;
  for (int k = 1; k <= 50; ++k)
  {
    const double now = t0 + kT * k;
    st.offer(0, now, now);
    st.offer(1, now, now);
    st.s.deadlines(Stream::clocks(now));
  }
  const std::size_t before = st.steps.size();
  EXPECT_GE(before, 49u);
  st.s.deadlines(Stream::clocks(t0 + 86400.0, t0 + 1.1));
  EXPECT_EQ(st.steps.size(), before);
  EXPECT_EQ(st.s.timeResets(), 1u);
  ASSERT_EQ(st.restarts.size(), 1u);
  EXPECT_TRUE(has(st.restarts[0], "more than max_stamp_behind 3 s")) << st.restarts[0];
  EXPECT_FALSE(st.s.online().started());

  Stream jump(adaptiveSettings());
  jump.offer(0, t0, t0);
  jump.offer(1, t0, t0);
  jump.s.deadlines(Stream::clocks(t0 + 0.05));
  const std::size_t n0 = jump.steps.size();
  jump.s.deadlines(Stream::clocks(t0 + 2.05, t0 + 0.06));
  EXPECT_GE(jump.steps.size() - n0, 98u);
  EXPECT_LE(jump.steps.size() - n0, 101u);
  EXPECT_EQ(jump.s.timeResets(), 0u);

  // ROS time at 100 x wall time, the clock rate told as 1: per wall second at most 2 x 50 steps
  // after the first burst (250), and the timeline restarts once it falls max_stamp_behind behind.
  Stream fast(adaptiveSettings());
  fast.offer(0, t0, t0);
  fast.offer(1, t0, t0);
  long max_per_second = 0;
  for (int second = 0; second < 5; ++second)
  {
    const std::size_t at = fast.steps.size();
    for (int ms = 0; ms < 1000; ++ms)
    {
      const double wall = t0 + second + 0.001 * ms;
      fast.s.deadlines(Stream::clocks(t0 + 100.0 * (wall - t0), wall));
    }
    max_per_second = std::max<long>(max_per_second, static_cast<long>(fast.steps.size() - at));
  }
  EXPECT_LE(max_per_second, 250 + 100);
  EXPECT_GE(fast.s.timeResets(), 1u);
}

// The adaptive budget follows a sensor that arrives 30 ms after its stamps (the minimum budget is
// 10 ms): nothing of it is dropped as late; with a fixed budget of 10 ms it loses nearly
// everything, and its late fraction over the last 10 s says so. A sensor whose message disabled
// its fields is not due at that step and not a loss.
TEST(OnlineStream, TheBudgetFollowsTheDelaysAndLossesAreCounted)
{
  const double t0 = 3000.0;
  auto feed = [&](Stream& st)
  {
    for (int i = 0; i < 1000; ++i)  // 1 ms ticks; a's samples arrive 1 ms after their stamps, b's 30 ms
    {
      const double now = t0 + 0.001 * i;
      if (i % 20 == 1)
        st.offer(0, now - 0.001, now);
      if (i % 20 == 10 && i >= 30)
        st.offer(1, now - 0.030, now);
      st.s.deadlines(Stream::clocks(now));
    }
  };
  Stream adaptive(adaptiveSettings());
  feed(adaptive);
  EXPECT_EQ(adaptive.s.online().counters().late_dropped_per_sensor[1], 0u);
  EXPECT_GT(adaptive.s.budget(), 0.030);
  EXPECT_NEAR(adaptive.s.latency().delay(1), 0.030, 1e-6);
  ne::RuntimeSettings fixed;
  fixed.adaptive_latency = false;
  fixed.latency_budget = 0.01;
  Stream late(fixed);
  feed(late);
  const std::uint64_t received = late.s.online().counters().received_per_sensor[1];
  EXPECT_GE(late.s.online().counters().late_dropped_per_sensor[1], received - 1);
  EXPECT_GT(late.s.latency().window(1, t0 + 1.0).fraction(), 0.9);
  EXPECT_EQ(late.s.latency().window(0, t0 + 1.0).lost, 0u);

  // Disabled: b's message at step 3 carries no estimate; the step is not waiting for it, b is not
  // due there, and nothing is lost.
  Stream d(adaptiveSettings());
  const double y = 0.2;
  for (long k = 1; k <= 5; ++k)
  {
    const double stamp = t0 + kT * static_cast<double>(k - 1);
    d.s.measurement({-1, 0, &y, 1, nullptr, stamp}, Stream::clocks(stamp));
    if (k == 3)
      EXPECT_EQ(d.s.disabled(1, stamp, -1, Stream::clocks(stamp)).offer, Offer::DISABLED);
    else
      d.s.measurement({-1, 1, &y, 1, nullptr, stamp}, Stream::clocks(stamp));
  }
  const ne::OnlineCounters& c = d.s.online().counters();
  EXPECT_EQ(c.processed, 5u);  // every step complete at once, step 3 included
  EXPECT_EQ(c.disabled_per_sensor[1], 1u);
  EXPECT_EQ(c.due, 9u);
  EXPECT_EQ(c.due_arrived, 9u);
}
