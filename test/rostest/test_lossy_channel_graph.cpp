// rostest: the LossyChannel nodelet on a real graph. Each .test file starts a nodelet manager with
// one or two channels and runs one scenario of this binary (selected with --gtest_filter).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <dynamic_reconfigure/Config.h>
#include <dynamic_reconfigure/Reconfigure.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <geometry_msgs/PointStamped.h>
#include <sensor_msgs/Imu.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <vector>

#include "networked_estimation/ChannelEvent.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/SetParameters.h"
#include "graph_test_support.hpp"

using networked_estimation::ChannelEvent;
using networked_estimation::Measurement;

namespace
{

/// Connects the test to the channels before a measured run. A channel advertises `out` only when
/// its first message arrives (it needs the message type), so one warm-up message goes first; the
/// collectors are then cleared, and the measured messages have channel sequence numbers 1, 2, ...
/// (Nodelets in one manager share one connection per topic: the publisher sees one subscriber.)
template <class M, class Out, class... Events>
bool warmUp(ros::Publisher& pub, const M& first, Out* out, Events&... events)
{
  if (!waitFor([&] { return pub.getNumSubscribers() >= 1 && ((events.sub.getNumPublishers() >= 1) && ...); }, 10.0))
    return false;
  pub.publish(first);
  if (!waitFor([&] { return (!out || out->sub.getNumPublishers() >= 1) && ((events.size() >= 1) && ...); }, 10.0))
    return false;
  ros::WallDuration(0.3).sleep();
  if (out)
    out->clear();
  (events.clear(), ...);
  return true;
}

}  // namespace

// (a) + (d): Gilbert-Elliott loss on sensor_msgs/Imu over 20 000 messages.
TEST(LossyChannelGraph, GilbertElliottStatisticsOnImu)
{
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::Imu>("imu_in", 100000);
  Collector<sensor_msgs::Imu> out(nh, "imu_out");
  Collector<ChannelEvent> events(nh, "channel/events");
  DiagnosticsProbe diag(nh, "channel");
  sensor_msgs::Imu first;
  first.orientation.x = -1;
  ASSERT_TRUE(warmUp(pub, first, &out, events));
  const int N = 20000;
  ros::Rate rate(5000);
  for (int i = 0; i < N; ++i)
  {
    sensor_msgs::Imu m;
    m.header.stamp = ros::Time(1000 + i * 1e-3);
    m.header.frame_id = "imu";
    m.orientation.x = i;  // the message's identity
    m.orientation.w = 1.0;
    pub.publish(m);
    rate.sleep();
  }
  ASSERT_TRUE(waitFor([&] { return events.size() == static_cast<std::size_t>(N); }, 30.0)) << events.size();
  // outputs: exactly the DELIVERED events, in order, same content
  std::vector<int> delivered;
  int lost = 0, bursts = 0;
  bool in_burst = false;
  for (int i = 0; i < N; ++i)
  {
    const ChannelEvent& e = events.msgs[i];
    ASSERT_EQ(e.seq, static_cast<uint64_t>(i + 1));
    ASSERT_EQ(e.input_stamp, ros::Time(1000 + i * 1e-3));
    const bool drop = e.outcome != ChannelEvent::DELIVERED;
    ASSERT_NE(e.outcome, ChannelEvent::DROPPED_QUEUE);
    if (!drop)
      delivered.push_back(i);
    lost += drop;
    bursts += drop && !in_burst;
    in_burst = drop;
  }
  ASSERT_TRUE(waitFor([&] { return out.size() == delivered.size(); }, 10.0))
      << out.size() << " vs " << delivered.size();
  for (std::size_t j = 0; j < delivered.size(); ++j)
    ASSERT_EQ(static_cast<int>(out.msgs[j].orientation.x), delivered[j]) << j;
  // stationary values: p = 0.05, r = 0.4 -> loss rate pi = p/(p+r) = 1/9, mean burst 1/r = 2.5.
  // The loss indicator is a two-state Markov chain with lambda = 1 - p - r = 0.55: the variance of
  // its sample mean is pi(1-pi)/N (1+lambda)/(1-lambda); bursts are geometric(r) with sd
  // sqrt(1-r)/r. Bounds are 5 standard errors (two-sided false-alarm probability below 1e-6).
  const double p = 0.05, r = 0.4, pi = p / (p + r), lam = 1 - p - r;
  const double se_rate = std::sqrt(pi * (1 - pi) / N * (1 + lam) / (1 - lam));
  EXPECT_NEAR(static_cast<double>(lost) / N, pi, 5 * se_rate);
  const double se_burst = std::sqrt(1 - r) / r / std::sqrt(static_cast<double>(bursts));
  EXPECT_NEAR(static_cast<double>(lost) / bursts, 1 / r, 5 * se_burst);
  // counts balance exactly, as reported on /diagnostics
  ASSERT_TRUE(waitFor([&] { return diag.get("received") == N + 1; }, 5.0)) << diag.get("received");
  EXPECT_EQ(diag.get("received") + diag.get("duplicated"), diag.get("delivered") + diag.get("dropped by model") +
                                                               diag.get("dropped by queue") + diag.get("in flight"));
  // the warm-up message is the one message the diagnostics count beyond the measured run
  EXPECT_NEAR(diag.get("dropped by model"), lost, 1.0);
  EXPECT_NEAR(diag.get("delivered"), static_cast<double>(delivered.size()), 1.0);
  EXPECT_EQ(diag.get("dropped by model") + diag.get("delivered"), N + 1);
  EXPECT_NEAR(diag.get("empirical loss rate"), static_cast<double>(lost) / N, 1.0 / N);
}

