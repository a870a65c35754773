// The Estimator nodelet (estimator_nodelet.hpp): parameters, inputs and the filter steps.
#include "estimator_nodelet.hpp"

#include <pluginlib/class_list_macros.hpp>

#include "networked_estimation/motion/linearised_model.hpp"

namespace networked_estimation
{

void EstimatorNodelet::onInit()
{
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  // The inputs are served by the Estimator's own thread (dispatch_thread.hpp), which also takes
  // the steps whose deadline passes; timers, tf and reconfigure stay on the nodelet's queue.
  ros::NodeHandle in_nh(nh);
  in_nh.setCallbackQueue(dispatch_.queue());
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
  startSetPose(nh);
  const Model& model = stream_->online().model();
  if (!datum_.empty() || std::any_of(inputs_.begin(), inputs_.end(), [](const SensorInput& in) {
        return in.type == InputType::NAVSATFIX;
      }))
    datum_pub_ = pnh.advertise<sensor_msgs::NavSatFix>("datum", 1, true);
  if (gnss_)
    gnss_->start(nh, in_nh, inputs_, frames(), [this](BasePose& pose) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!stream_->online().started())
        return false;
      pose = basePoseOf(stream_->online().estimator().state(), state_map_, gnss_roll_, gnss_pitch_);
      return true;
    });
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    const SensorInput& in = inputs_[i];
    if (in.type == InputType::MEASUREMENT)
    {
      subs_.push_back(subscribeEvents<Measurement>(in_nh, in.topic, queue_size_,
                                                   [this, i](const ros::MessageEvent<Measurement const>& e) {
                                                     onMeasurement(i, e.getConstMessage(), e.getReceiptTime());
                                                   }, in.transport));
      watchTransport(in_nh, i);
      continue;
    }
    SensorSink sink;
    sink.ok = [this, i](const ros::Time& stamp, const ros::Time& receipt, const double* y, std::size_t n,
                        const double* R) { offer(i, -1, stamp.toSec(), receipt, y, n, R); };
    const std::string who = "sensor '" + model.sensors[i].name + "' (" + toString(in.type) + " on " + in.topic + ")";
    sink.bad = [this, who](const std::string& why) { reject(who + ": " + why); };
    sink.fallback = [this, who](const std::string& why) { covarianceFallback(who + ": " + why); };
    sink.disabled = [this, i](const ros::Time& stamp, const ros::Time& receipt, const std::string& why) {
      onDisabled(i, stamp, receipt, why);
    };
    sink.datum = [this](const LocalEnu& d) { publishDatum(d); };
    if (gnss_ && in.type == InputType::NAVSATFIX)
      sink.gnss = [this](const sensor_msgs::NavSatFix& m, const LocalEnu& datum, Eigen::Vector3d& local,
                         boost::array<double, 9>& cov, std::string& why) {
        return gnss_->apply(m, datum, local, cov, why);
      };
    sink.frames = frames();
    subs_.push_back(subscribeSensor(in_nh, in, queue_size_, sink, datum_));
    watchTransport(in_nh, i);
  }
  if (!datum_.empty())
  {
    const LocalEnu d(datum_[0], datum_[1], datum_[2]);
    publishDatum(d);
  }
  if (model.hasControl() && command_.type == InputType::CONTROL_INPUT)
    cmd_sub_ = in_nh.subscribe(command_.topic, queue_size_, &EstimatorNodelet::onCommand, this,
                               transportHints(command_.transport));
  else if (model.hasControl())
  {
    SensorSink sink;
    sink.ok = [this](const ros::Time& stamp, const ros::Time&, const double* u, std::size_t n, const double*) {
      onHeldCommand(stamp, u, n);
    };
    const std::string who = "command (" + toString(command_.type) + " on " + command_.topic + ")";
    sink.bad = [this, who](const std::string& why) { reject(who + ": " + why); };
    sink.frames = frames();
    cmd_sub_ = subscribeSensor(in_nh, command_, queue_size_, sink, {});
  }
  if (model.hasControl())
    transports_.add("command (" + in_nh.resolveName(command_.topic) + ")", "command transport",
                    in_nh.resolveName(command_.topic), command_.transport, cmd_sub_);
  if (model.schedule.kind == Schedule::Kind::RANDOM)
    schedule_sub_ = in_nh.subscribe("schedule", queue_size_, &EstimatorNodelet::onSchedule, this, hints());
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID(toString(settings_.algorithm));
  diagnostics_->add("estimator", this, &EstimatorNodelet::diagnose);
  if (live_)  // live_stability: false: no window, no verdict, no status
    diagnostics_->add("link stability", this, &EstimatorNodelet::diagnoseLink);
  // force_update: the updater's own period check uses ROS time, which stalls or jumps under sim time.
  link_status_pub_ = pnh.advertise<LinkStatus>("link_status", 10);
  latency_figures_.assign(model.sensors.size(), LatencyBudget::Figures());
  diag_timer_ = nh.createWallTimer(ros::WallDuration(1.0), [this](const ros::WallTimerEvent&) {
    diagnostics_->force_update();
    publishLinkStatus();
  });
  if (publish_tf_)
  {
    if (child_frame_id_ == base_link_frame_)
    {
      frames();  // listen to tf from the start: base_link's parent decides what we publish
      // With the message event (a plain callback would lose the publisher's name).
      for (const bool static_tf : {false, true})
      {
        ros::SubscribeOptions o;
        o.initByFullCallbackType<const ros::MessageEvent<tf2_msgs::TFMessage const>&>(
            static_tf ? "/tf_static" : "/tf", 100,
            [this, static_tf](const ros::MessageEvent<tf2_msgs::TFMessage const>& e) { onTf(e, static_tf); });
        (static_tf ? tf_static_sub_ : tf_sub_) = nh.subscribe(o);
      }
    }
    tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
    tf_timer_ = nh.createWallTimer(ros::WallDuration(0.05), [this](const ros::WallTimerEvent&) { tfTimer(); });
  }
  if (predict_to_current_time_)
  {
    predict_timer_ = nh.createWallTimer(ros::WallDuration(1.0 / frequency_), [this](const ros::WallTimerEvent&) {
      predictTimer();
    });
    NODELET_INFO("Estimator: odometry/filtered%s at %g Hz, predicted to the current time (predict_to_current_time)",
                 publish_tf_ ? " and tf" : "", frequency_);
  }
  startReconfigure(pnh);
  clock_watch_.start(getNodeHandle(), [this] { dispatch_.wake(); });
  dispatch_.start([this] { return deadlineWork(); });
  std::string inputs;
  for (std::size_t i = 0; i < inputs_.size(); ++i)
    inputs += (i ? ", " : "") + model.sensors[i].name + " (" + toString(inputs_[i].type) + " on " +
              nh.resolveName(inputs_[i].topic) + ")";
  NODELET_INFO("Estimator %s on '%s' (n = %d): period %g s, %s; inputs: %s", toString(settings_.algorithm).c_str(),
               model.name.c_str(), model.n(), limits_.period, describe(stream_->runtime()).c_str(), inputs.c_str());
}

