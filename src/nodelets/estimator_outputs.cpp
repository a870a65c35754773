// The Estimator nodelet (estimator_nodelet.hpp): what it publishes: the estimate, odometry/filtered,
// pose, tf, the NavSatFix datum and the diagnostics.
#include "estimator_nodelet.hpp"

#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/motion/linearised_model.hpp"

namespace networked_estimation
{

void EstimatorNodelet::publishDatum(const LocalEnu& d)
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

void EstimatorNodelet::publishLocked(const Estimate::Ptr& e)
{
  {
    estimate_pub_.publish(e);
    if (trace_pub_.getNumSubscribers() > 0)
    {
      std_msgs::Float64::Ptr t = boost::make_shared<std_msgs::Float64>();
      t->data = e->covariance_trace;
      trace_pub_.publish(t);
    }
    if (predict_to_current_time_)
      last_step_ = e;  // odometry/filtered and tf come from predictTimer()
    else if (odom_pub_.getNumSubscribers() > 0)
      publishOdometry(*e);
    if (gnss_ && gnss_->wantsFiltered())
      publishFilteredGps(*e);
    const bool want_pose = pose_pub_.getNumSubscribers() > 0;
    if (publish_tf_ && !predict_to_current_time_)
    {
      last_estimate_ = e;  // tf leaves from tfTimer() in the nodelet's own queue, not this thread
      if (tf_timer_idle_)  // stopped while no estimate came (mutex held by both)
      {
        tf_timer_idle_ = false;
        tf_timer_.start();
      }
    }
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

void EstimatorNodelet::publishFilteredGps(const Estimate& e)
{
  const int n = static_cast<int>(e.state.size());
  const Eigen::Map<const Eigen::VectorXd> x(e.state.data(), n);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> P(
      e.covariance.data(), n, n);
  const int xyz[3] = {state_map_.x, state_map_.y, state_map_.z};
  Eigen::Matrix3d Pw = Eigen::Matrix3d::Zero();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      Pw(a, b) = xyz[a] >= 0 && xyz[b] >= 0 ? P(xyz[a], xyz[b]) : (a == b ? kUnmappedVariance : 0.0);
  gnss_->publishFiltered(basePoseOf(x, state_map_, gnss_roll_, gnss_pitch_), Pw, e.header.stamp);
}

void EstimatorNodelet::publishOdometry(const Estimate& e)
{
  const int n = static_cast<int>(e.state.size());
  const Eigen::Map<const Eigen::VectorXd> x(e.state.data(), n);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> P(
      e.covariance.data(), n, n);
  // Shared: an intra-process subscriber (a nodelet) gets it without serialization.
  odom_pub_.publish(
      boost::make_shared<const nav_msgs::Odometry>(toOdometry(x, P, state_map_, e.header.stamp, world_frame_, base_link_frame_)));
}

void EstimatorNodelet::predictTimer()
{
  Estimate::ConstPtr step;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    step = last_step_;
  }
  const ros::Time now = ros::Time::now();
  if (!step || now == last_predicted_ || now < step->header.stamp)
    return;  // no step yet, a stopped clock, or time went back (the stream restarts)
  const int n = static_cast<int>(step->state.size());
  const Eigen::Map<const Eigen::VectorXd> x(step->state.data(), n);
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> P(
      step->covariance.data(), n, n);
  Eigen::VectorXd xp;
  Eigen::MatrixXd Pp;
  double ahead = 0.0;
  try
  {
    ahead = predictAhead(*predict_model_, limits_.period, x, P, (now - step->header.stamp).toSec(), xp, Pp);
  }
  catch (const InputError& e)
  {
    NODELET_WARN_THROTTLE(10.0, "Estimator: predict_to_current_time: not predicted from step %lu: %s",
                          static_cast<unsigned long>(step->step), e.what());
    return;
  }
  last_predicted_ = now;
  Estimate::Ptr e = boost::make_shared<Estimate>(*step);
  e->header.stamp = step->header.stamp + ros::Duration(ahead);
  e->state.assign(xp.data(), xp.data() + n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      e->covariance[static_cast<std::size_t>(i) * n + j] = Pp(i, j);
  e->covariance_trace = Pp.trace();
  if (odom_pub_.getNumSubscribers() > 0)
    publishOdometry(*e);
  if (publish_tf_)
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_estimate_ = e;
    if (tf_timer_idle_)
    {
      tf_timer_idle_ = false;
      tf_timer_.start();
    }
  }
}

void EstimatorNodelet::tfTimer()
{
  Estimate::ConstPtr e;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    e = last_estimate_;
    if (!e || e->header.stamp == last_tf_)
    {
      // Nothing new (no input, a stopped clock): the timer stops until the next estimate starts
      // it again, rather than waking the manager's threads 20 times a second for nothing.
      tf_timer_.stop();
      tf_timer_idle_ = true;
      return;
    }
  }
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
  const Frames& f = frames();  // the tf2 buffer exists from onInit on in this mode
  std::string parent, publisher;
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    parent = foreign_parent_.at(ros::WallTime::now().toSec());
    publisher = foreign_parent_.publisher;
  }
  const TfPlan plan = planTf(world_frame_, odom_frame_, base_link_frame_, child_frame_id_, parent, publisher,
                             ros::this_node::getName());
  if (plan.kind == TfPlan::Kind::NONE)
  {
    NODELET_WARN_THROTTLE(10.0, "Estimator: no tf: %s", plan.reason.c_str());
    return;
  }
  const int n = static_cast<int>(e->state.size());
  const Eigen::Map<const Eigen::VectorXd> x(e->state.data(), n);
  const geometry_msgs::Pose p = poseOf(x, state_map_);
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
  {
    std::lock_guard<std::mutex> lock(tf_mutex_);
    own_tf_.sent(t);  // before it can come back on /tf
  }
  tf_->sendTransform(t);
}

