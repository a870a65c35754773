// Sim time: a nodelet's own view of /clock, read as each tick arrives, and word when a tick
// reaches a given ROS time.
//
// Why: under /use_sim_time, ROS time moves only at /clock ticks, which no wait can foresee: a thread
// that waits for a deadline in ROS time had to look at the clock again every few milliseconds
// (hundreds of wake-ups a second, most of them for nothing, and most of a nodelet's CPU when no
// message comes). Here the tick itself says when the deadline has come.
//
// The ticks are read in roscpp's receive thread (InlineQueue), which only stores the time and, when
// it reaches the armed time, raises a flag for its own next turn (takeReached, from a PollTurnHook):
// the deadline's work is done there, after every message read in the same round as the tick (a
// message read before the tick that passes its deadline is in time; one read after it is late).
// roscpp's ROS time follows the tick a moment later, from roscpp's internal thread: now() takes
// the later of the two.
#pragma once

#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <algorithm>
#include <atomic>
#include <limits>

#include "dispatch_thread.hpp"

namespace networked_estimation
{

class SimClockWatch
{
public:
  SimClockWatch() = default;
  SimClockWatch(const SimClockWatch&) = delete;
  SimClockWatch& operator=(const SimClockWatch&) = delete;
  ~SimClockWatch() { stop(); }

  /// Under sim time, subscribes /clock (nothing in wall time: active() stays false).
  void start(ros::NodeHandle nh)
  {
    if (!ros::Time::isSimTime())
      return;
    nh.setCallbackQueue(&queue_);
    ros::SubscribeOptions o;
    o.init<rosgraph_msgs::Clock>("/clock", 1, [this](const rosgraph_msgs::Clock::ConstPtr& c) { tick(c->clock.toSec()); });
    o.transport_hints = ros::TransportHints().tcpNoDelay();
    sub_ = nh.subscribe(o);
    active_ = true;
  }

  /// Unsubscribes. Idempotent.
  void stop()
  {
    active_ = false;
    sub_.shutdown();
  }

  /// Whether the ticks are watched (sim time).
  bool active() const { return active_; }

  /// ROS time (s): ros::Time::now(), or the last tick if roscpp has not taken it yet.
  double now() const
  {
    const double ros_now = ros::Time::now().toSec();
    return active() ? std::max(ros_now, latest_.load()) : ros_now;
  }

  /// Raise the flag when a tick reaches ROS time `t` (s; +inf: never), once. Returns false when the
  /// last tick already has (then no flag comes: the caller acts now).
  bool arm(double t)
  {
    armed_.store(t);
    if (latest_.load() >= t)
    {
      armed_.store(std::numeric_limits<double>::infinity());
      return false;
    }
    return true;
  }

  /// In the receive thread (its turn): whether a tick reached the armed time (or went back) since
  /// the last call.
  bool takeReached() { return reached_.load(std::memory_order_relaxed) && reached_.exchange(false); }

private:
  void tick(double t)
  {
    const double before = latest_.exchange(t);
    if (t >= armed_.load() || t < before)  // the deadline, or a clock that went back (a restart)
    {
      armed_.store(std::numeric_limits<double>::infinity());
      reached_ = true;
    }
  }

  InlineQueue queue_;
  ros::Subscriber sub_;
  std::atomic<bool> reached_{false};
  std::atomic<bool> active_{false};
  // (Sequentially consistent: arm() and tick() each store, then load what the other stores.)
  std::atomic<double> latest_{-std::numeric_limits<double>::infinity()};
  std::atomic<double> armed_{std::numeric_limits<double>::infinity()};
};

}  // namespace networked_estimation
