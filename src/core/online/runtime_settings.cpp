// The Estimator's runtime settings and their checks (runtime_settings.hpp).
#include "networked_estimation/online/runtime_settings.hpp"

#include <cmath>
#include <sstream>

#include "networked_estimation/common/error.hpp"
#include "io/tokens.hpp"

namespace networked_estimation
{
namespace
{

std::string settingNumber(double v)
{
  return tokens::format(v, 10);
}

void budgetFits(const std::string& source, const std::string& key, double v, const RuntimeLimits& limits)
{
  const double future = static_cast<double>(limits.max_future_steps) * limits.period;
  if (!(v < future))
    throw ConfigError(source + ": " + key + ": expected below max_future_steps x period = " + settingNumber(future) +
                      " s (messages for the steps it waits on would be refused as far future), found " +
                      settingNumber(v));
  if (!(v <= limits.max_stamp_behind))
    throw ConfigError(source + ": " + key +
                      ": expected at most max_stamp_behind = " + settingNumber(limits.max_stamp_behind) +
                      " s (messages it waits for would be refused as too old), found " + settingNumber(v));
}

}  // namespace

void validateRuntimeSettings(const RuntimeSettings& s, const RuntimeLimits& limits, const std::string& source)
{
  auto seconds = [&](const std::string& key, double v, bool zero_ok)
  {
    if (!std::isfinite(v) || v < 0.0 || (!zero_ok && v == 0.0))
      throw ConfigError(source + ": " + key + ": expected a number of seconds " + (zero_ok ? ">= 0" : "> 0") +
                        ", found " + settingNumber(v));
  };
  seconds("latency_budget", s.latency_budget, true);
  seconds("latency_budget_min", s.latency_budget_min, true);
  seconds("latency_budget_max", s.latency_budget_max, false);
  if (s.latency_budget_min > s.latency_budget_max)
    throw ConfigError(source + ": latency_budget_min: expected at most latency_budget_max = " +
                      settingNumber(s.latency_budget_max) + " s, found " + settingNumber(s.latency_budget_min));
  if (s.adaptive_latency)
    budgetFits(source, "latency_budget_max", s.latency_budget_max, limits);
  else
    budgetFits(source, "latency_budget", s.latency_budget, limits);
  latePolicyFromString(s.late_policy, source);
  if (std::isnan(s.trace_bound) || s.trace_bound < 0.0)
    throw ConfigError(source + ": trace_bound: expected a number >= 0 (inf: no bound), found " +
                      settingNumber(s.trace_bound));
}

std::string describe(const RuntimeSettings& s)
{
  std::ostringstream o;
  o.precision(6);
  if (s.adaptive_latency)
    o << "latency_budget auto in [" << s.latency_budget_min << ", " << s.latency_budget_max << "] s";
  else
    o << "latency_budget " << s.latency_budget << " s";
  o << ", late_policy " << s.late_policy << ", trace_bound " << s.trace_bound;
  return o.str();
}

LatencyOptions latencyOptions(const RuntimeSettings& s, double period)
{
  LatencyOptions o;
  o.adaptive = s.adaptive_latency;
  o.fixed = s.latency_budget;
  o.min = s.latency_budget_min;
  o.max = s.latency_budget_max;
  o.period = period;
  return o;
}

}  // namespace networked_estimation