void EstimatorNodelet::onTf(const ros::MessageEvent<tf2_msgs::TFMessage const>& e, bool static_tf)
{
  const double now = ros::WallTime::now().toSec();
  std::lock_guard<std::mutex> lock(tf_mutex_);
  for (const geometry_msgs::TransformStamped& t : e.getConstMessage()->transforms)
    foreign_parent_.saw(t, base_link_frame_, own_tf_, e.getPublisherName(), now, static_tf);
}

std::vector<std::string> EstimatorNodelet::wrongTypes()
{
  const Model& model = stream_->online().model();
  std::vector<bool> silent(inputs_.size(), true);
  bool any = model.hasControl();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool first = heard_.size() != inputs_.size();
    heard_.resize(inputs_.size(), 0);
    for (std::size_t i = 0; i < inputs_.size(); ++i)
    {
      const std::uint64_t n = stream_->online().counters().received_per_sensor[i] + stream_->refusedPerSensor()[i];
      silent[i] = first || n == heard_[i];
      heard_[i] = n;
      any = any || silent[i];
    }
  }
  const ros::WallTime now = ros::WallTime::now();
  if (!any)
    wrong_.clear();
  if (!any || (!wrong_asked_.isZero() && (now - wrong_asked_).toSec() < kWrongTypeSeconds))
    return wrong_;
  wrong_asked_ = now;
  ros::master::V_TopicInfo topics;
  if (!ros::master::getTopics(topics))
    return wrong_;
  std::vector<std::string> out;
  const ros::NodeHandle& nh = getNodeHandle();
  auto check = [&](const std::string& who, const std::string& topic, const std::string& expected) {
    const std::string name = nh.resolveName(topic);
    for (const ros::master::TopicInfo& t : topics)
      if (t.name == name && t.datatype != expected)
        out.push_back(who + ": " + name + " is " + t.datatype + ", expected " + expected);
  };
  for (std::size_t i = 0; i < inputs_.size(); ++i)
    if (silent[i])
      check("sensor '" + model.sensors[i].name + "'", inputs_[i].topic, toString(inputs_[i].type));
  if (model.hasControl())
    check("command", command_.topic, toString(command_.type));
  wrong_ = out;
  return out;
}

