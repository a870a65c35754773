// The Estimator's settings that may change while it runs (dynamic_reconfigure), validated as a
// whole, with the same checks at load and at every change: a change that fails any of them is
// refused naming the key, and nothing is clamped.
#pragma once

#include <limits>
#include <string>

#include "networked_estimation/online/latency_budget.hpp"
#include "networked_estimation/online/online_estimator.hpp"

namespace networked_estimation
{

struct RuntimeSettings
{
  /// latency_budget: auto (the default): the budget follows the sensors' delays within
  /// [latency_budget_min, latency_budget_max]; false: latency_budget, fixed.
  bool adaptive_latency = true;
  double latency_budget = 0.0;
  double latency_budget_min = 0.0, latency_budget_max = 1.0;
  std::string late_policy = "drop";
  double trace_bound = std::numeric_limits<double>::infinity();  ///< +inf: no bound
};

/// What the runtime settings must fit (fixed at load).
struct RuntimeLimits
{
  double period = 0.0;
  long max_future_steps = 1000;
  double max_stamp_behind = std::numeric_limits<double>::infinity();
};

/// Throws ConfigError "<source>: <key>: expected ..., found ..." for the first problem: a value
/// that is not a number (NaN) or out of its range, an unknown late_policy, and the inconsistent
/// combinations: latency_budget_min above latency_budget_max; a budget (the fixed one, or the
/// adaptive maximum) of max_future_steps periods or more (messages for the steps it waits on would
/// be refused as far future) or above max_stamp_behind (they would be refused as too old).
void validateRuntimeSettings(const RuntimeSettings& s, const RuntimeLimits& limits, const std::string& source);

/// "latency_budget auto in [0.01, 1] s, late_policy drop, trace_bound inf" (for logs).
std::string describe(const RuntimeSettings& s);

/// The latency options of the settings for a model of period `period`.
LatencyOptions latencyOptions(const RuntimeSettings& s, double period);

}  // namespace networked_estimation
