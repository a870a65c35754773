// The Estimator's input side as one ROS-free object: messages in (with their stamps and the ROS
// time they arrived at), filter steps out. It joins
// - the Timeline: which stamps are believed, the anchor, restarts on time jumps, the catch-up
//   work bound (timeline.hpp);
// - the LatencyBudget: each sensor's delays, the deadline they call for, losses to lateness
//   (latency_budget.hpp);
// - the OnlineEstimator: slots, due sensors (SensorLattice), late policies (online_estimator.hpp).
// The nodelet translates messages, calls in here under its lock, and publishes each step from the
// after_step hook.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/online/latency_budget.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/online/runtime_settings.hpp"
#include "networked_estimation/online/sensor_sample.hpp"
#include "networked_estimation/online/timeline.hpp"

namespace networked_estimation
{

/// The clocks at a call: ROS time and wall time (s), and how fast ROS time runs (sim time: a bag
/// played at -r 4 runs at 4; wall time: 1).
struct Clocks
{
  double ros = 0.0;
  double wall = 0.0;
  double rate = 1.0;
};

class OnlineStream
{
public:
  /// Throws ConfigError (as OnlineEstimator). `runtime` must be valid (validateRuntimeSettings).
  OnlineStream(const Model& model, const EstimatorSettings& settings, const OnlineOptions& online,
               const TimelineOptions& timeline, const RuntimeSettings& runtime);

  /// Called after each step k is taken (estimator() holds x_{k|k}): publish it.
  std::function<void(long k)> after_step;
  /// Called when everything starts over (why: a time jump, a contradicted anchor).
  std::function<void(const std::string& why)> on_restart;

  /// A sensor's message (sensor_sample.hpp): y of s.sensor stamped s.stamp (s) naming step s.step
  /// (>= 1; otherwise none, its step then comes from its stamp). Refused stamps come back REJECTED
  /// with the reason.
  OfferResult measurement(const SensorSample& s, const Clocks& now);
  /// A sensor's message that disabled the sensor's fields (sensor_msgs' covariance -1).
  OfferResult disabled(std::size_t sensor, double stamp, long step, const Clocks& now);
  /// A command naming its step c.step, stamped c.stamp (ControlInput). Ignored (ACCEPTED) before the
  /// timeline starts.
  OfferResult command(const CommandSample& c, const Clocks& now);
  /// A command of a type without a step (a Twist on /cmd_vel; c.step is not read): its step is the
  /// nearest one to its stamp c.stamp, and it holds until the next one (a step without a command of
  /// its own uses the latest earlier one), as a robot base holds /cmd_vel.
  OfferResult heldCommand(const CommandSample& c, const Clocks& now);
  /// A random schedule's draw for a step (it may start the timeline, as a measurement).
  OfferResult schedule(long step, double stamp, const std::vector<bool>& transmitting, const Clocks& now);

  /// Takes the steps whose deadline has passed (within the work bound), and starts over when ROS
  /// time went back or jumped forward past max_stamp_behind. Returns true when steps are still due
  /// (the caller comes back at once, after letting the inputs in).
  bool deadlines(const Clocks& now);
  /// Notes ROS time for deadlines()'s check that it went back, and starts over as it does when it
  /// has; takes no step. For a thread that takes the steps its messages complete but not those
  /// whose deadline passes (the Estimator's receive thread): without it, a clock that ran on and
  /// then went back to a time after deadlines()'s last look would not count as going back.
  void observe(const Clocks& now);
  /// The ROS time at which the next step is due: its deadline, or, when everything it can use is in
  /// hand, its stamp minus Timeline::kAhead (no step is taken earlier: no estimate is stamped more
  /// than kAhead ahead of ROS time); +inf before the timeline starts.
  double nextDeadline() const;
  /// Whether the work bound held back a due step at the last deadlines() call.
  bool throttled() const { return throttled_; }

  /// set_pose: the filter starts over from x, P (OnlineEstimator::setEstimate; throws InputError
  /// for a bad estimate, nothing changed).
  void setEstimate(const Eigen::VectorXd& x, const Eigen::MatrixXd& P) { online_->setEstimate(x, P); }

  /// New runtime settings (validated by the caller): budget, late policy.
  void setRuntime(const RuntimeSettings& runtime);
  const RuntimeSettings& runtime() const { return runtime_; }

  const OnlineEstimator& online() const { return *online_; }
  const Timeline& timeline() const { return timeline_; }
  const LatencyBudget& latency() const { return latency_; }
  double budget() const { return timeline_.clock().budget(); }

