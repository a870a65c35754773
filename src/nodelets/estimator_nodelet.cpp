// Estimator nodelet: one estimator (kf, kfio, rseio, aoe, oe) on a measurement stream.
//
// The sample assembly is the core OnlineEstimator: exactly one filter step per sample k, with
// gamma_k = 1 iff y_k is in hand at the deadline stamp_k + latency_budget. A step is taken as soon
// as everything it can use has arrived (same result, lowest latency), otherwise at its deadline by
// a thread that sleeps in ROS time. This file only translates messages and parameters.
//
// Inputs: per sensor of the model, the topic, standard type and fields of its ~sensors block
// (sensor_subscriptions.hpp; default `measurement` for one sensor or `measurement/<sensor>` of
// ~input_type: networked_estimation/Measurement, sensor_msgs/Range or geometry_msgs/PointStamped).
// The step of a message without a step number is the nearest k to its stamp; a sensor slower than
// the model is due only at its own steps. `command` (ControlInput, the
// commands before the actuator link) for models with control, and `schedule` (ScheduleStep) for a
// model with a random sensor schedule (a periodic one is known from k): a sensor that is not
// scheduled at k is not waited for and not counted as lost.
// Outputs: `estimate` (Estimate), `covariance_trace` (std_msgs/Float64), `pose`
// (PoseWithCovarianceStamped of ~position_indices), `odometry/filtered` (nav_msgs/Odometry of
// ~state_mapping, ~world_frame -> ~base_link_frame), tf ~frame_id -> ~child_frame_id, diagnostics.
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>
#include <std_msgs/Float64.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

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
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"
#include "networked_estimation/stability/live_stability.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "load_failure.hpp"
#include "param_yaml.hpp"
#include "odometry_output.hpp"
#include "tf_output.hpp"
#include "sensor_subscriptions.hpp"
#include "worker.hpp"