void EstimatorNodelet::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  const std::vector<std::string> wrong = wrongTypes();  // asks the master: outside the lock
  for (const std::string& w : wrong)
    NODELET_WARN_THROTTLE(10.0, "Estimator: wrong message type on an input topic: %s", w.c_str());
  // Asks this process's bus info (udp inputs only, when their publishers changed): outside the lock.
  transports_.update([this](const std::string& w) { NODELET_WARN("Estimator: %s", w.c_str()); });
  std::lock_guard<std::mutex> lock(mutex_);
  const OnlineEstimator& online = stream_->online();
  const OnlineCounters& c = online.counters();
  const ros::WallTime now = ros::WallTime::now();
  const double dt = last_diag_.isZero() ? 0.0 : (now - last_diag_).toSec();
  const double rate = dt > 0.0 ? static_cast<double>(c.processed - last_processed_) / dt : 0.0;
  last_diag_ = now;
  last_processed_ = c.processed;
  const double arrival = c.processed > 0 ? static_cast<double>(c.arrivals) / static_cast<double>(c.processed) : 0.0;
  if (!online.started())
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "waiting for measurements");
  else if (!(last_trace_ <= trace_bound_))
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "covariance trace %.4g above trace_bound %.4g",
                  last_trace_, trace_bound_);
  else
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "step %ld, arrival rate %.3f", online.nextStep() - 1,
                  arrival);
  if (!wrong.empty())
    stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "wrong message type: %s", wrong.front().c_str());
  // Messages refused for their stamp (stamp 0, ahead of ROS time...) and timeline restarts, over
  // the last 10 s, naming the sensor and the reason.
  for (const std::string& w : stream_->stampWarnings(now.toSec()))
    stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, w);
  stat.add("wrong type inputs", wrong.size());
  stat.add("algorithm", toString(settings_.algorithm));
  stat.add("steps", c.processed);
  stat.add("step rate (Hz)", rate);
  stat.add("arrival rate", arrival);
  stat.add("accepted", c.accepted);
  stat.add("late dropped", c.late_dropped);
  stat.add("poses set (set_pose)", c.estimates_set);
  stat.add("set_pose refused", set_pose_refused_.load());
  stat.add("late fused", c.late_fused);
  stat.add("duplicates", c.duplicates);
  stat.add("rejected", rejectedLocked());
  if (gnss_)
  {
    const bool aligned = gnss_->aligned();
    stat.add("GNSS aligned (navsat_transform)", aligned ? "yes" : "no");
    if (aligned)
      stat.add("GNSS world_T_enu yaw (rad)", gnss_->yawDelta());
    else if (gnss_->notYet() > 0)  // fixes came and could not be used yet
      stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                         "GNSS not aligned yet: %lu fixes not fused (waiting for a heading and an estimate)",
                         static_cast<unsigned long>(gnss_->notYet()));
  }
  stat.add("missing commands", c.missing_commands);
  stat.add("covariance fallbacks", covariance_fallbacks_);
  if (stream_->offsetCount() > 0)
  {
    stat.add("stamp offset mean (s)", stream_->offsetMean());
    stat.add("stamp offset max (s)", stream_->offsetMax());
  }
  for (std::size_t i = 0; i < inputs_.size(); ++i)
    if (std::isfinite(inputs_[i].rejection_threshold))
      stat.add(online.model().sensors[i].name + " rejected by threshold", c.gated_per_sensor[i]);
  // "arrival rate" above is gamma's (some sensor arrived); these count only the samples that
  // were due: scheduled, and at a slower sensor's own steps.
  stat.add("due samples", c.due);
  stat.add("due arrival rate", c.due > 0 ? static_cast<double>(c.due_arrived) / static_cast<double>(c.due) : 0.0);
  if (online.model().schedule.active())
  {
    stat.add("unscheduled measurements", c.unscheduled);
    if (online.model().schedule.kind == Schedule::Kind::RANDOM)
      stat.add("steps without schedule", c.schedule_missing);
  }
  stat.add("divergence resets", c.divergence_resets);
  stat.add("time resets", stream_->timeResets());
  stat.add("timeline restarts", stream_->restarts());
  if (!stream_->lastRestart().reason.empty())
    stat.add("last timeline restart", stream_->lastRestart().reason);
  stat.add("stamps refused (commands, schedules)", stream_->refusedOther());
  stat.add("latency budget (s)", stream_->budget());
  stat.add("latency budget", stream_->runtime().adaptive_latency ? "auto" : "fixed");
  for (const std::string& who : transports_.fallbacks())
    stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%s: udp fell back to TCPROS", who.c_str());
  for (const auto& kv : transports_.values())
    stat.add(kv.first, kv.second);
  diagnoseSensors(stat);
  stat.add("covariance trace", last_trace_);
  stat.add("trace bound", trace_bound_);
}

