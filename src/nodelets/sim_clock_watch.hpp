// Sim time: a nodelet's own view of /clock, and a call when a tick reaches a time it waits for.
//
// Why: under /use_sim_time, ROS time moves only at /clock ticks, which no wait can foresee. A thread
// waiting for a deadline in ROS time had to look at the clock every 2 ms: at -r 4 with rosbag's
// 100 Hz /clock, about five wake-ups per tick, most of them for nothing, and most of an idle
// Estimator's CPU. Here the tick itself wakes the thread, once, when it reaches the deadline.
//
// The ticks are read in roscpp's receive thread (InlineQueue): the callback only stores the time
// and, when it reaches the armed time (or the clock went back), calls `reached` (which must be as
// light: DispatchThread::wake). roscpp's own ROS time follows the tick a moment later, from its
// internal thread: now() takes the later of the two, so that the woken thread sees the deadline
// passed.
#pragma once

#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>

#include <algorithm>
#include <atomic>
#include <functional>
#include <limits>
#include <utility>

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

  /// Under sim time, subscribes /clock and calls `reached` from roscpp's receive thread when a tick
  /// reaches the armed time; in wall time does nothing (active() stays false).
  void start(ros::NodeHandle nh, std::function<void()> reached)
  {
    if (!ros::Time::isSimTime())
      return;
    reached_ = std::move(reached);
    nh.setCallbackQueue(&queue_);
    ros::SubscribeOptions o;
    o.init<rosgraph_msgs::Clock>("/clock", 1,
                                 [this](const rosgraph_msgs::Clock::ConstPtr& c) { tick(c->clock.toSec()); });
    o.transport_hints = ros::TransportHints().tcpNoDelay();
    sub_ = nh.subscribe(o);
    active_ = true;
  }

  /// Unsubscribes (no call after it returns). Idempotent.
  void stop()
  {
    active_ = false;
    sub_.shutdown();
  }

  /// Whether the ticks are watched (sim time).
  bool active() const { return active_; }

  /// ROS time (s): ros::Time::now(), or the last tick when roscpp has not taken it yet.
  double now() const
  {
    const double ros_now = ros::Time::now().toSec();
    return active() ? std::max(ros_now, latest_.load()) : ros_now;
  }

  /// Call `reached` once when a tick reaches ROS time `t` (s). Returns false when the last tick
  /// already has (no call comes then: the caller acts now).
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

private:
  void tick(double t)
  {
    const double before = latest_.exchange(t);
    if (t >= armed_.load() || t < before)  // the deadline, or a clock that went back (a restart)
    {
      armed_.store(std::numeric_limits<double>::infinity());
      reached_();
    }
  }

  InlineQueue queue_;
  ros::Subscriber sub_;
  std::function<void()> reached_;
  std::atomic<bool> active_{false};
  // (Sequentially consistent: arm() and tick() each store, then load what the other stores, so
  // that a tick between the two is seen by one of them.)
  std::atomic<double> latest_{-std::numeric_limits<double>::infinity()};
  std::atomic<double> armed_{std::numeric_limits<double>::infinity()};
};

}  // namespace networked_estimation