namespace networked_estimation
{

class EstimatorNodelet : public nodelet::Nodelet
{
public:
  ~EstimatorNodelet() override
  {
    stopWorker(mutex_, stop_, wake_, thread_);
    // Before the tf2 buffer the input callbacks use goes.
    for (ros::Subscriber& s : subs_)
      s.shutdown();
    cmd_sub_.shutdown();
  }

private:
  void onInit() override
  {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    try
    {
      configure(pnh);
    }
    catch (const ConfigError& e)
    {
      refuseLoad(getName(), std::string("Estimator not started: ") + e.what());
    }
    estimate_pub_ = nh.advertise<Estimate>("estimate", 1000);
    trace_pub_ = nh.advertise<std_msgs::Float64>("covariance_trace", 1000);
    pose_pub_ = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 100);
    odom_pub_ = nh.advertise<nav_msgs::Odometry>("odometry/filtered", 100);
    const Model& model = online_->model();
    if (!datum_.empty() || std::any_of(inputs_.begin(), inputs_.end(), [](const SensorInput& in) {
          return in.type == InputType::NAVSATFIX;
        }))
      datum_pub_ = pnh.advertise<sensor_msgs::NavSatFix>("datum", 1, true);
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
    {
      const SensorInput& in = inputs_[i];
      if (in.type == InputType::MEASUREMENT)
      {
        subs_.push_back(nh.subscribe<Measurement>(
            in.topic, queue_size_, [this, i](const Measurement::ConstPtr& m) { onMeasurement(i, m); },
            ros::VoidConstPtr(), hints()));
        continue;
      }
      SensorSink sink;
      sink.ok = [this, i](const ros::Time& stamp, const double* y, std::size_t n) { onForeign(i, stamp, y, n); };
      const std::string who = "sensor '" + model.sensors[i].name + "' (" + toString(in.type) + " on " + in.topic + ")";
      sink.bad = [this, who](const std::string& why) { reject(who + ": " + why); };
      sink.datum = [this](const LocalEnu& d) { publishDatum(d); };
      sink.frames = frames();
      subs_.push_back(subscribeSensor(nh, in, queue_size_, sink, datum_));
    }
    if (!datum_.empty())
    {
      const LocalEnu d(datum_[0], datum_[1], datum_[2]);
      publishDatum(d);
    }
    if (model.hasControl() && command_.type == InputType::CONTROL_INPUT)
      cmd_sub_ = nh.subscribe(command_.topic, queue_size_, &EstimatorNodelet::onCommand, this, hints());
    else if (model.hasControl())
    {
      SensorSink sink;
      sink.ok = [this](const ros::Time& stamp, const double* u, std::size_t n) { onHeldCommand(stamp, u, n); };
      const std::string who = "command (" + toString(command_.type) + " on " + command_.topic + ")";
      sink.bad = [this, who](const std::string& why) { reject(who + ": " + why); };
      sink.frames = frames();
      cmd_sub_ = subscribeSensor(nh, command_, queue_size_, sink, {});
    }
    if (model.schedule.kind == Schedule::Kind::RANDOM)
      schedule_sub_ = nh.subscribe("schedule", queue_size_, &EstimatorNodelet::onSchedule, this, hints());
    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
    diagnostics_->setHardwareID(toString(settings_.algorithm));
    diagnostics_->add("estimator", this, &EstimatorNodelet::diagnose);
    diagnostics_->add("link stability", this, &EstimatorNodelet::diagnoseLink);
    // force_update: the updater's own period check uses ROS time, which stalls or jumps under sim time.
    diag_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) { diagnostics_->force_update(); });
    if (publish_tf_)
    {
      if (child_frame_id_ == base_link_frame_)
        frames();  // listen to tf from the start: base_link's parent decides what we publish
      tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
      tf_timer_ = nh.createWallTimer(ros::WallDuration(0.05), [this](const ros::WallTimerEvent&) { tfTimer(); });
    }
    startReconfigure(pnh);
    thread_ = std::thread(&EstimatorNodelet::deadlineLoop, this);
    std::string inputs;
    for (std::size_t i = 0; i < inputs_.size(); ++i)
      inputs += (i ? ", " : "") + model.sensors[i].name + " (" + toString(inputs_[i].type) + " on " +
                nh.resolveName(inputs_[i].topic) + ")";
    NODELET_INFO("Estimator %s on '%s' (n = %d): period %g s, latency_budget %g s, late_policy %s; inputs: %s",
                 toString(settings_.algorithm).c_str(), model.name.c_str(), model.n(), clock_.period(), clock_.budget(),
                 toString(online_->options().late_policy).c_str(), inputs.c_str());
  }

  static ros::TransportHints hints() { return ros::TransportHints().tcpNoDelay(); }

  /// dynamic_reconfigure: latency_budget, late_policy, trace_bound (1e300 = no bound). Starts
  /// from the values in use (the server's first call, with what it read, is not applied).
  void startReconfigure(ros::NodeHandle& pnh)
  {
    // In ~reconfigure: the server writes its values back as parameters, which must not become
    // parameters of the nodelet's next load.
    reconfigure_ = std::make_unique<dynamic_reconfigure::Server<EstimatorConfig>>(
        reconfigure_mutex_, ros::NodeHandle(pnh, "reconfigure"));
    EstimatorConfig now;
    now.latency_budget = clock_.budget();
    now.late_policy = toString(online_->options().late_policy);
    now.trace_bound = std::min(trace_bound_, 1e300);
    reconfigure_->setCallback([this](EstimatorConfig& c, uint32_t) {
      if (!reconfigure_ready_)
        return;
      std::lock_guard<std::mutex> lock(mutex_);
      clock_.setBudget(c.latency_budget);
      online_->setLatePolicy(latePolicyFromString(c.late_policy, "reconfigure"));
      trace_bound_ = c.trace_bound >= 1e300 ? std::numeric_limits<double>::infinity() : c.trace_bound;
      NODELET_INFO("Estimator reconfigured: latency_budget %g s, late_policy %s, trace_bound %g", c.latency_budget,
                   c.late_policy.c_str(), trace_bound_);
      wake_.notify_one();
    });
    reconfigure_ready_ = true;
    reconfigure_->updateConfig(now);
  }

  /// world_frame and base_link_frame, looked up in tf2 at the message's stamp (a missing or
  /// extrapolated transform rejects the message, naming both frames).
  Frames frames()
  {
    if (!tf_buffer_)
    {
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
      tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
    }
    Frames f;
    f.world = world_frame_;
    f.base = base_link_frame_;
    tf2_ros::Buffer* buffer = tf_buffer_.get();
    f.lookup = [buffer](const std::string& target, const std::string& source, const ros::Time& stamp,
                        tf2::Transform& out, std::string& why) {
      try
      {
        const geometry_msgs::TransformStamped t = buffer->lookupTransform(target, source, stamp);
        const auto& r = t.transform.rotation;
        const auto& x = t.transform.translation;
        out = tf2::Transform(tf2::Quaternion(r.x, r.y, r.z, r.w), tf2::Vector3(x.x, x.y, x.z));
        return true;
      }
      catch (const tf2::TransformException& e)
      {
        why = "no transform " + target + " <- " + source + " at the message's stamp: " + e.what();
        return false;
      }
    };
    return f;
  }

  /// The ENU origin of the NavSatFix inputs, latched on ~datum and logged (pin it with ~datum).
  void publishDatum(const LocalEnu& d)
  {
    sensor_msgs::NavSatFix m;
    m.header.stamp = ros::Time::now();
    m.header.frame_id = frame_id_;
    m.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
    m.latitude = d.latitude();
    m.longitude = d.longitude();
    m.altitude = d.altitude();
    m.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN;
    datum_pub_.publish(m);
    NODELET_INFO("Estimator: NavSatFix datum (ENU origin) %.9f, %.9f, %.3f%s", d.latitude(), d.longitude(),
                 d.altitude(), datum_.empty() ? " (the first valid fix; set ~datum to pin it)" : "");
  }

  void configure(ros::NodeHandle& pnh)
  {
    const EstimatorNodeConfig c = parseEstimatorNodeConfig(privateParameters(pnh), pnh.getNamespace() + " parameters");
    settings_ = c.settings;
    input_type_ = c.input_type;
    inputs_ = c.inputs;
    command_ = c.command;
    state_map_ = c.state_map;
    world_frame_ = c.world_frame;
    base_link_frame_ = c.base_link_frame;
    odom_frame_ = c.odom_frame;
    datum_ = c.datum;
    frame_id_ = c.frame_id;
    child_frame_id_ = c.child_frame_id;
    positions_ = c.position_indices;
    publish_tf_ = c.publish_tf;
    trace_bound_ = c.trace_bound;
    queue_size_ = static_cast<uint32_t>(c.queue_size);
    online_ = std::make_unique<OnlineEstimator>(c.model, settings_, c.online);
    clock_ = StepClock(c.period, c.latency_budget);
    // Live stability (stability/live_stability.hpp): one window per sensor and the joint verdict
    // of the same core test as `analyze`, the critical rates of a single i.i.d. sensor, and Gan
    // and Liu's evidence.
    LiveStabilityOptions live;
    live.window = c.stability_window;
    live.markov = c.markov_link;
    live.min_samples = c.stability_min_samples;
    live.late_data_dropped = c.online.late_policy == LatePolicy::DROP;
    live_ = std::make_unique<LiveStability>(online_->model(), settings_, live);
  }


  // --- inputs (subscriber threads) ---------------------------------------------------------------

  void onMeasurement(std::size_t sensor, const Measurement::ConstPtr& m)
  {
    try
    {
      measurement(sensor, m);
    }
    catch (const std::exception& e)
    {
      NODELET_ERROR_THROTTLE(1.0, "Estimator: measurement callback failed: %s", e.what());
    }
  }

  void measurement(std::size_t sensor, const Measurement::ConstPtr& m)
  {
    const std::string& expected = online_->model().sensors[sensor].name;
    if (!m->sensor.empty() && m->sensor != expected)
    {
      reject("sensor: expected '" + expected + "', found '" + m->sensor + "'");
      return;
    }
    const double t = m->header.stamp.toSec();
    if (m->step > static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2))
    {
      reject("step " + std::to_string(m->step) + " out of range");
      return;
    }
    offer(sensor, static_cast<long>(m->step), t, m->y.data(), m->y.size(), true);
  }

  void onForeign(std::size_t sensor, const ros::Time& stamp, const double* y, std::size_t size)
  {
    offer(sensor, -1, stamp.toSec(), y, size, false);
  }

  /// k < 0: the step is the nearest one to the stamp (anchored on the first message as k = 1).
  /// Estimates are published with the mutex held, so that they leave in step order whichever
  /// thread takes the step (publish only queues the message; it never calls back into us).
  void offer(std::size_t sensor, long k, double stamp, const double* y, std::size_t size, bool has_step)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!clock_.anchored() && !anchorLocked(has_step ? k : 1, stamp))
      return;
    if (!has_step)
      k = clock_.stepAt(stamp);
    // Steps whose deadline has passed are taken first (the deadline thread may not have woken
    // yet): what arrives after a deadline is late, exactly, whichever thread notices first.
    catchUp(ros::Time::now().toSec());
    const OfferResult r = online_->offerMeasurement(k, sensor, y, size);
    if (r.offer == Offer::REJECTED)
      NODELET_WARN_THROTTLE(1.0, "Estimator %s: measurement rejected: %s (%lu rejected so far)",
                            toString(settings_.algorithm).c_str(), r.reason.c_str(), rejectedLocked());
    drainComplete();
  }

  /// Starts the timeline on the first message of the stream, step k stamped `stamp` (mutex held).
  /// False (rejected) for k < 1.
  bool anchorLocked(long k, double stamp)
  {
    if (k < 1)
    {
      rejectLocked("step: expected >= 1, found " + std::to_string(k));
      return false;
    }
    clock_.anchor(k, stamp);
    // A stream seen from its start is filtered from step 1 (the steps before the first message
    // are losses); joining a running stream starts at the first step seen.
    online_->start(k - 1 <= static_cast<long>(online_->options().history_length) ? 1 : k);
    wake_.notify_one();
    return true;
  }

  void onCommand(const ControlInput::ConstPtr& c)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!online_->started())
      return;  // the timeline starts with the measurements
    if (c->step > static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2))
    {
      rejectLocked("command step " + std::to_string(c->step) + " out of range");
      return;
    }
    catchUp(ros::Time::now().toSec());
    const OfferResult r = online_->offerCommand(static_cast<long>(c->step), c->u.data(), c->u.size());
    if (r.offer == Offer::REJECTED)
      NODELET_WARN_THROTTLE(1.0, "Estimator %s: command rejected: %s (%lu rejected so far)",
                            toString(settings_.algorithm).c_str(), r.reason.c_str(), rejectedLocked());
    drainComplete();
  }

  void onSchedule(const ScheduleStep::ConstPtr& sc)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (sc->step > static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2))
    {
      rejectLocked("schedule step " + std::to_string(sc->step) + " out of range");
      return;
    }
    // The draw of a step leaves before its measurements: it may start the timeline.
    if (!clock_.anchored() && !anchorLocked(static_cast<long>(sc->step), sc->header.stamp.toSec()))
      return;
    catchUp(ros::Time::now().toSec());
    const std::vector<bool> transmitting(sc->transmitting.begin(), sc->transmitting.end());
    const OfferResult r = online_->offerSchedule(static_cast<long>(sc->step), transmitting);
    if (r.offer == Offer::REJECTED)
      NODELET_WARN_THROTTLE(1.0, "Estimator %s: schedule rejected: %s (%lu rejected so far)",
                            toString(settings_.algorithm).c_str(), r.reason.c_str(), rejectedLocked());
    drainComplete();
  }

  /// A command of a standard type (a Twist on /cmd_vel...): its step is the nearest one to its
  /// stamp (its arrival for unstamped types), and it holds until the next one, as a robot base
  /// holds /cmd_vel: a step without a command of its own uses the latest earlier one.
  void onHeldCommand(const ros::Time& stamp, const double* u, std::size_t n)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (held_.size() >= 1000)
      held_.erase(held_.begin());
    held_[stamp.toSec()].assign(u, u + n);  // kept before the timeline starts, too
    if (!online_->started())
      return;
    catchUp(ros::Time::now().toSec());
    const OfferResult r = online_->offerCommand(clock_.stepAt(stamp.toSec()), u, n);
    if (r.offer == Offer::REJECTED)
      NODELET_WARN_THROTTLE(1.0, "Estimator %s: command rejected: %s (%lu rejected so far)",
                            toString(settings_.algorithm).c_str(), r.reason.c_str(), rejectedLocked());
    drainComplete();
  }

  /// A held command type: offers the latest command of a step <= k for step k when k has none of
  /// its own (mutex held), and forgets the older ones.
  void offerHeldCommand(long k)
  {
    auto latest = held_.end();
    for (auto it = held_.begin(); it != held_.end() && clock_.stepAt(it->first) <= k; ++it)
      latest = it;
    if (latest == held_.end())
      return;
    held_.erase(held_.begin(), latest);
    if (!online_->hasCommand(k))
      online_->offerCommand(k, latest->second.data(), latest->second.size());
  }

  void reject(const std::string& why)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    rejectLocked(why);
  }

  void rejectLocked(const std::string& why)
  {
    ++rejected_topic_;
    NODELET_WARN_THROTTLE(1.0, "Estimator %s: message rejected: %s (%lu rejected so far)",
                          toString(settings_.algorithm).c_str(), why.c_str(), rejectedLocked());
  }

  unsigned long rejectedLocked() const
  {
    return static_cast<unsigned long>(online_->counters().rejected + rejected_topic_);
  }

  // --- steps -------------------------------------------------------------------------------------

  /// Takes the steps whose deadline is at or before `now` (mutex held), at most `limit`.
  void catchUp(double now, int limit = 1000)
  {
    for (int i = 0; i < limit && online_->started() && now >= clock_.deadline(online_->nextStep()); ++i)
    {
      publishLocked(stepLocked());
      drainComplete();
    }
  }

  /// Takes every step whose inputs are complete (mutex held).
  void drainComplete()
  {
    while (online_->nextComplete())
      publishLocked(stepLocked());
  }

  /// One filter step (mutex held); returns its message.
  Estimate::Ptr stepLocked()
  {
    const long k = online_->nextStep();
    if (online_->model().hasControl() && command_.type != InputType::CONTROL_INPUT)
      offerHeldCommand(k);  // zero-order hold
    online_->process();
    const Estimator& est = online_->estimator();
    Estimate::Ptr e = boost::make_shared<Estimate>();
    e->header.stamp.fromSec(clock_.stamp(k));
    e->header.frame_id = frame_id_;
    e->step = static_cast<std::uint64_t>(k);
    e->algorithm = toString(settings_.algorithm);
    e->gamma = online_->lastGamma();
    const Eigen::VectorXd& x = est.state();
    const Eigen::MatrixXd& P = est.covariance();
    const int n = static_cast<int>(x.size());
    e->state.assign(x.data(), x.data() + n);
    e->covariance.resize(static_cast<std::size_t>(n) * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        e->covariance[static_cast<std::size_t>(i) * n + j] = P(i, j);  // row-major (REP-103)
    e->covariance_trace = P.trace();
    e->covariance_is_pseudo = settings_.algorithm == Algorithm::RSEIO;
    const std::uint64_t resets = online_->counters().divergence_resets;
    live_->add(online_->lastArrived(), online_->lastDue(), online_->lastGamma(), P, resets != resets_seen_);
    resets_seen_ = resets;
    const double q = est.commandArrivalProbability();
    e->command_arrival_probability = std::isfinite(q) ? q : -1.0;
    last_trace_ = e->covariance_trace;
    return e;
  }

  /// Publishes one step's outputs (mutex held).
  void publishLocked(const Estimate::Ptr& e)
  {
    {
      estimate_pub_.publish(e);
      if (trace_pub_.getNumSubscribers() > 0)
      {
        std_msgs::Float64::Ptr t = boost::make_shared<std_msgs::Float64>();
        t->data = e->covariance_trace;
        trace_pub_.publish(t);
      }
      if (odom_pub_.getNumSubscribers() > 0)
        publishOdometry(*e);
      const bool want_pose = pose_pub_.getNumSubscribers() > 0;
      if (publish_tf_)
        last_estimate_ = e;  // tf leaves from tfTimer() in the nodelet's own queue, not this thread
      if (!want_pose)
        return;
      const int n = static_cast<int>(e->state.size());
      double xyz[3] = {0.0, 0.0, 0.0};
      for (std::size_t i = 0; i < positions_.size(); ++i)
        xyz[i] = e->state[positions_[i]];
      geometry_msgs::PoseWithCovarianceStamped::Ptr p = boost::make_shared<geometry_msgs::PoseWithCovarianceStamped>();
      p->header = e->header;
      p->pose.pose.position.x = xyz[0];
      p->pose.pose.position.y = xyz[1];
      p->pose.pose.position.z = xyz[2];
      p->pose.pose.orientation.w = 1.0;
      // 6x6 row-major (x y z roll pitch yaw): the position block from P; axes that are not
      // estimated get a large variance (1e6) rather than a false certainty.
      for (int i = 0; i < 6; ++i)
        p->pose.covariance[i * 6 + i] = 1e6;
      for (std::size_t a = 0; a < positions_.size(); ++a)
        for (std::size_t b = 0; b < positions_.size(); ++b)
          p->pose.covariance[a * 6 + b] = e->covariance[static_cast<std::size_t>(positions_[a]) * n + positions_[b]];
      pose_pub_.publish(p);
    }
  }

  /// The latest estimate as the tf frame_id -> child_frame_id, 20 times a second (tf is for
  /// viewing; sending it from the deadline thread stalled the manager's callback queues).
  void publishOdometry(const Estimate& e)
  {
    const int n = static_cast<int>(e.state.size());
    const Eigen::Map<const Eigen::VectorXd> x(e.state.data(), n);
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> P(
        e.covariance.data(), n, n);
    odom_pub_.publish(toOdometry(x, P, state_map_, e.header.stamp, world_frame_, base_link_frame_));
  }

  void tfTimer()
  {
    Estimate::ConstPtr e;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      e = last_estimate_;
    }
    if (!e || e->header.stamp == last_tf_)
      return;
    last_tf_ = e->header.stamp;
    geometry_msgs::TransformStamped t;
    t.header = e->header;
    t.child_frame_id = child_frame_id_;
    if (child_frame_id_ != base_link_frame_)
    {
      // The estimate's own frame: its position entries, no rotation.
      double* xyz[3] = {&t.transform.translation.x, &t.transform.translation.y, &t.transform.translation.z};
      for (std::size_t i = 0; i < positions_.size(); ++i)
        *xyz[i] = e->state[positions_[i]];
      t.transform.rotation.w = 1.0;
      tf_->sendTransform(t);
      return;
    }
    // Driving base_link: its pose from ~state_mapping, and never a second parent.
    std::string parent, broadcaster;
    const Frames f = frames();  // the tf2 buffer exists from onInit on in this mode
    parentOf(tf_buffer_->allFramesAsYAML(), base_link_frame_, parent, broadcaster);
    const TfPlan plan =
        planTf(world_frame_, odom_frame_, base_link_frame_, child_frame_id_, parent, broadcaster, ros::this_node::getName());
    if (plan.kind == TfPlan::Kind::NONE)
    {
      NODELET_WARN_THROTTLE(10.0, "Estimator: no tf: %s", plan.reason.c_str());
      return;
    }
    const int n = static_cast<int>(e->state.size());
    const Eigen::Map<const Eigen::VectorXd> x(e->state.data(), n);
    const nav_msgs::Odometry o = toOdometry(x, Eigen::MatrixXd::Zero(n, n), state_map_, e->header.stamp, world_frame_,
                                            base_link_frame_);
    const auto& p = o.pose.pose;
    tf2::Transform world_base(tf2::Quaternion(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w),
                              tf2::Vector3(p.position.x, p.position.y, p.position.z));
    t.header.frame_id = world_frame_;
    if (plan.kind == TfPlan::Kind::MAP_TO_ODOM)
    {
      tf2::Transform odom_base;
      std::string why;
      if (!f.lookup(odom_frame_, base_link_frame_, ros::Time(0), odom_base, why))
      {
        NODELET_WARN_THROTTLE(10.0, "Estimator: no %s -> %s tf: %s", world_frame_.c_str(), odom_frame_.c_str(),
                              why.c_str());
        return;
      }
      world_base = mapToOdom(world_base, odom_base);
      t.child_frame_id = odom_frame_;
    }
    const tf2::Vector3& v = world_base.getOrigin();
    const tf2::Quaternion q = world_base.getRotation();
    t.transform.translation.x = v.x();
    t.transform.translation.y = v.y();
    t.transform.translation.z = v.z();
    t.transform.rotation.x = q.x();
    t.transform.rotation.y = q.y();
    t.transform.rotation.z = q.z();
    t.transform.rotation.w = q.w();
    tf_->sendTransform(t);
  }

  /// Takes the steps whose deadline has passed (in ROS time) and resets on a backwards time jump.
  void deadlineLoop()
  {
    std::unique_lock<std::mutex> lock(mutex_);
    double last_now = -std::numeric_limits<double>::infinity();
    while (!stop_)
    {
      if (!online_->started())
      {
        wake_.wait_for(lock, std::chrono::milliseconds(50));
        continue;
      }
      const double now = ros::Time::now().toSec();
      if (now < last_now - 0.5 * clock_.period() && now > 0.0)
      {
        // The clock went back (a bag looped, a simulator restarted): start over cleanly.
        ++time_resets_;
        NODELET_WARN("Estimator %s: time jumped back by %.3f s: estimator reset, waiting for the stream to restart",
                     toString(settings_.algorithm).c_str(), last_now - now);
        online_->reset();
        live_->clear();
        clock_.clear();
        last_now = -std::numeric_limits<double>::infinity();
        continue;
      }
      last_now = now;
      const double due = clock_.deadline(online_->nextStep());
      if (now >= due)
      {
        catchUp(now);  // at most 1000 steps per lock hold, so that the inputs are not starved
        lock.unlock();
        std::this_thread::yield();
        lock.lock();
        continue;
      }
      // Wall-clock wait; under sim time the clock may run at another rate, so re-check often.
      const double cap = ros::Time::isSimTime() ? 0.0005 : 0.05;
      wake_.wait_for(lock, std::chrono::duration<double>(std::min(due - now, cap)));
    }
  }

  // --- diagnostics -------------------------------------------------------------------------------

  /// The inputs whose topic is advertised with another type than configured (ROS then connects
  /// nothing: without this check the sensor would just look silent), e.g.
  /// "sensor 'gps': /fix is geometry_msgs/PointStamped, expected sensor_msgs/NavSatFix".
  std::vector<std::string> wrongTypes() const
  {
    ros::master::V_TopicInfo topics;
    std::vector<std::string> out;
    if (!ros::master::getTopics(topics))
      return out;
    const ros::NodeHandle& nh = const_cast<EstimatorNodelet*>(this)->getNodeHandle();
    auto check = [&](const std::string& who, const std::string& topic, const std::string& expected) {
      const std::string name = nh.resolveName(topic);
      for (const ros::master::TopicInfo& t : topics)
        if (t.name == name && t.datatype != expected)
          out.push_back(who + ": " + name + " is " + t.datatype + ", expected " + expected);
    };
    const Model& model = online_->model();
    for (std::size_t i = 0; i < inputs_.size(); ++i)
      check("sensor '" + model.sensors[i].name + "'", inputs_[i].topic, toString(inputs_[i].type));
    if (model.hasControl())
      check("command", command_.topic, toString(command_.type));
    return out;
  }

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat)
  {
    const std::vector<std::string> wrong = wrongTypes();  // asks the master: outside the lock
    for (const std::string& w : wrong)
      NODELET_WARN_THROTTLE(10.0, "Estimator: wrong message type on an input topic: %s", w.c_str());
    std::lock_guard<std::mutex> lock(mutex_);
    const OnlineCounters& c = online_->counters();
    const ros::WallTime now = ros::WallTime::now();
    const double dt = last_diag_.isZero() ? 0.0 : (now - last_diag_).toSec();
    const double rate = dt > 0.0 ? static_cast<double>(c.processed - last_processed_) / dt : 0.0;
    last_diag_ = now;
    last_processed_ = c.processed;
    const double arrival = c.processed > 0 ? static_cast<double>(c.arrivals) / static_cast<double>(c.processed) : 0.0;
    if (!online_->started())
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "waiting for measurements");
    else if (!(last_trace_ <= trace_bound_))
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "covariance trace %.4g above trace_bound %.4g",
                    last_trace_, trace_bound_);
    else
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "step %ld, arrival rate %.3f", online_->nextStep() - 1,
                    arrival);
    if (!wrong.empty())
      stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "wrong message type: %s", wrong.front().c_str());
    stat.add("wrong type inputs", wrong.size());
    stat.add("algorithm", toString(settings_.algorithm));
    stat.add("steps", c.processed);
    stat.add("step rate (Hz)", rate);
    stat.add("arrival rate", arrival);
    stat.add("accepted", c.accepted);
    stat.add("late dropped", c.late_dropped);
    stat.add("late fused", c.late_fused);
    stat.add("duplicates", c.duplicates);
    stat.add("rejected", c.rejected + rejected_topic_);
    stat.add("missing commands", c.missing_commands);
    // "arrival rate" above is gamma's (some sensor arrived); these count only the samples that
    // were due: scheduled, and at a slower sensor's own steps.
    stat.add("due samples", c.due);
    stat.add("due arrival rate", c.due > 0 ? static_cast<double>(c.due_arrived) / static_cast<double>(c.due) : 0.0);
    if (online_->model().schedule.active())
    {
      stat.add("unscheduled measurements", c.unscheduled);
      if (online_->model().schedule.kind == Schedule::Kind::RANDOM)
        stat.add("steps without schedule", c.schedule_missing);
    }
    stat.add("divergence resets", c.divergence_resets);
    stat.add("time resets", time_resets_);
    stat.add("covariance trace", last_trace_);
    stat.add("trace bound", trace_bound_);
  }

  void diagnoseLink(diagnostic_updater::DiagnosticStatusWrapper& stat)
  {
    // Copied under the lock, evaluated outside it (three core stability tests and the Gan-Liu
    // evidence, well under a millisecond), so the filter thread is never held up by it.
    std::unique_ptr<LiveStability> snapshot;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      snapshot = std::make_unique<LiveStability>(*live_);
    }
    const LiveStabilityReport report = snapshot->evaluate();
    const unsigned char level = report.status.level == LinkStatus::Level::OK ? diagnostic_msgs::DiagnosticStatus::OK
                                : report.status.level == LinkStatus::Level::WARN
                                    ? diagnostic_msgs::DiagnosticStatus::WARN
                                    : diagnostic_msgs::DiagnosticStatus::ERROR;
    stat.summary(level, report.status.message);
    for (const auto& kv : report.values)
      stat.add(kv.first, kv.second);
  }

  EstimatorSettings settings_;
  std::unique_ptr<OnlineEstimator> online_;
  std::unique_ptr<LiveStability> live_;
  std::uint64_t resets_seen_ = 0;  ///< divergence resets of the filter already told to live_

  StepClock clock_{1.0, 0.0};
  std::string input_type_, frame_id_, child_frame_id_;
  std::vector<SensorInput> inputs_;
  SensorInput command_;
  std::map<double, std::vector<double>> held_;  ///< a held command type: commands by stamp (s)
  StateMap state_map_;
  std::string world_frame_, base_link_frame_, odom_frame_;
  std::vector<double> datum_;
  ros::Publisher datum_pub_;
  std::vector<int> positions_;
  bool publish_tf_ = true;
  double trace_bound_ = std::numeric_limits<double>::infinity();
  uint32_t queue_size_ = 1000;

  std::vector<ros::Subscriber> subs_;
  ros::Subscriber cmd_sub_, schedule_sub_;
  ros::Publisher estimate_pub_, trace_pub_, pose_pub_, odom_pub_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::WallTimer tf_timer_;
  Estimate::ConstPtr last_estimate_;
  ros::Time last_tf_;
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  ros::WallTimer diag_timer_;

  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<EstimatorConfig>> reconfigure_;
  bool reconfigure_ready_ = false;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::thread thread_;
  bool stop_ = false;
  double last_trace_ = 0.0;
  std::uint64_t rejected_topic_ = 0, time_resets_ = 0, last_processed_ = 0;
  ros::WallTime last_diag_;
};

}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::EstimatorNodelet, nodelet::Nodelet)