void EstimatorNodelet::watchTransport(ros::NodeHandle& nh, std::size_t i)
{
  const std::string& name = stream_->online().model().sensors[i].name;
  const std::string topic = nh.resolveName(inputs_[i].topic);
  transports_.add("sensor '" + name + "' (" + topic + ")", name + " transport", topic, inputs_[i].transport,
                  subs_.back());
}

void EstimatorNodelet::startReconfigure(ros::NodeHandle& pnh)
{
  // In ~reconfigure: the server writes its values back as parameters, which must not become
  // parameters of the nodelet's next load.
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<EstimatorConfig>>(
      reconfigure_mutex_, ros::NodeHandle(pnh, "reconfigure"));
  const RuntimeSettings& r = stream_->runtime();
  shown_.adaptive_latency = r.adaptive_latency;
  shown_.latency_budget = r.adaptive_latency ? stream_->budget() : r.latency_budget;
  shown_.latency_budget_min = r.latency_budget_min;
  shown_.latency_budget_max = r.latency_budget_max;
  shown_.late_policy = r.late_policy;
  shown_.trace_bound = std::min(r.trace_bound, 1e300);
  reconfigure_->setCallback([this](EstimatorConfig& c, uint32_t) {
    if (reconfigure_ready_)
      reconfigure(c);
  });
  reconfigure_ready_ = true;
  reconfigure_->updateConfig(shown_);
}