  /// Per sensor: messages refused for their stamp (Timeline; a poisoned anchor counts at the
  /// restart that discards it). Timeline restarts (a contradicted
  /// anchor), time resets (ROS time back, or forward past max_stamp_behind), and messages refused
  /// for their stamp that belong to no sensor (commands, schedules).
  const std::vector<std::uint64_t>& refusedPerSensor() const { return refused_; }
  std::uint64_t restarts() const { return restarts_; }
  std::uint64_t timeResets() const { return time_resets_; }
  std::uint64_t refusedOther() const { return refused_other_; }
  /// The reason of the last refusal, restart, ... and the wall time (Clocks::wall) it happened at.
  struct Event
  {
    std::string reason;  ///< empty: none yet
    double wall = 0.0;
  };
  /// Per sensor: its last message refused for its stamp (Timeline's reason: stamp 0, too far ahead
  /// or behind ROS time, off its step; or it anchored the timeline and a later message contradicted
  /// it, counted at the restart); and the same for commands and schedules.
  const Event& lastRefused(std::size_t sensor) const { return last_refused_[sensor]; }
  const Event& lastRefusedOther() const { return last_refused_other_; }
  /// The last timeline restart (a contradicted anchor, five misfits in a row).
  const Event& lastRestart() const { return last_restart_; }
  /// What the diagnostics warn about at wall time `wall` (s): per sensor that had a message refused
  /// for its stamp over the last kRecentSeconds, "sensor '<name>': <n> messages refused for their
  /// stamp, the last <t> s ago: <reason>" (n: since the start); the same for commands and
  /// schedules; and "timeline restarted <t> s ago: <reason>".
  std::vector<std::string> stampWarnings(double wall) const;
  static constexpr double kRecentSeconds = 10.0;
  /// |stamp - its step's grid time| of the messages placed by their stamp: mean, max, count.
  double offsetMean() const { return offset_count_ ? offset_sum_ / static_cast<double>(offset_count_) : 0.0; }
  double offsetMax() const { return offset_max_; }
  std::uint64_t offsetCount() const { return offset_count_; }

private:
  /// The timeline's verdict on a message (sensor: its index, or npos); anchors or restarts as it
  /// says. False: refused (counted), with the reason in `refusal`.
  bool admit(std::size_t sensor, double stamp, long step, const Clocks& now, OfferResult& refusal);
  /// A sensor's message arriving: index checked, admitted by the timeline, placed (its step
  /// position), and the steps whose deadline passed taken. False: refused, `r` says why.
  bool arrive(std::size_t sensor, double stamp, long step, const Clocks& now, OfferResult& r, double& position);
  /// A command's stamp checked by the timeline; false: refused (counted), `r` says why.
  bool admitCommand(double stamp, const Clocks& now, OfferResult& r);
  /// Counts a message refused for its stamp (sensor: its index, or npos: a command or schedule).
  void refuse(std::size_t sensor, const std::string& why, const Clocks& now);
  void restart(const std::string& why);
  void catchUp(const Clocks& now);
  /// Takes the steps that are complete, from the next one on, while ROS time (`now`) allows.
  void drainComplete(const Clocks& now);
  /// The earliest ROS time step k may be taken at (its stamp minus Timeline::kAhead).
  double gate(long k) const;
  void step();
  void offerHeld(long k);
  /// The step of a sensor's message and its delay recorded (the budget follows).
  long place(std::size_t sensor, double stamp, long step, const Clocks& now, double& position);

  std::unique_ptr<OnlineEstimator> online_;
  Timeline timeline_;
  LatencyBudget latency_;
  RuntimeSettings runtime_;
  std::map<double, std::vector<double>> held_;  ///< held command type: commands by stamp (s)
  double last_now_ = -std::numeric_limits<double>::infinity();
  /// Starts over when ROS time went back by over half a period since the last look (true), else
  /// notes it.
  bool wentBack(const Clocks& now);
  bool throttled_ = false;
  std::vector<std::uint64_t> refused_;
  std::uint64_t restarts_ = 0, time_resets_ = 0, refused_other_ = 0;
  std::vector<Event> last_refused_;
  std::size_t anchor_sensor_ = 0;  ///< the sensor of the message the timeline was anchored on
  Event last_refused_other_, last_restart_;
  double offset_sum_ = 0.0, offset_max_ = 0.0;
  std::uint64_t offset_count_ = 0;
};

}  // namespace networked_estimation