// (b) + (c): delay and jitter on this package's Measurement, FIFO order kept.
TEST(LossyChannelGraph, DelayJitterAndOrderOnMeasurement)
{
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<Measurement>("meas_in", 100000);
  Collector<Measurement> out(nh, "meas_out");
  Collector<ChannelEvent> events(nh, "channel/events");
  ASSERT_TRUE(warmUp(pub, Measurement(), &out, events));
  const int N = 2000;
  std::vector<ros::Time> sent(N);
  ros::Rate rate(1000);
  for (int i = 0; i < N; ++i)
  {
    Measurement m;
    m.step = i + 1;
    m.sensor = "y";
    m.y = {static_cast<double>(i)};
    sent[i] = ros::Time::now();
    m.header.stamp = sent[i];
    pub.publish(m);
    rate.sleep();
  }
  ASSERT_TRUE(waitFor([&] { return out.size() == static_cast<std::size_t>(N); }, 30.0)) << out.size();
  ASSERT_EQ(events.size(), static_cast<std::size_t>(N));
  // configured: delay 0.02 s, jitter 0.005 s, normal: sampled delay = 0.02 + 0.005 Z.
  std::vector<double> applied;
  for (int i = 0; i < N; ++i)
  {
    // (c) reorder: false keeps the input order even though the jitter reorders due times
    ASSERT_EQ(out.msgs[i].step, static_cast<uint64_t>(i + 1)) << "position " << i;
    ASSERT_EQ(events.msgs[i].outcome, ChannelEvent::DELIVERED);
    applied.push_back(events.msgs[i].sampled_delay);
    EXPECT_GE(events.msgs[i].delay, events.msgs[i].sampled_delay) << i;  // FIFO only ever holds back
    // never early: received - sent >= applied delay
    EXPECT_GE((out.received_at[i] - sent[i]).toSec(), events.msgs[i].delay - 1e-6) << i;
  }
  // mean of N(0.02, 0.005^2): 5 standard errors (0.005 / sqrt(N)); clipping at 0 is 4 sd away
  double mean = 0;
  for (double d : applied)
    mean += d / N;
  EXPECT_NEAR(mean, 0.02, 5 * 0.005 / std::sqrt(N));
  // 90 % quantile: the empirical CDF at the true quantile 0.02 + 1.2816 * 0.005 is within the
  // DKW bound sqrt(ln(2/1e-6) / (2N)) of 0.9
  const double q90 = 0.02 + 1.2815516 * 0.005;
  const double below = std::count_if(applied.begin(), applied.end(), [&](double d) { return d <= q90; });
  EXPECT_NEAR(below / N, 0.9, std::sqrt(std::log(2 / 1e-6) / (2.0 * N)));
  // the FIFO hold-back makes the real delay of late messages exceed their own draw; check the
  // added latency beyond the applied delay stays small (median under 5 ms on loopback)
  std::vector<double> extra;
  for (int i = 0; i < N; ++i)
    extra.push_back((out.received_at[i] - sent[i]).toSec() - events.msgs[i].delay);
  std::nth_element(extra.begin(), extra.begin() + N / 2, extra.end());
  EXPECT_LT(extra[N / 2], 0.005);
}