void EstimatorNodelet::reconfigure(EstimatorConfig& c)
{
  RuntimeSettings r;
  r.adaptive_latency = c.adaptive_latency;
  r.latency_budget = c.latency_budget;
  r.latency_budget_min = c.latency_budget_min;
  r.latency_budget_max = c.latency_budget_max;
  r.late_policy = c.late_policy;
  r.trace_bound = c.trace_bound >= 1e300 ? std::numeric_limits<double>::infinity() : c.trace_bound;
  std::lock_guard<std::mutex> lock(mutex_);
  try
  {
    validateRuntimeSettings(r, limits_, "reconfigure");
  }
  catch (const ConfigError& e)
  {
    NODELET_ERROR("Estimator: change refused: %s; the settings stay %s", e.what(), describe(stream_->runtime()).c_str());
    c = shown_;  // the server shows these back
    return;
  }
  stream_->setRuntime(r);
  trace_bound_ = r.trace_bound;
  shown_ = c;
  NODELET_INFO("Estimator reconfigured: %s", describe(r).c_str());
  dispatch_.wake();  // the deadlines moved
}

const Frames& EstimatorNodelet::frames()
{
  if (tf_buffer_)
    return frames_;
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  // tf messages on the nodelet's own callback queue (spin_thread = false): no dedicated listener
  // thread waking 100 times a second when no tf flows.
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, getNodeHandle(), false);
  frames_.world = world_frame_;
  frames_.base = base_link_frame_;
  tf2_ros::Buffer* buffer = tf_buffer_.get();
  frames_.lookup = [buffer](const std::string& target, const std::string& source, const ros::Time& stamp,
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
  return frames_;
}

void EstimatorNodelet::configure(ros::NodeHandle& pnh)
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
  if (c.gnss.navsat_transform)
  {
    gnss_ = std::make_unique<GnssAligner>(c.gnss, c.world_frame, c.base_link_frame);
    gnss_roll_ = c.gnss.roll;
    gnss_pitch_ = c.gnss.pitch;
  }
  frame_id_ = c.frame_id;
  child_frame_id_ = c.child_frame_id;
  positions_ = c.position_indices;
  publish_tf_ = c.publish_tf;
  predict_to_current_time_ = c.predict_to_current_time;
  frequency_ = c.frequency;
  if (predict_to_current_time_)
    predict_model_ = std::make_unique<const Model>(c.model);
  trace_bound_ = c.runtime.trace_bound;
  queue_size_ = static_cast<uint32_t>(c.queue_size);
  stream_ = std::make_unique<OnlineStream>(c.model, settings_, c.online, c.timeline, c.runtime);
  stream_->after_step = [this](long k) { publishLocked(stepLocked(k)); };
  stream_->on_restart = [this](const std::string& why) {
    if (live_)
      live_->clear();
    if (gnss_)
      gnss_->restart();  // the world frame is anchored again: so is the GNSS alignment
    NODELET_WARN("Estimator %s: %s", toString(settings_.algorithm).c_str(), why.c_str());
  };
  limits_.period = c.period;
  limits_.max_future_steps = c.online.max_future_steps;
  limits_.max_stamp_behind = c.timeline.max_behind;
  // Live stability (stability/live_stability.hpp): one window per sensor and the joint verdict
  // of the same core test as `analyze`, the critical rates of a single i.i.d. sensor, and Gan
  // and Liu's evidence.
  LiveStabilityOptions live;
  live.window = c.stability_window;
  live.markov = c.markov_link;
  live.min_samples = c.stability_min_samples;
  live.late_data_dropped = c.online.late_policy == LatePolicy::DROP;
  // Sensors at their own rates: the verdicts see each sensor only at its own steps.
  std::string rates_note;
  rate_ratios_.clear();
  for (double r : c.online.rate_ratio)
    rate_ratios_.push_back(SensorLattice::whole(r));  // a 9.996 Hz sensor in a 30 Hz model: every 3rd step
  // A built-in motion: the verdicts of its linearisation over the steps' period, at x0 until the
  // first diagnostic, then at the estimate (a local verdict, docs/stability.md 5)
  if (c.model.nonlinear())
  {
    NODELET_INFO("Estimator: model '%s' has motion %s: the link verdicts are local, for its linearisation at the "
                 "current estimate",
                 c.model.name.c_str(), toString(c.model.motion).c_str());
    motion_model_ = std::make_unique<const Model>(c.model);
  }
  const Model stability_model =
      withSensorRates(linearisedModel(c.model, c.model.x0, c.period), rate_ratios_, &rates_note);
  if (!rates_note.empty())
    NODELET_WARN("Estimator: %s", rates_note.c_str());
  if (c.live_stability)
    live_ = std::make_unique<LiveStability>(stability_model, settings_, live);
}

