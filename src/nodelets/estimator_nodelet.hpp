// Estimator nodelet: one estimator (kf, kfio, rseio, aoe, oe) on a measurement stream
// (estimator_nodelet.cpp: parameters and inputs; estimator_steps.cpp: the steps and when they are
// published; estimator_outputs.cpp: what it publishes).
//
// The input side is the core OnlineStream (online/online_stream.hpp): which stamps are believed and
// when the timeline starts and restarts, the latency budget the sensors' delays call for, and the
// OnlineEstimator's sample assembly: exactly one filter step per sample k, with gamma_k = 1 iff y_k
// is in hand at the deadline stamp_k + budget. A step is taken as soon as everything it can use has
// arrived (same result, lowest latency), otherwise at its deadline by the Estimator's own thread
// (dispatch_thread.hpp), which sleeps until that deadline (in ROS time), or under sim time by
// roscpp's receive thread after the /clock tick that reaches it (sim_clock_watch.hpp). The inputs are handled in the thread that
// delivers them (InlineQueue: roscpp's receive thread, or an in-process publisher's), with no
// hand-off; the steps they complete are published from an Outbox (outbox.hpp) after the lock is
// released, by that thread, or by the receive thread on its next turn (PollTurnHook). The
// nodelet only translates messages and parameters.
//
// Inputs: per sensor of the model, the topic, standard type and fields of its ~sensors block
// (sensor_subscriptions.hpp; default `measurement` for one sensor or `measurement/<sensor>` of
// ~input_type: networked_estimation/Measurement, sensor_msgs/Range or geometry_msgs/PointStamped).
// The step of a message without a step number is its sensor's sample step nearest to its stamp
// (SensorLattice); a sensor slower than the model is due only at its own steps. `command` (ControlInput, the
// commands before the actuator link) for models with control, and `schedule` (ScheduleStep) for a
// model with a random sensor schedule (a periodic one is known from k): a sensor that is not
// scheduled at k is not waited for and not counted as lost.
// Outputs: `estimate` (Estimate), `covariance_trace` (std_msgs/Float64), `pose`
// (PoseWithCovarianceStamped of ~position_indices), `odometry/filtered` (nav_msgs/Odometry of
// ~state_mapping, ~world_frame -> ~base_link_frame), tf ~frame_id -> ~child_frame_id, diagnostics.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <std_msgs/Float64.h>
#include <tf2_ros/buffer.h>
#include <tf2/exceptions.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>

#include "networked_estimation/ControlInput.h"
#include "networked_estimation/EstimatorConfig.h"
#include "networked_estimation/Estimate.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/ScheduleStep.h"
#include "networked_estimation/SetPose.h"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"
#include "networked_estimation/config/rate_schedule.hpp"
#include "networked_estimation/stability/live_stability.hpp"
#include "networked_estimation/online/online_stream.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "load_failure.hpp"
#include "param_yaml.hpp"
#include "odometry_output.hpp"
#include "tf_output.hpp"
#include "sensor_subscriptions.hpp"
#include "dispatch_thread.hpp"
#include "outbox.hpp"
#include "sim_clock_watch.hpp"
#include <tf2_msgs/TFMessage.h>

namespace networked_estimation
{

class EstimatorNodelet : public nodelet::Nodelet
{
public:
  ~EstimatorNodelet() override
  {
    poll_hook_.reset();  // waits for a turn of the receive thread that is publishing
    clock_watch_.stop();
    dispatch_.stop();
    // Before the tf2 buffer the input callbacks use goes, and while their queue exists.
    for (ros::Subscriber& s : subs_)
      s.shutdown();
    cmd_sub_.shutdown();
    schedule_sub_.shutdown();
    tf_sub_.shutdown();
    tf_static_sub_.shutdown();
  }

private:
  void onInit() override;

  static ros::TransportHints hints() { return ros::TransportHints().tcpNoDelay(); }

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

  /// world_frame and base_link_frame, looked up in tf2 at the message's stamp (a missing or
  /// extrapolated transform rejects the message, naming both frames).
  /// (Built once, with the tf2 buffer and listener, on the first call.)
  const Frames& frames();

  /// The ENU origin of the NavSatFix inputs, latched on ~datum and logged (pin it with ~datum):
  /// queued for publishPending (it may come from an input callback).
  void publishDatum(const LocalEnu& d);

