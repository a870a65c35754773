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
  // The inputs from other processes are handled where roscpp receives them, with no hand-off;
  // in-process publishers' go to the Estimator's own thread (dispatch_thread.hpp:
  // ReceiveThreadQueue), which also takes the steps whose deadline passes, publishes the steps'
  // outputs and sends the tf. NavSatFix inputs, which publish (the datum, gps odometry), all go to
  // that thread. The timers and reconfigure stay on the nodelet's queue.
  ros::NodeHandle in_nh(nh), rx_nh(nh);
  in_nh.setCallbackQueue(dispatch_.queue());
  rx_nh.setCallbackQueue(dispatch_.receiveThreadQueue());
  try
  {
    configure(pnh);
  }
  catch (const ConfigError& e)
  {
    refuseLoad(getName(), std::string("Estimator not started: ") + e.what());
  }
  frames_.configure(nh, config_.world_frame, config_.base_link_frame);
  outputs_.start(
      nh, config_, getName(), [this]() -> const Frames& { return frames_.get(); }, gnss_.get(),
      [this]
      {
        if (!dispatch_.inThisThread())  // (in it, flush() and tfWork() run after the callback)
          dispatch_.wake();
      });
  startSetPose(nh);
  const Model& model = stream_->online().model();
  const std::vector<SensorInput>& inputs = config_.inputs;
  if (!config_.datum.empty() ||
      std::any_of(inputs.begin(), inputs.end(), [](const SensorInput& in) { return in.type == InputType::NAVSATFIX; }))
    datum_pub_ = pnh.advertise<sensor_msgs::NavSatFix>("datum", 1, true);
  if (gnss_)
    gnss_->start(nh, in_nh, inputs, frames_.get(),
                 [this](BasePose& pose)
                 {
                   std::lock_guard<std::mutex> lock(mutex_);
                   if (!stream_->online().started())
                     return false;
                   pose = basePoseOf(stream_->online().estimator().state(), config_.state_map, config_.gnss.roll,
                                     config_.gnss.pitch);
                   return true;
                 });
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    const SensorInput& in = inputs[i];
    SensorSink sink;
    sink.sensor = model.sensors[i].name;
    sink.ok = [this, i](const ros::Time& receipt, SensorSample s)
    {
      s.sensor = i;
      offer(s, receipt);
    };
    const std::string who = "sensor '" + model.sensors[i].name + "' (" + toString(in.type) + " on " + in.topic + ")";
    sink.bad = [this, who](const std::string& why) { reject(who + ": " + why); };
    sink.fallback = [this, who](const std::string& why) { covarianceFallback(who + ": " + why); };
    sink.disabled = [this, i](const ros::Time& stamp, const ros::Time& receipt, const std::string& why)
    { onDisabled(i, stamp, receipt, why); };
    sink.datum = [this](const LocalEnu& d) { publishDatum(d); };
    if (gnss_ && in.type == InputType::NAVSATFIX)
      sink.gnss = [this](const sensor_msgs::NavSatFix& m, const LocalEnu& datum, Eigen::Vector3d& local,
                         boost::array<double, 9>& cov, std::string& why)
      { return gnss_->apply(m, datum, local, cov, why); };
    sink.frames = frames_.get();
    subs_.push_back(
        subscribeSensor(in.type == InputType::NAVSATFIX ? in_nh : rx_nh, in, queueSize(), sink, config_.datum));
    watchTransport(in_nh, i);
  }
  if (!config_.datum.empty())
  {
    const LocalEnu d(config_.datum[0], config_.datum[1], config_.datum[2]);
    publishDatum(d);
  }
  const SensorInput& command = config_.command;
  if (model.hasControl())
  {
    SensorSink sink;
    const bool held = command.type != InputType::CONTROL_INPUT;  // no step: held (onCommand)
    sink.ok = [this, held](const ros::Time&, const SensorSample& s) {
      onCommand({s.step, s.y, s.size, s.stamp}, held);
    };
    const std::string who = "command (" + toString(command.type) + " on " + command.topic + ")";
    sink.bad = [this, who](const std::string& why) { reject(who + ": " + why); };
    sink.frames = frames_.get();
    cmd_sub_ = subscribeSensor(rx_nh, command, queueSize(), sink, {});
  }
  if (model.hasControl())
    transports_.add("command (" + in_nh.resolveName(command.topic) + ")", "command transport",
                    in_nh.resolveName(command.topic), command.transport, cmd_sub_);
  if (model.schedule.kind == Schedule::Kind::RANDOM)
    schedule_sub_ = rx_nh.subscribe("schedule", queueSize(), &EstimatorNodelet::onSchedule, this, hints());
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
  diagnostics_->setHardwareID(toString(config_.settings.algorithm));
  diagnostics_->add("estimator", this, &EstimatorNodelet::diagnose);
  if (link_.enabled())  // live_stability: false: no window, no verdict, no status
    diagnostics_->add(
        "link stability", [this](diagnostic_updater::DiagnosticStatusWrapper& stat)
        { link_.diagnose(stat, mutex_, [this] { return Eigen::VectorXd(stream_->online().estimator().state()); }); });
  // force_update: the updater's own period check uses ROS time, which stalls or jumps under sim time.
  link_.advertise(pnh);
  latency_figures_.assign(model.sensors.size(), LatencyBudget::Figures());
  diag_timer_ = nh.createWallTimer(ros::WallDuration(1.0),
                                   [this](const ros::WallTimerEvent&)
                                   {
                                     diagnostics_->force_update();
                                     link_.publishStatus(stream_->online().model(), latency_figures_);
                                   });
  startReconfigure(pnh);
  clock_watch_.start(getNodeHandle(), [this] { dispatch_.wake(); });
  dispatch_.start(
      [this]
      {
        outputs_.flush();  // the steps taken in the receive thread first: they wait for it
        const double wait = deadlineWork();
        outputs_.flush();
        return std::min(wait, outputs_.tfWork());
      });
  std::string names;
  for (std::size_t i = 0; i < config_.inputs.size(); ++i)
    names += (i ? ", " : "") + model.sensors[i].name + " (" + toString(config_.inputs[i].type) + " on " +
             nh.resolveName(config_.inputs[i].topic) + ")";
  NODELET_INFO("Estimator %s on '%s' (n = %d): period %g s, %s; inputs: %s",
               toString(config_.settings.algorithm).c_str(), model.name.c_str(), model.n(), limits_.period,
               describe(stream_->runtime()).c_str(), names.c_str());
}

