// Estimator nodelet: one estimator (kf, kfio, rseio, aoe, oe, ekfio) on a measurement stream. The
// nodelet keeps its configuration whole (EstimatorNodeConfig) and owns its parts: the inputs and
// steps (estimator_nodelet.cpp), what it publishes (EstimatorOutputs, estimator_outputs.hpp), its
// tf lookups (FrameLookup), the link diagnostics (LinkDiagnostics) and the estimator diagnostics
// (estimator_diagnostics.cpp), set_pose (estimator_set_pose.cpp).
//
// The input side is the core OnlineStream (online/online_stream.hpp): which stamps are believed and
// when the timeline starts and restarts, the latency budget the sensors' delays call for, and the
// OnlineEstimator's sample assembly: exactly one filter step per sample k, with gamma_k = 1 iff y_k
// is in hand at the deadline stamp_k + budget. A step is taken as soon as everything it can use has
// arrived (same result, lowest latency), otherwise at its deadline by the Estimator's own input
// thread (dispatch_thread.hpp), whose wait for the next message ends at that deadline (in ROS
// time; under sim time the /clock tick that reaches the deadline wakes it, sim_clock_watch.hpp).
// The nodelet only translates messages and parameters.
//
// Inputs: per sensor of the model, the topic, standard type and fields of its ~sensors block
// (sensor_subscriptions.hpp; default `measurement` for one sensor or `measurement/<sensor>` of
// ~input_type: networked_estimation/Measurement, sensor_msgs/Range or geometry_msgs/PointStamped),
// over the block's `transport` (TCPROS, or UDPROS with the TCPROS fallback: transport_watch.hpp).
// The step of a message without a step number is its sensor's sample step nearest to its stamp
// (SensorLattice); a sensor slower than the model is due only at its own steps. `command` (ControlInput, the
// commands before the actuator link) for models with control, and `schedule` (ScheduleStep) for a
// model with a random sensor schedule (a periodic one is known from k): a sensor that is not
// scheduled at k is not waited for and not counted as lost.
// Outputs: `estimate` (Estimate), `covariance_trace` (std_msgs/Float64), `pose`
// (PoseWithCovarianceStamped of ~position_indices), `odometry/filtered` (nav_msgs/Odometry of
// ~state_mapping, ~world_frame -> ~base_link_frame), tf ~frame_id -> ~child_frame_id (both per
// step, or with ~predict_to_current_time at ~frequency, predicted to the current time), diagnostics,
// and ~link_status (LinkStatus, one per sensor a second: the diagnostics' link numbers).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <algorithm>
#include <atomic>
#include <mutex>

#include "dispatch_thread.hpp"
#include "estimator_outputs.hpp"
#include "frame_lookup.hpp"
#include "gnss_alignment.hpp"
#include "link_diagnostics.hpp"
#include "load_failure.hpp"
#include "networked_estimation/EstimatorConfig.h"
#include "networked_estimation/ScheduleStep.h"
#include "networked_estimation/SetPose.h"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"
#include "networked_estimation/online/online_stream.hpp"
#include "networked_estimation/online/sensor_sample.hpp"
#include "param_yaml.hpp"
#include "sensor_subscriptions.hpp"
#include "sim_clock_watch.hpp"
#include "transport_watch.hpp"

namespace networked_estimation
{

class EstimatorNodelet : public nodelet::Nodelet
{
public:
  ~EstimatorNodelet() override
  {
    // The inputs first: roscpp's receive thread calls them directly (shutdown waits for a call in
    // progress), and they use everything below. Their queue (dispatch_) exists until the end.
    for (ros::Subscriber& s : subs_)
      s.shutdown();
    cmd_sub_.shutdown();
    schedule_sub_.shutdown();
    outputs_.stop();      // no tf and no wake() after this; off /tf (before the tf2 buffer goes)
    clock_watch_.stop();  // no wake() from a tick after this
    dispatch_.stop();
    if (gnss_)
      gnss_->stop();
  }

private:
  void onInit() override;

  static ros::TransportHints hints() { return ros::TransportHints().tcpNoDelay(); }
  uint32_t queueSize() const { return static_cast<uint32_t>(config_.queue_size); }

  /// dynamic_reconfigure: adaptive_latency, latency_budget, latency_budget_min/_max, late_policy,
  /// trace_bound (1e300 = no bound). Starts from the values in use (the server's first call, with
  /// what it read, is not applied). A change is validated as a whole (validateRuntimeSettings):
  /// refused with the key named, the settings in use kept and shown back.
  void startReconfigure(ros::NodeHandle& pnh);
  /// set_pose topic and service (estimator_set_pose.cpp).
  void startSetPose(ros::NodeHandle& nh);
  /// The filter starts over from the pose (into world_frame); false with `why` when refused.
  bool setPose(const geometry_msgs::PoseWithCovarianceStamped& m, std::string& why);
  void reconfigure(EstimatorConfig& c);

  /// The ENU origin of the NavSatFix inputs, latched on ~datum and logged (pin it with ~datum).
  void publishDatum(const LocalEnu& d);

  void configure(ros::NodeHandle& pnh);
  /// Sensor i's subscription (the last in subs_) to the transport watch.
  void watchTransport(ros::NodeHandle& nh, std::size_t i);

  // --- inputs (roscpp's receive thread, or the input thread) -------------------------------------