// (e): two channels with the same seed on the same input give the same event sequence.
TEST(LossyChannelGraph, SameSeedSameEvents)
{
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::Imu>("imu_in", 100000);
  Collector<ChannelEvent> a(nh, "channel_a/events");
  Collector<ChannelEvent> b(nh, "channel_b/events");
  Collector<ChannelEvent> c(nh, "channel_c/events");  // another seed
  ASSERT_TRUE(warmUp(pub, sensor_msgs::Imu(), static_cast<Collector<sensor_msgs::Imu>*>(nullptr), a, b, c));
  const int N = 3000;
  ros::Rate rate(3000);
  for (int i = 0; i < N; ++i)
  {
    sensor_msgs::Imu m;
    m.header.stamp = ros::Time(10 + i * 1e-3);
    pub.publish(m);
    rate.sleep();
  }
  ASSERT_TRUE(waitFor(
      [&] { return a.size() == std::size_t(N) && b.size() == std::size_t(N) && c.size() == std::size_t(N); }, 30.0));
  int differ_c = 0;
  for (int i = 0; i < N; ++i)
  {
    ASSERT_EQ(a.msgs[i].outcome, b.msgs[i].outcome) << i;
    ASSERT_EQ(a.msgs[i].state, b.msgs[i].state) << i;
    ASSERT_EQ(a.msgs[i].duplicated, b.msgs[i].duplicated) << i;
    ASSERT_EQ(a.msgs[i].sampled_delay, b.msgs[i].sampled_delay) << i;
    differ_c += a.msgs[i].outcome != c.msgs[i].outcome;
  }
  EXPECT_GT(differ_c, 50);  // a different seed gives a different sequence
}

// (f): bad parameters: the channel's load fails (onInit throws), so nothing is forwarded.
TEST(LossyChannelGraph, BadParametersForwardNothing)
{
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::Imu>("imu_in", 100);
  Collector<sensor_msgs::Imu> out(nh, "imu_out");
  // give the manager time to load (and refuse) the channel
  ros::WallDuration(2.0).sleep();
  EXPECT_EQ(pub.getNumSubscribers(), 0u);
  for (int i = 0; i < 50; ++i)
  {
    pub.publish(sensor_msgs::Imu());
    ros::WallDuration(0.01).sleep();
  }
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(out.size(), 0u);
  EXPECT_EQ(out.sub.getNumPublishers(), 0u);
  // The load itself failed: the manager holds no nodelet named /channel.
  const std::vector<std::string> loaded = loadedNodelets("/manager");
  EXPECT_FALSE(isLoaded(loaded, "/channel"));
}

