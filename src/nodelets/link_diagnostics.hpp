// The Estimator's link diagnostics, an owned part of the nodelet: the live stability window of each
// sensor and the joint verdict (stability/live_stability.hpp), for a built-in motion at its
// linearisation about the estimate (a local verdict, docs/stability.md 5), published as the
// "link stability" diagnostic and, one message per sensor, on ~link_status.
//
// Threads: step() and clear() run with the filter's lock held; diagnose() copies the window under
// that lock and evaluates outside it, on the diagnostics' thread, which alone calls publishStatus().
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "networked_estimation/online/estimator_node_config.hpp"
#include "networked_estimation/online/latency_budget.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/stability/live_stability.hpp"

namespace networked_estimation
{

class LinkDiagnostics
{
public:
  /// From the configuration; `name`: the nodelet's, for the logs. With live_stability false there
  /// is no window, verdict or status (enabled() false).
  void configure(const EstimatorNodeConfig& c, const std::string& name);
  bool enabled() const { return live_ != nullptr; }
  /// Advertises ~link_status.
  void advertise(ros::NodeHandle& pnh);

  /// The step just taken (the filter's lock held).
  void step(const OnlineEstimator& online);
  /// The stream restarted (the filter's lock held).
  void clear();

  /// The "link stability" diagnostic. `lock` is the filter's; `estimate` gives x_{k|k} with it held.
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat, std::mutex& lock,
                const std::function<Eigen::VectorXd()>& estimate);
  /// ~link_status: one LinkStatus per sensor from the last diagnostics' numbers (their thread).
  void publishStatus(const Model& model, const std::vector<LatencyBudget::Figures>& latency);

private:
  std::unique_ptr<LiveStability> live_;
  /// A built-in motion: the motion model, the sensors' rate ratios, and the verdicts of its
  /// linearisation at the estimate, rebuilt when the Jacobian moved (the diagnostics' thread only).
  std::unique_ptr<const Model> motion_model_;
  std::vector<double> rate_ratios_;
  double period_ = 0.0;
  std::unique_ptr<LiveStability> local_;
  std::uint64_t relinearisations_ = 0;
  std::uint64_t resets_seen_ = 0;  ///< divergence resets of the filter already told to live_
  ros::Publisher status_pub_;
  LiveStabilityReport report_;
  bool reported_ = false;
};

}  // namespace networked_estimation
