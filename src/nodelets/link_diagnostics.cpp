// The Estimator's link diagnostics (link_diagnostics.hpp).
#include "link_diagnostics.hpp"

#include "link_status_message.hpp"
#include "networked_estimation/config/rate_schedule.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/online/sensor_lattice.hpp"

namespace networked_estimation
{

void LinkDiagnostics::configure(const EstimatorNodeConfig& c, const std::string& name)
{
  // One window per sensor and the joint verdict of the same core test as `analyze`, the critical
  // rates of a single i.i.d. sensor, and Gan and Liu's evidence.
  LiveStabilityOptions live;
  live.window = c.stability_window;
  live.markov = c.markov_link;
  live.min_samples = c.stability_min_samples;
  live.late_data_dropped = c.online.late_policy == LatePolicy::DROP;
  period_ = c.period;
  // Sensors at their own rates: the verdicts see each sensor only at its own steps.
  rate_ratios_.clear();
  for (double r : c.online.rate_ratio)
    rate_ratios_.push_back(SensorLattice::whole(r));  // a 9.996 Hz sensor in a 30 Hz model: every 3rd step
  // A built-in motion: the verdicts of its linearisation over the steps' period, at x0 until the
  // first diagnostic, then at the estimate.
  if (c.model.nonlinear())
  {
    ROS_INFO_NAMED(name,
                   "Estimator: model '%s' has motion %s: the link verdicts are local, for its linearisation "
                   "at the current estimate",
                   c.model.name.c_str(), toString(c.model.motion).c_str());
    motion_model_ = std::make_unique<const Model>(c.model);
  }
  std::string rates_note;
  const Model stability_model =
      withSensorRates(linearisedModel(c.model, c.model.x0, c.period), rate_ratios_, &rates_note);
  if (!rates_note.empty())
    ROS_WARN_NAMED(name, "Estimator: %s", rates_note.c_str());
  if (c.live_stability)
    live_ = std::make_unique<LiveStability>(stability_model, c.settings, live);
}

void LinkDiagnostics::advertise(ros::NodeHandle& pnh)
{
  status_pub_ = pnh.advertise<LinkStatus>("link_status", 10);
}

void LinkDiagnostics::step(const OnlineEstimator& online)
{
  const std::uint64_t resets = online.counters().divergence_resets;
  if (live_)
    live_->add(online.lastArrived(), online.lastDue(), online.lastGamma(), online.estimator().covariance(),
               resets != resets_seen_);
  resets_seen_ = resets;
}

void LinkDiagnostics::clear()
{
  if (live_)
    live_->clear();
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

void LinkDiagnostics::diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat, std::mutex& lock,
                               const std::function<Eigen::VectorXd()>& estimate)
{
  // Copied under the lock, evaluated outside it (three core stability tests and the Gan-Liu
  // evidence, well under a millisecond), so the filter thread is never held up by it.
  std::unique_ptr<LiveStability> snapshot;
  Eigen::VectorXd x;
  {
    std::lock_guard<std::mutex> guard(lock);
    snapshot = std::make_unique<LiveStability>(*live_);
    if (motion_model_)
      x = estimate();
  }
  const LiveStability* evaluated = snapshot.get();
  if (motion_model_)  // a built-in motion: the verdicts of its linearisation at the estimate
  {
    // (the sensors' rates change the schedule, not A: compare first, add them only to rebuild)
    const Model local = linearisedModel(*motion_model_, x, period_);
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
    report.values.emplace_back("linearisation",
                               "at the estimate (a local verdict), rebuilt " + std::to_string(relinearisations_) +
                                   " times: when the Jacobian moves by over 0.1 % of its largest entry");
  const unsigned char level = report.status.level == LinkCondition::Level::OK ? diagnostic_msgs::DiagnosticStatus::OK
                              : report.status.level == LinkCondition::Level::WARN
                                  ? diagnostic_msgs::DiagnosticStatus::WARN
                                  : diagnostic_msgs::DiagnosticStatus::ERROR;
  stat.summary(level, report.status.message);
  for (const auto& kv : report.values)
    stat.add(kv.first, kv.second);
  report_ = std::move(report);  // ~link_status carries the same numbers
  reported_ = true;
}

void LinkDiagnostics::publishStatus(const Model& model, const std::vector<LatencyBudget::Figures>& latency)
{
  const ros::Time stamp = ros::Time::now();
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    const SensorLinkFigures* link = reported_ && i < report_.sensors.size() ? &report_.sensors[i] : nullptr;
    status_pub_.publish(linkStatusMessage(model.sensors[i].name, stamp, latency[i], link,
                                          reported_ ? toString(report_.status.level) : ""));
  }
}

}  // namespace networked_estimation