  /// covariance: message, and a message without one: counted, warned about (throttled).
  void covarianceFallback(const std::string& why);
  /// A message without an estimate of the sensor's fields (Imu covariance -1): not fused, counted.
  void onDisabled(std::size_t sensor, const ros::Time& stamp, const ros::Time& receipt, const std::string& why);

  /// A sensor's sample (s.step < 1: its step comes from its stamp, the sensor's own sample steps),
  /// received at `receipt`, the ROS time roscpp received the message at (its lateness is judged by
  /// it). Runs in roscpp's receive thread (or the input thread): a step it completes is queued
  /// (EstimatorOutputs::queueStep) and published by the same thread once out of the mutex; nothing
  /// is published under the mutex (ReceiveThreadQueue's rule).
  void offer(const SensorSample& s, const ros::Time& receipt);

  /// ROS time (or the receipt time of the message at hand), wall time and the measured rate of ROS
  /// time (mutex held).
  Clocks clocks(const ros::Time& receipt = ros::Time()) const;
  /// Logs a refused input, naming it (throttled).
  void warnRejected(const char* what, const OfferResult& r);

  void onSchedule(const ScheduleStep::ConstPtr& sc);

  /// A command: a ControlInput names its step; one of a standard type (`held`: a Twist on
  /// /cmd_vel...) takes the step nearest to its stamp (its arrival for unstamped types) and holds
  /// until the next one, as a robot base holds /cmd_vel: a step without a command of its own uses
  /// the latest earlier one.
  void onCommand(const CommandSample& c, bool held);
  /// In roscpp's receive thread, after a message: ROS time noted for the time-jump check, and (sim
  /// time) the /clock tick that wakes the input thread armed for the next deadline (mutex held).
  void afterInputLocked();

  void reject(const std::string& why);

  void rejectLocked(const std::string& why);

  unsigned long rejectedLocked() const;

  // --- steps -------------------------------------------------------------------------------------

  /// The estimate of step k, just taken (mutex held).
  StepEstimatePtr stepLocked(long k);

  /// Takes the steps whose deadline has passed (in ROS time) and restarts on a time jump (the
  /// stream's deadlines()); returns the wall seconds until the next deadline (the dispatch
  /// thread's wait).
  double deadlineWork();

  // --- diagnostics -------------------------------------------------------------------------------

  /// The inputs whose topic is advertised with another type than configured (ROS then connects
  /// nothing: without this check the sensor would just look silent), e.g.
  /// "sensor 'gps': /fix is geometry_msgs/PointStamped, expected sensor_msgs/NavSatFix".
  /// Asks the master only about the command topic and the sensors that heard nothing since the
  /// last report (one that receives has its type), at most every kWrongTypeSeconds (an idle
  /// Estimator called the master every second); in between, the last answer stands. Takes the
  /// mutex for the counts only (the diagnostics' thread).
  std::vector<std::string> wrongTypes();
  static constexpr double kWrongTypeSeconds = 5.0;

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// Per sensor: messages, losses, delay, disabled samples and rate; WARN for a sensor that lost more
  /// than 1 % of its messages over the last 10 s (late or refused), or whose stamps do not fit its
  /// rate (mutex held).
  void diagnoseSensors(diagnostic_updater::DiagnosticStatusWrapper& stat);

  /// The configuration, whole (read-only after onInit).
  EstimatorNodeConfig config_;
  std::unique_ptr<OnlineStream> stream_;
  RuntimeLimits limits_;
  /// gnss_alignment: navsat_transform (gnss_alignment.hpp); null with enu.
  std::unique_ptr<GnssAligner> gnss_;
  FrameLookup frames_;
  EstimatorOutputs outputs_;
  LinkDiagnostics link_;
  double trace_bound_ = std::numeric_limits<double>::infinity();  ///< reconfigurable (mutex_)
  ros::Publisher datum_pub_;

  DispatchThread dispatch_;    ///< in-process inputs, deadlines, tf (before the subscribers: outlives them)
  SimClockWatch clock_watch_;  ///< sim time: wakes dispatch_ when a /clock tick reaches the next deadline
  std::vector<ros::Subscriber> subs_;
  ros::Subscriber cmd_sub_, schedule_sub_, set_pose_sub_;
  /// The transport each input got (udp may fall back to TCPROS); the diagnostics' thread only.
  TransportWatch transports_;
  ros::ServiceServer set_pose_srv_;
  std::atomic<unsigned long> set_pose_refused_{0};
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diag_timer_;
  /// The last diagnostics' per-sensor latency figures, for ~link_status (the diagnostics' thread only).
  std::vector<LatencyBudget::Figures> latency_figures_;

  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<EstimatorConfig>> reconfigure_;
  bool reconfigure_ready_ = false;
  EstimatorConfig shown_;  ///< the settings in use, as the reconfigure server shows them

  std::mutex mutex_;
  /// Sim time: sim seconds per wall second, measured by the deadline loop (sim_ref_/wall_ref_).
  double clock_rate_ = 1.0, sim_ref_ = 0.0, wall_ref_ = 0.0;
  double last_trace_ = 0.0;
  int deferred_ = 0;  ///< deadline work deferred for queued messages, in a row
  std::uint64_t rejected_topic_ = 0, last_processed_ = 0, covariance_fallbacks_ = 0;
  ros::WallTime last_diag_;
  /// wrongTypes(): the sensors' messages at the last report, the last answer and when it was asked.
  std::vector<std::uint64_t> heard_;
  std::vector<std::string> wrong_;
  ros::WallTime wrong_asked_;
};

}  // namespace networked_estimation