// Runtime change: set_parameters degrades the link mid-run, from the next message on; a bad
// change is refused with the key named and nothing changes.
TEST(LossyChannelGraph, SetParametersAppliesFromNextMessage)
{
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<sensor_msgs::Imu>("imu_in", 100000);
  Collector<ChannelEvent> events(nh, "channel/events");
  ASSERT_TRUE(warmUp(pub, sensor_msgs::Imu(), static_cast<Collector<sensor_msgs::Imu>*>(nullptr), events));
  ros::ServiceClient client = nh.serviceClient<networked_estimation::SetParameters>("channel/set_parameters");
  ASSERT_TRUE(client.waitForExistence(ros::Duration(10.0)));
  auto send = [&](int n)
  {
    for (int i = 0; i < n; ++i)
    {
      pub.publish(sensor_msgs::Imu());
      ros::WallDuration(0.001).sleep();
    }
  };
  send(200);
  ASSERT_TRUE(waitFor([&] { return events.size() == 200u; }, 10.0));
  networked_estimation::SetParameters srv;
  srv.request.yaml = "{loss: 2.0}";
  ASSERT_TRUE(client.call(srv));
  EXPECT_FALSE(srv.response.success);
  EXPECT_NE(srv.response.message.find("loss"), std::string::npos) << srv.response.message;
  srv.request.yaml = "{loss: 1.0}";
  ASSERT_TRUE(client.call(srv));
  EXPECT_TRUE(srv.response.success) << srv.response.message;
  send(200);
  ASSERT_TRUE(waitFor([&] { return events.size() == 400u; }, 10.0));
  int delivered_before = 0;
  for (int i = 0; i < 200; ++i)
    delivered_before += events.msgs[i].outcome == ChannelEvent::DELIVERED;
  EXPECT_EQ(delivered_before, 200);  // configured loss 0 at start
  for (int i = 200; i < 400; ++i)
    EXPECT_EQ(events.msgs[i].outcome, ChannelEvent::DROPPED_MODEL) << i;

  // dynamic_reconfigure (in channel/reconfigure) shows the change made by set_parameters, applies
  // its own from the next message on, and undoes a change the settings refuse.
  auto value = [](const dynamic_reconfigure::Config& c, const std::string& name)
  {
    for (const auto& d : c.doubles)
      if (d.name == name)
        return d.value;
    return std::nan("");
  };
  auto text = [](const dynamic_reconfigure::Config& c, const std::string& name)
  {
    for (const auto& d : c.strs)
      if (d.name == name)
        return d.value;
    return std::string();
  };
  Collector<dynamic_reconfigure::Config> updates(nh, "channel/reconfigure/parameter_updates");
  ASSERT_TRUE(waitFor([&] { return updates.size() >= 1u; }, 10.0));  // latched
  {
    std::lock_guard<std::mutex> lock(updates.mutex);
    EXPECT_EQ(value(updates.msgs.back(), "loss"), 1.0);
    EXPECT_EQ(text(updates.msgs.back(), "model"), "bernoulli");
  }
  ros::ServiceClient dyn = nh.serviceClient<dynamic_reconfigure::Reconfigure>("channel/reconfigure/set_parameters");
  ASSERT_TRUE(dyn.waitForExistence(ros::Duration(10.0)));
  dynamic_reconfigure::Reconfigure rc;
  dynamic_reconfigure::DoubleParameter loss;
  loss.name = "loss";
  loss.value = 0.0;
  rc.request.config.doubles.push_back(loss);
  ASSERT_TRUE(dyn.call(rc));
  EXPECT_EQ(value(rc.response.config, "loss"), 0.0);
  send(100);
  ASSERT_TRUE(waitFor([&] { return events.size() == 500u; }, 10.0));
  for (int i = 400; i < 500; ++i)
    EXPECT_EQ(events.msgs[i].outcome, ChannelEvent::DELIVERED) << i;
  dynamic_reconfigure::Reconfigure bad;
  dynamic_reconfigure::StrParameter dist;
  dist.name = "distribution";
  dist.value = "cauchy";  // not one of the enum's: the settings refuse it
  bad.request.config.strs.push_back(dist);
  ASSERT_TRUE(dyn.call(bad));
  EXPECT_EQ(text(bad.response.config, "distribution"), "uniform");
  EXPECT_EQ(value(bad.response.config, "loss"), 0.0);
}

// Delays are in ROS time: under /use_sim_time a message waits for the simulated clock, however
// much wall time passes.
TEST(LossyChannelGraph, DelayHoldsUnderSimTime)
{
  ros::NodeHandle nh;
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  auto setClock = [&](double t)
  {
    rosgraph_msgs::Clock c;
    c.clock = ros::Time(t);
    clock.publish(c);
  };
  ASSERT_TRUE(waitFor([&] { return clock.getNumSubscribers() >= 1; }, 10.0));
  setClock(100.0);
  ASSERT_TRUE(waitFor([&] { return ros::Time::now() == ros::Time(100.0); }, 5.0));
  ros::Publisher pub = nh.advertise<Measurement>("meas_in", 100);
  Collector<Measurement> out(nh, "meas_out");
  Collector<ChannelEvent> events(nh, "channel/events");
  // warm-up: delivered after 0.5 s of simulated time
  ASSERT_TRUE(waitFor([&] { return pub.getNumSubscribers() >= 1 && events.sub.getNumPublishers() >= 1; }, 10.0));
  pub.publish(Measurement());
  ASSERT_TRUE(waitFor([&] { return events.size() == 1u && out.sub.getNumPublishers() >= 1; }, 10.0));
  setClock(101.0);
  ASSERT_TRUE(waitFor([&] { return out.size() == 1u; }, 5.0));
  out.clear();
  // the measured message: sent at sim time 101; the clock stays still for a wall second
  Measurement m;
  m.step = 7;
  pub.publish(m);
  ASSERT_TRUE(waitFor([&] { return events.size() == 2u; }, 5.0));
  EXPECT_DOUBLE_EQ(events.msgs[1].sampled_delay, 0.5);
  ros::WallDuration(1.0).sleep();
  EXPECT_EQ(out.size(), 0u) << "delivered after wall time, not simulated time";
  setClock(101.3);
  ros::WallDuration(0.3).sleep();
  EXPECT_EQ(out.size(), 0u) << "delivered 0.3 s (sim) into a 0.5 s delay";
  setClock(101.6);
  ASSERT_TRUE(waitFor([&] { return out.size() == 1u; }, 5.0));
  EXPECT_EQ(out.msgs[0].step, 7u);
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lossy_channel_graph");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  spinner.stop();
  return rc;
}

