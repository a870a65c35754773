// The live stability verdict of a multi-sensor estimator: one window per sensor (its own arrival
// sequence, not "some sensor arrived"), each link estimated from its own sequence with 95 %
// intervals (i.i.d.: the arrival rate; Markov: the failure rate p and the recovery rate r, nothing
// assumed), and the joint verdict from the estimated links through the same core test as analyze
// (SetVerdicts, built once with the monitor: the model's part of the test is not redone). The
// verdicts are the links' (the modes the sensors observe: dead-reckoned modes grow whatever the
// links do and are named in the message, not counted as a link problem). The interval ends give a
// pessimistic and an optimistic set of links:
//   OK     the pessimistic links are stable (every link at the bad end of its interval),
//   ERROR  even the optimistic links are unstable,
//   WARN   otherwise (the intervals straddle the boundary, undecided, or too few samples).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/stability/link_monitor.hpp"
#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

/// One sensor's link as measured.
struct SensorLinkEstimate
{
  std::string sensor;
  RateEstimate arrival;   ///< P(arrived)
  RateEstimate recovery;  ///< P(arrived | lost before) (Markov mode)
  RateEstimate failure;   ///< P(lost | arrived before) (Markov mode)
};

struct JointLinkStatus
{
  LinkCondition status;  ///< OK / WARN / ERROR and its message
  std::vector<SensorLinkEstimate> sensors;
  /// The links' verdicts (SetVerdicts::linksVerdict: the modes the sensors observe) at the interval
  /// ends and at the estimates.
  Verdict pessimistic, optimistic, point;
  std::vector<LinkModel> pessimistic_links, optimistic_links, point_links;
};

class JointLinkMonitor
{
public:
  /// markov: estimate on/off Gilbert-Elliott links (p and r) instead of i.i.d. arrival rates.
  /// window >= 2; min_samples: fewer trials than this (arrivals, or transitions in Markov mode) in
  /// any sensor's window give WARN. The model must outlive the monitor.
  JointLinkMonitor(const Model& model, std::size_t window, bool markov, std::size_t min_samples);

  /// Records one step: arrived[s] for every sensor s of the model (size = sensors). Throws
  /// std::invalid_argument on a wrong size.
  void add(const std::vector<bool>& arrived);
  /// Records one step of a scheduled model: only the sensors with due[s] (scheduled to transmit)
  /// enter their windows, so a sensor that was not due is never counted as lost; a due sample
  /// after skipped steps starts no transition (LinkMonitor::add).
  void add(const std::vector<bool>& arrived, const std::vector<bool>& due);
  void clear();
  /// The windows of `from` (a monitor of a model with the same sensors, e.g. another linearisation
  /// of a built-in motion) in place of this one's; the verdicts stay this monitor's. Throws
  /// std::invalid_argument when the sensors or the mode differ.
  void takeWindows(const JointLinkMonitor& from);
  std::size_t sensors() const { return monitors_.size(); }
  const LinkMonitor& sensor(std::size_t s) const { return monitors_[s]; }
  bool markov() const { return markov_; }

  /// The estimates and the joint verdict now (three verdicts of the same SetVerdicts).
  JointLinkStatus evaluate() const;
  /// The verdicts of the model's sensors (every one), shared with copies of the monitor.
  const SetVerdicts& verdicts() const { return verdicts_; }

private:
  const Model& model_;
  SetVerdicts verdicts_;
  bool markov_;
  std::size_t min_samples_;
  std::vector<LinkMonitor> monitors_;
  std::vector<char> skipped_;  ///< per sensor: steps were skipped since its last due sample
  std::vector<bool> all_due_;
};

}  // namespace networked_estimation