void EstimatorNodelet::onMeasurement(std::size_t sensor, const Measurement::ConstPtr& m, const ros::Time& receipt)
{
  try
  {
    measurement(sensor, m, receipt);
  }
  catch (const std::exception& e)
  {
    NODELET_ERROR_THROTTLE(1.0, "Estimator: measurement callback failed: %s", e.what());
  }
}

void EstimatorNodelet::measurement(std::size_t sensor, const Measurement::ConstPtr& m, const ros::Time& receipt)
{
  const std::string& expected = stream_->online().model().sensors[sensor].name;
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
  offer(sensor, static_cast<long>(m->step), t, receipt, m->y.data(), m->y.size());
}

void EstimatorNodelet::covarianceFallback(const std::string& why)
{
  std::lock_guard<std::mutex> lock(mutex_);
  ++covariance_fallbacks_;
  NODELET_WARN_THROTTLE(10.0, "Estimator: message without a covariance, the model's R is used: %s (%lu so far)",
                        why.c_str(), static_cast<unsigned long>(covariance_fallbacks_));
}

void EstimatorNodelet::onDisabled(std::size_t sensor, const ros::Time& stamp, const ros::Time& receipt,
                                  const std::string& why)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const OfferResult r = stream_->disabled(sensor, stamp.toSec(), -1, clocks(receipt));
  if (r.offer == Offer::REJECTED)
    warnRejected("measurement", r);
  else
    NODELET_WARN_THROTTLE(10.0, "Estimator: sensor '%s': not fused: %s (%lu such messages so far; the sensor is "
                          "not due at their steps)", stream_->online().model().sensors[sensor].name.c_str(), why.c_str(),
                          static_cast<unsigned long>(stream_->online().counters().disabled_per_sensor[sensor]));
}

void EstimatorNodelet::offer(std::size_t sensor, long k, double stamp, const ros::Time& receipt, const double* y,
                             std::size_t size, const double* R)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const OfferResult r = stream_->measurement(sensor, stamp, k, y, size, R, clocks(receipt));
  if (r.offer == Offer::REJECTED)
    warnRejected("measurement", r);
}

Clocks EstimatorNodelet::clocks(const ros::Time& receipt) const
{
  Clocks c;
  c.ros = receipt.isZero() ? clock_watch_.now() : receipt.toSec();
  c.wall = ros::WallTime::now().toSec();
  c.rate = ros::Time::isSimTime() ? clock_rate_ : 1.0;
  return c;
}

void EstimatorNodelet::warnRejected(const char* what, const OfferResult& r)
{
  NODELET_WARN_THROTTLE(1.0, "Estimator %s: %s rejected: %s (%lu rejected so far)", toString(settings_.algorithm).c_str(),
                        what, r.reason.c_str(), rejectedLocked());
}

void EstimatorNodelet::onCommand(const ControlInput::ConstPtr& c)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (c->step > static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2))
  {
    rejectLocked("command step " + std::to_string(c->step) + " out of range");
    return;
  }
  const OfferResult r =
      stream_->command(static_cast<long>(c->step), c->header.stamp.toSec(), c->u.data(), c->u.size(), clocks());
  if (r.offer == Offer::REJECTED)
    warnRejected("command", r);
}

void EstimatorNodelet::onSchedule(const ScheduleStep::ConstPtr& sc)
{
  std::lock_guard<std::mutex> lock(mutex_);
  if (sc->step > static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2))
  {
    rejectLocked("schedule step " + std::to_string(sc->step) + " out of range");
    return;
  }
  const std::vector<bool> transmitting(sc->transmitting.begin(), sc->transmitting.end());
  const OfferResult r = stream_->schedule(static_cast<long>(sc->step), sc->header.stamp.toSec(), transmitting, clocks());
  if (r.offer == Offer::REJECTED)
    warnRejected("schedule", r);
}

void EstimatorNodelet::onHeldCommand(const ros::Time& stamp, const double* u, std::size_t n)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const OfferResult r = stream_->heldCommand(stamp.toSec(), u, n, clocks());
  if (r.offer == Offer::REJECTED)
    warnRejected("command", r);
}