// ~type with a publisher in the same manager (channel_typed.test): the PlantSimulator's Imu are
// handled in the plant's thread (DirectQueue) and the delayed ones published later by the
// channel's thread. Every delivered message comes out once, in FIFO order, with the stamp its
// event names; the loss rate is the model's; a publisher of another type on `in` is reported.
TEST(LossyChannelGraph, TypedInProcessDelayOrderAndWrongType)
{
  ros::NodeHandle nh;
  Collector<sensor_msgs::Imu> out(nh, "/imu_out");
  Collector<ChannelEvent> events(nh, "/imu_link/events");
  ASSERT_TRUE(waitFor([&] { return out.sub.getNumPublishers() >= 1 && events.sub.getNumPublishers() >= 1; }, 10.0));
  const std::size_t N = 600;  // the plant's steps, published from 5 s after its load
  ASSERT_TRUE(waitFor([&] { return events.size() >= N; }, 30.0)) << events.size();
  ros::WallDuration(0.5).sleep();  // the last delays (at most a few tenths of a second) expire
  std::vector<ros::Time> delivered;
  for (std::size_t i = 0; i < events.msgs.size(); ++i)
  {
    const ChannelEvent& e = events.msgs[i];
    if (i > 0)
      ASSERT_GT(e.input_stamp, events.msgs[i - 1].input_stamp) << "event " << i;  // typed stamps, in order
    if (e.outcome == ChannelEvent::DELIVERED)
      delivered.push_back(e.input_stamp);
  }
  ASSERT_EQ(events.size(), N);
  ASSERT_EQ(out.size(), delivered.size());
  std::vector<double> held;
  for (std::size_t j = 0; j < delivered.size(); ++j)
  {
    ASSERT_EQ(out.msgs[j].header.stamp, delivered[j]) << j;  // FIFO (reorder: false), each once
    held.push_back((out.received_at[j] - out.msgs[j].header.stamp).toSec());
  }
  // Binomial loss 0.2 over 600: sd sqrt(0.2 0.8 / 600) = 0.016; 5 sd.
  EXPECT_NEAR(1.0 - static_cast<double>(delivered.size()) / N, 0.2, 5 * 0.0163);
  // Held for the delay: 20 ms, normal jitter of 5 ms (FIFO may hold a message behind a later
  // draw): the median lies within 2 sd of 20 ms plus the few milliseconds of the hops.
  // And none much later than due: 20 ms + 6 sd of jitter, with 0.2 s to spare for the machine's
  // scheduling (a delivery waits for its own due time, not for the next message to arrive).
  EXPECT_LT(*std::max_element(held.begin(), held.end()), 0.25);
  std::nth_element(held.begin(), held.begin() + static_cast<std::ptrdiff_t>(held.size() / 2), held.end());
  const double median = held[held.size() / 2];
  EXPECT_GT(median, 0.010);
  EXPECT_LT(median, 0.035);

  Collector<sensor_msgs::Imu> wrong_out(nh, "/wrong_out");
  DiagnosticsProbe diag(nh, "wrong_link: channel");
  ros::Publisher wrong = nh.advertise<geometry_msgs::PointStamped>("/wrong_in", 10);
  geometry_msgs::PointStamped p;
  ASSERT_TRUE(waitFor(
      [&]
      {
        wrong.publish(p);
        return diag.text("wrong type").find("geometry_msgs/PointStamped") != std::string::npos;
      },
      15.0))
      << diag.text("wrong type");
  EXPECT_NE(diag.text("wrong type").find("expected sensor_msgs/Imu"), std::string::npos) << diag.text("wrong type");
  EXPECT_TRUE(diag.levelIs(diagnostic_msgs::DiagnosticStatus::WARN)) << diag.lastMessage();
  EXPECT_EQ(wrong_out.size(), 0u);
  EXPECT_EQ(diag.get("received"), 0.0);
}