void EstimatorNodelet::diagnoseSensors(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  const OnlineEstimator& online = stream_->online();
  const OnlineCounters& c = online.counters();
  const LatencyBudget& latency = stream_->latency();
  const double now = ros::Time::now().toSec(), period = limits_.period;
  for (std::size_t i = 0; i < inputs_.size(); ++i)
  {
    const std::string& name = online.model().sensors[i].name;
    const LatencyBudget::Figures f = latency.figures(i, now);
    latency_figures_[i] = f;  // ~link_status carries the same numbers
    const double delay = f.delay_p99;
    stat.add(name + " messages", c.received_per_sensor[i] + stream_->refusedPerSensor()[i]);
    stat.add(name + " late dropped", c.late_dropped_per_sensor[i]);
    stat.add(name + " stamps refused", stream_->refusedPerSensor()[i]);
    if (!stream_->lastRefused(i).reason.empty())
      stat.add(name + " last stamp refused", stream_->lastRefused(i).reason);
    stat.add(name + " delay p50 (s)", f.delay_p50);
    stat.add(name + " delay p99 (s)", delay);
    stat.add(name + " late fraction", f.late_fraction);
    stat.add(name + " rate (Hz)", online.lattice(i).measuredRate(period));
    if (inputs_[i].type == InputType::IMU)
      stat.add(name + " without estimate (covariance -1)", c.disabled_per_sensor[i]);
    else if (inputs_[i].differential)
      stat.add(name + " reference poses (differential)", c.disabled_per_sensor[i]);
    else if (gnss_ && inputs_[i].type == InputType::NAVSATFIX)
      stat.add(name + " fixes before the GNSS alignment (not fused)", c.disabled_per_sensor[i]);
    if (f.late_fraction > 0.01)
      stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                         "sensor '%s': %.1f %% of its messages over the last %d s late or refused (delay p99 %.0f ms, "
                         "latency budget %.0f ms)",
                         name.c_str(), 100.0 * f.late_fraction, LatencyBudget::kLateSeconds, 1e3 * delay,
                         1e3 * stream_->budget());
    std::string why;
    if (online.lattice(i).mismatch(period, &why))
    {
      stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "sensor '%s': %s", name.c_str(), why.c_str());
      NODELET_WARN_THROTTLE(30.0, "Estimator: sensor '%s': %s", name.c_str(), why.c_str());
    }
  }
}

namespace
{
/// Two Jacobians of a motion give the same verdicts for the live diagnostic: no entry moved by more
/// than 0.1 % of the largest (the verdicts depend on the structure, not on small changes).
bool sameLinearisation(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b)
{
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a - b).cwiseAbs().maxCoeff() <= 1e-3 * std::max(1.0, b.cwiseAbs().maxCoeff());
}
}  // namespace

void EstimatorNodelet::diagnoseLink(diagnostic_updater::DiagnosticStatusWrapper& stat)
{
  // Copied under the lock, evaluated outside it (three core stability tests and the Gan-Liu
  // evidence, well under a millisecond), so the filter thread is never held up by it.
  std::unique_ptr<LiveStability> snapshot;
  Eigen::VectorXd estimate;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    snapshot = std::make_unique<LiveStability>(*live_);
    if (motion_model_)
      estimate = stream_->online().estimator().state();
  }
  const LiveStability* evaluated = snapshot.get();
  if (motion_model_)  // a built-in motion: the verdicts of its linearisation at the estimate
  {
    // (the sensors' rates change the schedule, not A: compare first, add them only to rebuild)
    const Model local = linearisedModel(*motion_model_, estimate, limits_.period);
    if (!local_ || !sameLinearisation(local_->model().A, local.A))
    {
      local_ = std::make_unique<LiveStability>(snapshot->relinearised(withSensorRates(local, rate_ratios_)));
      ++relinearisations_;
    }
    else
      local_->takeWindows(*snapshot);
    evaluated = local_.get();
  }
  LiveStabilityReport report = evaluated->evaluate();
  if (motion_model_)
    report.values.emplace_back("linearisation", "at the estimate (a local verdict), rebuilt " +
                                                    std::to_string(relinearisations_) +
                                                    " times: when the Jacobian moves by over 0.1 % of its largest entry");
  const unsigned char level = report.status.level == LinkCondition::Level::OK ? diagnostic_msgs::DiagnosticStatus::OK
                              : report.status.level == LinkCondition::Level::WARN
                                  ? diagnostic_msgs::DiagnosticStatus::WARN
                                  : diagnostic_msgs::DiagnosticStatus::ERROR;
  stat.summary(level, report.status.message);
  for (const auto& kv : report.values)
    stat.add(kv.first, kv.second);
  link_report_ = std::move(report);  // ~link_status carries the same numbers
  link_reported_ = true;
}

void EstimatorNodelet::publishLinkStatus()
{
  const Model& model = stream_->online().model();
  const ros::Time stamp = ros::Time::now();
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    const SensorLinkFigures* link =
        link_reported_ && i < link_report_.sensors.size() ? &link_report_.sensors[i] : nullptr;
    link_status_pub_.publish(linkStatusMessage(model.sensors[i].name, stamp, latency_figures_[i], link,
                                               link_reported_ ? toString(link_report_.status.level) : ""));
  }
}
}  // namespace networked_estimation
