// The Estimator nodelet's own diagnostics (estimator_nodelet.hpp): the "estimator" status, per
// sensor figures, and input topics advertised with another type than configured.
#include "estimator_nodelet.hpp"

namespace networked_estimation
{

std::vector<std::string> EstimatorNodelet::wrongTypes()
{
  const Model& model = stream_->online().model();
  std::vector<bool> silent(config_.inputs.size(), true);
  bool any = model.hasControl();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool first = heard_.size() != config_.inputs.size();
    heard_.resize(config_.inputs.size(), 0);
    for (std::size_t i = 0; i < config_.inputs.size(); ++i)
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
  auto check = [&](const std::string& who, const std::string& topic, const std::string& expected)
  {
    const std::string name = nh.resolveName(topic);
    for (const ros::master::TopicInfo& t : topics)
      if (t.name == name && t.datatype != expected)
        out.push_back(who + ": " + name + " is " + t.datatype + ", expected " + expected);
  };
  for (std::size_t i = 0; i < config_.inputs.size(); ++i)
    if (silent[i])
      check("sensor '" + model.sensors[i].name + "'", config_.inputs[i].topic, toString(config_.inputs[i].type));
  if (model.hasControl())
    check("command", config_.command.topic, toString(config_.command.type));
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
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "covariance trace %.4g above trace_bound %.4g", last_trace_,
                  trace_bound_);
  else
    stat.summaryf(diagnostic_msgs::DiagnosticStatus::OK, "step %ld, arrival rate %.3f", online.nextStep() - 1, arrival);
  if (!wrong.empty())
    stat.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "wrong message type: %s", wrong.front().c_str());
  // Messages refused for their stamp (stamp 0, ahead of ROS time...) and timeline restarts, over
  // the last 10 s, naming the sensor and the reason.
  for (const std::string& w : stream_->stampWarnings(now.toSec()))
    stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, w);
  stat.add("wrong type inputs", wrong.size());
  stat.add("algorithm", toString(config_.settings.algorithm));
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
  for (std::size_t i = 0; i < config_.inputs.size(); ++i)
    if (std::isfinite(config_.inputs[i].rejection_threshold))
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
  for (std::size_t i = 0; i < config_.inputs.size(); ++i)
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
    if (config_.inputs[i].type == InputType::IMU)
      stat.add(name + " without estimate (covariance -1)", c.disabled_per_sensor[i]);
    else if (config_.inputs[i].differential)
      stat.add(name + " reference poses (differential)", c.disabled_per_sensor[i]);
    else if (gnss_ && config_.inputs[i].type == InputType::NAVSATFIX)
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

}  // namespace networked_estimation