void EstimatorNodelet::publishDatum(const LocalEnu& d)
{
  sensor_msgs::NavSatFix m;
  m.header.stamp = ros::Time::now();
  m.header.frame_id = config_.frame_id;
  m.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
  m.latitude = d.latitude();
  m.longitude = d.longitude();
  m.altitude = d.altitude();
  m.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN;
  datum_pub_.publish(m);
  NODELET_INFO("Estimator: NavSatFix datum (ENU origin) %.9f, %.9f, %.3f%s", d.latitude(), d.longitude(), d.altitude(),
               config_.datum.empty() ? " (the first valid fix; set ~datum to pin it)" : "");
}

void EstimatorNodelet::watchTransport(ros::NodeHandle& nh, std::size_t i)
{
  const std::string& name = stream_->online().model().sensors[i].name;
  const std::string topic = nh.resolveName(config_.inputs[i].topic);
  transports_.add("sensor '" + name + "' (" + topic + ")", name + " transport", topic, config_.inputs[i].transport,
                  subs_.back());
}

void EstimatorNodelet::configure(ros::NodeHandle& pnh)
{
  config_ = parseEstimatorNodeConfig(privateParameters(pnh), pnh.getNamespace() + " parameters");
  const EstimatorNodeConfig& c = config_;
  if (c.gnss.navsat_transform)
    gnss_ = std::make_unique<GnssAligner>(c.gnss, c.world_frame, c.base_link_frame);
  trace_bound_ = c.runtime.trace_bound;
  stream_ = std::make_unique<OnlineStream>(c.model, c.settings, c.online, c.timeline, c.runtime);
  stream_->after_step = [this](long k) { outputs_.queueStep(stepLocked(k)); };
  stream_->on_restart = [this](const std::string& why)
  {
    link_.clear();
    if (gnss_)
      gnss_->restart();  // the world frame is anchored again: so is the GNSS alignment
    NODELET_WARN("Estimator %s: %s", toString(config_.settings.algorithm).c_str(), why.c_str());
  };
  limits_.period = c.period;
  limits_.max_future_steps = c.online.max_future_steps;
  limits_.max_stamp_behind = c.timeline.max_behind;
  link_.configure(c, getName());
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
  afterInputLocked();
  if (r.offer == Offer::REJECTED)
    warnRejected("measurement", r);
  else
    NODELET_WARN_THROTTLE(10.0,
                          "Estimator: sensor '%s': not fused: %s (%lu such messages so far; the sensor is "
                          "not due at their steps)",
                          stream_->online().model().sensors[sensor].name.c_str(), why.c_str(),
                          static_cast<unsigned long>(stream_->online().counters().disabled_per_sensor[sensor]));
}