  void configure(ros::NodeHandle& pnh);


  // --- inputs (the thread that delivers them: InlineQueue) ---------------------------------------

  /// `receipt`: the ROS time roscpp received the message at (its lateness is judged by it).
  void onMeasurement(std::size_t sensor, const Measurement::ConstPtr& m, const ros::Time& receipt);

  void measurement(std::size_t sensor, const Measurement::ConstPtr& m, const ros::Time& receipt);

  /// covariance: message, and a message without one: counted, warned about (throttled).
  void covarianceFallback(const std::string& why);
  /// A message without an estimate of the sensor's fields (Imu covariance -1): not fused, counted.
  void onDisabled(std::size_t sensor, const ros::Time& stamp, const ros::Time& receipt, const std::string& why);

  /// k < 0: the step comes from the stamp (the sensor's own sample steps). The steps it completes
  /// go to the outbox (in step order, whichever thread takes them).
  void offer(std::size_t sensor, long k, double stamp, const ros::Time& receipt, const double* y, std::size_t size,
             const double* R = nullptr);

  /// ROS time (or the receipt time of the message at hand), wall time and the measured rate of ROS
  /// time (mutex held).
  Clocks clocks(const ros::Time& receipt = ros::Time()) const;
  /// After an input's work, with the mutex released: its steps published (by this thread, or by the
  /// receive thread's next turn when this is it), the dispatch thread woken if the next deadline is
  /// earlier than it waits for.
  void afterInput();
  /// A turn of roscpp's receive thread (PollTurnHook): publishes what its input callbacks made, and
  /// under sim time takes the steps whose deadline a /clock tick reached.
  void pollTurn();
  /// What the steps left to publish (the outbox, a new datum), with no lock of ours held.
  void publishPending();
  /// Sets what the dispatch thread waits for to the next deadline (mutex held); true when it must
  /// be woken to act on it now.
  bool armLocked();

  /// Logs a refused input, naming it (throttled).
  void warnRejected(const char* what, const OfferResult& r);

  void onCommand(const ControlInput::ConstPtr& c);

  void onSchedule(const ScheduleStep::ConstPtr& sc);

  /// A command of a standard type (a Twist on /cmd_vel...): its step is the nearest one to its
  /// stamp (its arrival for unstamped types), and it holds until the next one, as a robot base
  /// holds /cmd_vel: a step without a command of its own uses the latest earlier one.
  void onHeldCommand(const ros::Time& stamp, const double* u, std::size_t n);

  void reject(const std::string& why);

  void rejectLocked(const std::string& why);

  unsigned long rejectedLocked() const;

  // --- steps -------------------------------------------------------------------------------------

  /// The message of step k, just taken (mutex held).
  Estimate::Ptr stepLocked(long k);

  /// Publishes one step's outputs (from the outbox: no lock of ours held).
  void publishOutputs(const Estimate::Ptr& e);

  /// odometry/filtered of one estimate (~state_mapping, world_frame -> base_link_frame).
  void publishOdometry(const Estimate& e);

  /// One estimate as the tf frame_id -> child_frame_id (with every estimate, as robot_localization
  /// sends its tf with every filter cycle; from publishOutputs).
  void publishTf(const Estimate& e);
  void sendTf(const geometry_msgs::TransformStamped& t);
  /// /tf and /tf_static (InlineQueue): into the tf2 buffer, and base_link's parent from other
  /// publishers than ourselves (ForeignParent).
  void onTf(const ros::MessageEvent<tf2_msgs::TFMessage const>& e, bool static_tf);

  /// Takes the steps whose deadline has passed (in ROS time) and restarts on a time jump (the
  /// stream's deadlines()), then publishes them; returns the wall seconds until the next deadline
  /// (the dispatch thread's wait).
  double deadlineWork();
  double deadlineWorkLocked();

  // --- diagnostics -------------------------------------------------------------------------------

  /// The inputs whose topic is advertised with another type than configured (ROS then connects
  /// nothing: without this check the sensor would just look silent), e.g.
  /// "sensor 'gps': /fix is geometry_msgs/PointStamped, expected sensor_msgs/NavSatFix".
  /// Asked only for the inputs that heard no message since the last call (diagnostics' thread).
  std::vector<std::string> wrongTypes();

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat);
  /// Per sensor: messages, losses, delay, disabled samples and rate; WARN for a sensor that lost more
  /// than 1 % of its messages over the last 10 s (late or refused), or whose stamps do not fit its
  /// rate (mutex held).
  void diagnoseSensors(diagnostic_updater::DiagnosticStatusWrapper& stat);