void EstimatorNodelet::reject(const std::string& why)
{
  std::lock_guard<std::mutex> lock(mutex_);
  rejectLocked(why);
}

void EstimatorNodelet::rejectLocked(const std::string& why)
{
  ++rejected_topic_;
  NODELET_WARN_THROTTLE(1.0, "Estimator %s: message rejected: %s (%lu rejected so far)",
                        toString(settings_.algorithm).c_str(), why.c_str(), rejectedLocked());
}

unsigned long EstimatorNodelet::rejectedLocked() const
{
  std::uint64_t refused = stream_->refusedOther();
  for (std::uint64_t n : stream_->refusedPerSensor())
    refused += n;
  return static_cast<unsigned long>(stream_->online().counters().rejected + rejected_topic_ + refused);
}

Estimate::Ptr EstimatorNodelet::stepLocked(long k)
{
  const OnlineEstimator& online = stream_->online();
  const Estimator& est = online.estimator();
  Estimate::Ptr e = boost::make_shared<Estimate>();
  e->header.stamp.fromSec(stream_->timeline().clock().stamp(k));
  e->header.frame_id = frame_id_;
  e->step = static_cast<std::uint64_t>(k);
  e->algorithm = toString(settings_.algorithm);
  e->gamma = online.lastGamma();
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
  const std::uint64_t resets = online.counters().divergence_resets;
  if (live_)
    live_->add(online.lastArrived(), online.lastDue(), online.lastGamma(), P, resets != resets_seen_);
  resets_seen_ = resets;
  const double q = est.commandArrivalProbability();
  e->command_arrival_probability = std::isfinite(q) ? q : -1.0;
  last_trace_ = e->covariance_trace;
  return e;
}

double EstimatorNodelet::deadlineWork()
{
  // Nothing timed is due before a message, a wake() or (sim time) a /clock tick that reaches the
  // armed time: those end the wait; the thread's own bound (1 s) is the only poll.
  constexpr double kIdle = 1.0;
  std::lock_guard<std::mutex> lock(mutex_);
  if (!stream_->online().started())
    return kIdle;
  // Sim time: the clock's rate over the last half second (a bag at -r 4 runs 4 sim seconds per
  // second), for the waits below and the stream's catch-up work bound.
  const double now = clock_watch_.now(), wall = ros::WallTime::now().toSec();
  if (ros::Time::isSimTime())
  {
    if (wall_ref_ == 0.0 || now < sim_ref_)  // the first wait, or time went back
    {
      sim_ref_ = now;
      wall_ref_ = wall;
    }
    else if (wall - wall_ref_ >= 0.5)
    {
      const double r = (now - sim_ref_) / (wall - wall_ref_);
      clock_rate_ = r > 1e-3 && r < 1e6 ? r : 1e-3;  // paused: the smallest rate
      sim_ref_ = now;
      wall_ref_ = wall;
    }
  }
  // Messages already queued first: they came before now, and whether they were in time is decided
  // by their receipt time, not by when this thread gets to them (a busy machine).
  if (!dispatch_.queue()->isEmpty() && ++deferred_ <= 10)
    return 0.0;
  deferred_ = 0;
  // Steps whose deadline has passed (at most 1000 per lock hold, so that the inputs are not
  // starved); time jumps restart the stream.
  if (stream_->deadlines(clocks()))
    return 0.0;
  if (stream_->throttled())
    return 0.005;  // the catch-up work bound: tokens come back at twice the rate ROS time needs
  const double due = stream_->nextDeadline();
  if (!std::isfinite(due))
    return kIdle;  // restarted: waiting for the stream
  // Wall time: wait until the deadline (a message that completes a step takes it at once, in its
  // callback, and the wait is then set again for the next step: no wake-up per step). Sim time:
  // ROS time moves only at /clock ticks, and the tick that reaches the deadline wakes this thread
  // (sim_clock_watch.hpp), so no poll: a stopped clock (a bag that ended) costs nothing.
  if (clock_watch_.active())
    return clock_watch_.arm(due) ? kIdle : 0.0;
  return std::max(0.0, std::min(due - now, 0.05));
}
}  // namespace networked_estimation

PLUGINLIB_EXPORT_CLASS(networked_estimation::EstimatorNodelet, nodelet::Nodelet)
