// The Estimator's ~link_status message (networked_estimation/LinkStatus): one sensor's link as
// numbers, from the same core figures its diagnostics are written from (LiveStability's report and
// LatencyBudget::figures), never from the diagnostics' strings. Header-only and master-free.
#pragma once

#include <boost/make_shared.hpp>
#include <ros/time.h>

#include <limits>
#include <string>

#include "networked_estimation/LinkStatus.h"
#include "networked_estimation/online/latency_budget.hpp"
#include "networked_estimation/stability/live_stability.hpp"

namespace networked_estimation
{

/// `link`: the sensor's figures in the live stability report (null without live_stability: the
/// rates and the margin are then NaN); `link_level`: the report's joint level ("OK", "WARN",
/// "ERROR"; empty without a report).
inline LinkStatus::Ptr linkStatusMessage(const std::string& sensor, const ros::Time& stamp,
                                         const LatencyBudget::Figures& latency, const SensorLinkFigures* link,
                                         const std::string& link_level)
{
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  LinkStatus::Ptr m = boost::make_shared<LinkStatus>();
  m->header.stamp = stamp;
  m->sensor = sensor;
  const RateEstimate none{nan, 0.0, 1.0, 0, 0};
  const RateEstimate& a = link ? link->arrival : none;
  const RateEstimate& p = link ? link->failure : none;
  const RateEstimate& r = link ? link->recovery : none;
  m->arrival_rate = a.value;
  m->arrival_rate_lower = a.lower;
  m->arrival_rate_upper = a.upper;
  m->arrival_samples = a.trials;
  m->p = p.value;
  m->p_lower = p.lower;
  m->p_upper = p.upper;
  m->p_transitions = p.trials;
  m->r = r.value;
  m->r_lower = r.lower;
  m->r_upper = r.upper;
  m->r_transitions = r.trials;
  m->late_fraction = latency.late_fraction;
  m->delay_p50 = latency.delay_p50;
  m->delay_p99 = latency.delay_p99;
  m->verdict = link ? link->needs : std::string();
  m->margin = link ? link->margin : nan;
  m->link_level = link_level;
  return m;
}

}  // namespace networked_estimation