  void diagnoseLink(diagnostic_updater::DiagnosticStatusWrapper& stat);

  EstimatorSettings settings_;
  std::unique_ptr<OnlineStream> stream_;
  RuntimeLimits limits_;
  std::unique_ptr<LiveStability> live_;
  /// A built-in motion (docs/stability.md 5): the motion model, the sensors' rate ratios, and the
  /// verdicts of its linearisation at the estimate, rebuilt in diagnoseLink when the Jacobian moved
  /// (the diagnostics' thread only).
  std::unique_ptr<const Model> motion_model_;
  std::vector<double> rate_ratios_;
  std::unique_ptr<LiveStability> local_;
  std::uint64_t relinearisations_ = 0;
  std::uint64_t resets_seen_ = 0;  ///< divergence resets of the filter already told to live_

  std::string input_type_, frame_id_, child_frame_id_;
  std::vector<SensorInput> inputs_;
  /// Messages received per input (the sensors, then the command; any thread) and as wrongTypes()
  /// last saw them (the diagnostics' thread).
  std::unique_ptr<std::atomic<std::uint64_t>[]> heard_;
  std::vector<std::uint64_t> heard_seen_;
  SensorInput command_;
  StateMap state_map_;
  std::string world_frame_, base_link_frame_, odom_frame_;
  std::vector<double> datum_;
  ros::Publisher datum_pub_;
  std::vector<int> positions_;
  bool publish_tf_ = true;
  double trace_bound_ = std::numeric_limits<double>::infinity();
  uint32_t queue_size_ = 1000;

  DispatchThread dispatch_;  ///< takes the steps at their deadlines (before the subscribers: outlives them)
  InlineQueue inputs_queue_;  ///< the input subscriptions' (before them: outlives them)
  /// Estimates to publish, in step order (publishOutputs).
  Outbox<Estimate::Ptr> outbox_{[this](const Estimate::Ptr& e) { publishOutputs(e); }};
  std::atomic<bool> poll_pending_{false};  ///< the receive thread made steps: its next turn publishes them
  std::unique_ptr<PollTurnHook> poll_hook_;
  SimClockWatch clock_watch_;  ///< sim time: the tick that reaches the next deadline
  double wait_until_ = std::numeric_limits<double>::infinity();  ///< wall time: the deadline it sleeps until (mutex_)
  std::mutex datum_mutex_;
  sensor_msgs::NavSatFix::Ptr pending_datum_;  ///< to publish (datum_mutex_)
  std::vector<ros::Subscriber> subs_;
  ros::Subscriber cmd_sub_, schedule_sub_, tf_sub_, tf_static_sub_, set_pose_sub_;
  ros::ServiceServer set_pose_srv_;
  std::atomic<unsigned long> set_pose_refused_{0};
  ros::Publisher estimate_pub_, trace_pub_, pose_pub_, odom_pub_;
  ros::Publisher tf_pub_;  ///< /tf
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  Frames frames_;
  /// child_frame_id = base_link_frame: the transforms we sent, and base_link's parent from others;
  /// the ROS time of the last tf message (a clock that went back clears the buffer).
  std::mutex tf_mutex_;
  ros::Time last_tf_update_;
  OwnTransforms own_tf_;
  ForeignParent foreign_parent_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diag_timer_;

  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<EstimatorConfig>> reconfigure_;
  bool reconfigure_ready_ = false;
  EstimatorConfig shown_;  ///< the settings in use, as the reconfigure server shows them

  std::mutex mutex_;
  /// Sim time: sim seconds per wall second, measured by the deadline loop (sim_ref_/wall_ref_).
  double clock_rate_ = 1.0, sim_ref_ = 0.0, wall_ref_ = 0.0;
  double last_trace_ = 0.0;
  std::uint64_t rejected_topic_ = 0, last_processed_ = 0, covariance_fallbacks_ = 0;
  ros::WallTime last_diag_;
};

}  // namespace networked_estimation
