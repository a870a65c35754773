// What the LossyChannel reports of itself: the ~events message of one record and the counters and
// windowed rates of its /diagnostics status (lossy_channel_nodelet.cpp).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/time.h>

#include <cstdint>
#include <string>

#include "networked_estimation/ChannelEvent.h"
#include "networked_estimation/channel/channel.hpp"
#include "networked_estimation/stability/link_monitor.hpp"

namespace networked_estimation
{

/// The ~events message of record `e`: its arrival on the channel's clock (started at t0) and the
/// stamp of the input message it carries.
inline ChannelEvent channelEventMessage(const ChannelRecord& e, const ros::Time& t0, const ros::Time& input_stamp)
{
  ChannelEvent m;
  m.header.stamp = t0 + ros::Duration(e.arrival);
  m.seq = e.seq;
  m.input_stamp = input_stamp;
  m.outcome = static_cast<uint8_t>(e.outcome);
  m.duplicated = e.duplicated;
  m.state = static_cast<uint8_t>(e.state);
  m.delay = e.delay;
  m.sampled_delay = e.sampled_delay;
  return m;
}

/// The channel's counters, loss, bursts and delay quantiles, `wrong` (why `in` has the wrong message
/// type, "" when it has not), and the monitor's windowed estimates (last 1000 messages, 95 % Wilson
/// intervals) of what the link does now.
inline void addChannelStatus(diagnostic_updater::DiagnosticStatusWrapper& stat, const LossyChannel& channel,
                             const LinkMonitor& monitor, const std::string& wrong)
{
  const ChannelCounters& c = channel.counters();
  stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "loss %.3f over %lu messages", channel.lossRate(),
                static_cast<unsigned long>(c.received));
  if (c.dropped_queue > 0)
    stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, "queue_limit reached: messages dropped");
  stat.add("received", c.received);
  stat.add("delivered", c.delivered);
  stat.add("dropped by model", c.dropped_model);
  stat.add("dropped by queue", c.dropped_queue);
  stat.add("duplicated", c.duplicated);
  stat.add("in flight", c.in_flight);
  stat.add("empirical loss rate", channel.lossRate());
  stat.add("mean burst length", channel.meanBurstLength());
  stat.add("delay p50 (s)", channel.delayQuantile(0.5));
  stat.add("delay p90 (s)", channel.delayQuantile(0.9));
  stat.add("delay p99 (s)", channel.delayQuantile(0.99));
  if (!wrong.empty())
    stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "wrong message type: %s", wrong.c_str());
  stat.add("wrong type", wrong.empty() ? std::string("none") : wrong);
  const RateEstimate a = monitor.arrivalRate(), r = monitor.recoveryRate();
  stat.addf("windowed arrival rate", "%.4f [%.4f, %.4f] over %zu", a.value, a.lower, a.upper, a.trials);
  stat.addf("windowed recovery rate", "%.4f [%.4f, %.4f] over %zu", r.value, r.lower, r.upper, r.trials);
}

}  // namespace networked_estimation
