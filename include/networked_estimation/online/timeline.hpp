// The Estimator's timeline: which stamps it believes, when it starts and restarts, and how much
// catching up it may do (docs/ros_interface.md, "Time").
//
// Steps are numbered on a grid stamp_k = t0 + k period anchored on a message. No single message
// may anchor or move it:
// - every message's stamp is checked against ROS time first: a stamp of 0 (or below), one more
//   than max_ahead seconds ahead of ROS time or more than max_behind behind it is refused (the
//   caller counts it), so a sensor with a broken clock never becomes the timeline;
// - the first plausible message anchors the timeline provisionally, and no step is taken before ROS
//   time reaches its stamp minus kAhead (OnlineStream), so no estimate is ever stamped more than
//   kAhead ahead of ROS time, whatever the anchor (kAhead leaves room for a simulated clock's ticks
//   and for clocks a little apart);
// - while nothing confirms the anchor, a message that contradicts it restarts the timeline on
//   itself: a named step whose stamp is more than kAgree off the grid, or, when the anchor lies
//   more than kAhead ahead of ROS time, a message in the present (a named step more than kAhead off
//   the grid, a stamp more than kAhead before the anchor). A message cannot confirm an anchor that
//   lies ahead of ROS time. So after a poisoned first message stamped ahead of ROS time (within
//   max_ahead, or any stamp before the clock exists), the first good message starts the timeline.
//   Once confirmed, a message whose stamp does not fit its named step is refused, and only
//   kMisfitsToRestart of them in a row restart it (the stream itself jumped);
// - ROS time going back (a looped bag) restarts it (the caller's time-jump reset), and so does a
//   next deadline more than max_behind behind ROS time (time jumped forward, or the estimator
//   stalled): nothing older than max_behind can still arrive in time, so the backlog is skipped
//   rather than ground through;
// - the steps taken to catch up with ROS time are limited per wall second: at most twice the
//   rate ROS time needs (the model's rate times the clock's rate, at least 1) plus a burst of one
//   max_behind backlog, kept as a token bucket.
#pragma once

#include <limits>
#include <string>

#include "networked_estimation/online/online_estimator.hpp"

namespace networked_estimation
{

struct TimelineOptions
{
  double period = 0.0;
  double max_ahead = 10.0;  ///< max_stamp_ahead (s)
  double max_behind = 3.0;  ///< max_stamp_behind (s)
};

class Timeline
{
public:
  /// A stamp fits its named step's grid time within this (s).
  static constexpr double kAgree = 1.0;
  static constexpr int kMisfitsToRestart = 5;
  /// How far ahead of ROS time a step's stamp may be when it is taken, and an anchor may lie before
  /// a message in the present contradicts it (s): a bag's /clock at -r 10 moves in 0.1 s ticks.
  static constexpr double kAhead = 0.25;

  /// Options are not validated here (parseEstimatorNodeConfig does it).
  Timeline(const TimelineOptions& options, double latency_budget);

  enum class Verdict
  {
    ACCEPT,   ///< offer it
    ANCHOR,   ///< the timeline is not anchored: anchor it on this message, then offer it
    RESTART,  ///< start over (reset the estimator), anchor on this message, then offer it
    REFUSE    ///< refuse it (reason), counted by the caller
  };
  struct Admission
  {
    Verdict verdict = Verdict::ACCEPT;
    std::string reason;
  };
  /// A message stamped `stamp` (s) naming step `step` (>= 1) or none (-1), at ROS time `now` (s;
  /// 0: no clock yet under sim time, then only the stamp of 0 is checked).
  Admission admit(double stamp, long step, double now);
  /// Only the check against ROS time (for inputs that cannot anchor, e.g. commands).
  Admission plausible(double stamp, double now) const;

  /// Anchors the grid on step k stamped `stamp`.
  void anchor(long k, double stamp);
  bool anchored() const { return clock_.anchored(); }
  /// Whether a message agreed with the anchor (a restart before that discards a poisoned anchor).
  bool confirmed() const { return confirmed_; }
  /// The stamp the timeline was anchored on.
  double anchorStamp() const { return anchor_stamp_; }
  /// A step was taken on this anchor (a stamp-only anchor is then kept).
  void stepped() { stepped_ = true; }
  /// Back to unanchored (a restart).
  void clear();

  StepClock& clock() { return clock_; }
  const StepClock& clock() const { return clock_; }
  /// The continuous step position of a stamp: (stamp - t0) / period.
  double position(double stamp) const;

  /// Whether the deadline of step `next` lies more than max_behind behind ROS time `now`.
  bool stale(long next, double now) const;
  /// Steps that may be taken for catching up at wall time `wall` (s), with ROS time running
  /// `clock_rate` times as fast as wall time; spend() what was taken.
  long allowance(double wall, double clock_rate);
  void spend(long steps) { tokens_ -= static_cast<double>(steps); }

  const TimelineOptions& options() const { return options_; }
  void setOptions(const TimelineOptions& options) { options_ = options; }

private:
  /// admit() after the check against ROS time: the verdict of the anchor and the grid.
  Admission decide(double stamp, long step, double now);

  TimelineOptions options_;
  StepClock clock_;
  long first_step_ = 1;
  double anchor_stamp_ = 0.0;
  bool confirmed_ = false, stepped_ = false;
  int misfits_ = 0;
  double tokens_ = 0.0, last_wall_ = 0.0;
  bool bucket_started_ = false;
};

}  // namespace networked_estimation