void EstimatorNodelet::offer(const SensorSample& s, const ros::Time& receipt)
{
  try
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const OfferResult r = stream_->measurement(s, clocks(receipt));
    if (r.offer == Offer::REJECTED)
      warnRejected("measurement", r);
    afterInputLocked();
  }
  catch (const std::exception& e)  // the step and its outputs run in here
  {
    NODELET_ERROR_THROTTLE(1.0, "Estimator: measurement callback failed: %s", e.what());
  }
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
  NODELET_WARN_THROTTLE(1.0, "Estimator %s: %s rejected: %s (%lu rejected so far)",
                        toString(config_.settings.algorithm).c_str(), what, r.reason.c_str(), rejectedLocked());
}

void EstimatorNodelet::onCommand(const CommandSample& c, bool held)
{
  std::lock_guard<std::mutex> lock(mutex_);
  const OfferResult r = held ? stream_->heldCommand(c, clocks()) : stream_->command(c, clocks());
  if (r.offer == Offer::REJECTED)
    warnRejected("command", r);
  afterInputLocked();
}

void EstimatorNodelet::afterInputLocked()
{
  // The input thread does both in deadlineWork(), after its own callbacks.
  if (!inRoscppPollThread())
    return;
  // ROS time as the steps this message completed saw it: a clock that goes back is measured from
  // here (the input thread may not have looked for many steps).
  stream_->observe(clocks());
  // Sim time: the message may have moved the next deadline on, and the /clock tick armed for the
  // old one would wake the input thread for nothing.
  if (!clock_watch_.active())
    return;
  const double due = stream_->nextDeadline();
  if (std::isfinite(due) && !clock_watch_.arm(due))
    dispatch_.wake();  // already passed: the input thread takes it now
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
  const OfferResult r =
      stream_->schedule(static_cast<long>(sc->step), sc->header.stamp.toSec(), transmitting, clocks());
  if (r.offer == Offer::REJECTED)
    warnRejected("schedule", r);
  afterInputLocked();
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
                        toString(config_.settings.algorithm).c_str(), why.c_str(), rejectedLocked());
}

unsigned long EstimatorNodelet::rejectedLocked() const
{
  std::uint64_t refused = stream_->refusedOther();
  for (std::uint64_t n : stream_->refusedPerSensor())
    refused += n;
  return static_cast<unsigned long>(stream_->online().counters().rejected + rejected_topic_ + refused);
}

StepEstimatePtr EstimatorNodelet::stepLocked(long k)
{
  const OnlineEstimator& online = stream_->online();
  const Estimator& est = online.estimator();
  auto e = std::make_shared<StepEstimate>();
  e->stamp.fromSec(stream_->timeline().clock().stamp(k));
  e->step = static_cast<std::uint64_t>(k);
  e->gamma = online.lastGamma();
  e->x = est.state();
  e->P = est.covariance();
  e->trace = e->P.trace();
  const double q = est.commandArrivalProbability();
  e->command_arrival_probability = std::isfinite(q) ? q : -1.0;
  link_.step(online);
  last_trace_ = e->trace;
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
