// Live link diagnostics (link_monitor.hpp).
#include "networked_estimation/stability/link_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

LinkMonitor::LinkMonitor(std::size_t window)
{
  if (window < 2)
    throw std::invalid_argument("LinkMonitor: window must be at least 2");
  ring_.assign(window, 0);
}

void LinkMonitor::clear()
{
  head_ = 0;
  counts_ = ArrivalCounts();
  total_ = 0;
}

void LinkMonitor::add(bool arrived, bool follows_previous)
{
  constexpr std::uint8_t ARRIVED = 1, FOLLOWS = 2;
  const std::size_t w = ring_.size();
  if (counts_.samples == w)
  {
    // Evict the oldest sample and the transition (oldest, second oldest) when they were
    // consecutive steps.
    const bool old = (ring_[head_] & ARRIVED) != 0;
    const std::uint8_t second = ring_[(head_ + 1) % w];
    counts_.removeSample(old);
    if (second & FOLLOWS)
      counts_.removeTransition(old, (second & ARRIVED) != 0);
    head_ = (head_ + 1) % w;
  }
  const std::size_t count = counts_.samples;
  const bool transition = count > 0 && follows_previous;
  if (transition)
    counts_.addTransition((ring_[(head_ + count - 1) % w] & ARRIVED) != 0, arrived);
  ring_[(head_ + count) % w] = static_cast<std::uint8_t>((arrived ? ARRIVED : 0) | (transition ? FOLLOWS : 0));
  counts_.addSample(arrived);
  ++total_;
}

std::vector<bool> LinkMonitor::window() const
{
  std::vector<bool> out(counts_.samples);
  for (std::size_t i = 0; i < counts_.samples; ++i)
    out[i] = (ring_[(head_ + i) % ring_.size()] & 1) != 0;
  return out;
}

RateEstimate LinkMonitor::arrivalRate() const
{
  return arrivalEstimate(counts_);
}

RateEstimate LinkMonitor::recoveryRate() const
{
  return recoveryEstimate(counts_);
}

RateEstimate LinkMonitor::failureRate() const
{
  return failureEstimate(counts_);
}

LinkThresholds linkThresholds(const StabilityReport& report, std::size_t min_samples)
{
  // The links' thresholds: of the observed modes when some mode grows regardless of the links.
  const RateAnalysis& ra = report.model.observed.empty() ? report.model : report.model.observed.front();
  LinkThresholds t;
  t.min_samples = min_samples;
  const bool markov = report.has_channel && report.link.kind == LinkModel::Kind::GILBERT_ELLIOTT;
  t.quantity = markov ? "recovery rate" : "arrival rate";
  double nec = ra.necessary_threshold, suf = ra.sufficient_threshold;
  if (std::isnan(nec))
    nec = markov ? ra.recovery_lower_bound : ra.lower_bound;
  if (std::isnan(suf) || suf > 1.0)
    suf = 1.0;
  t.necessary = nec;
  t.sufficient = std::max(nec, suf);
  return t;
}

std::string toString(LinkCondition::Level level)
{
  switch (level)
  {
    case LinkCondition::Level::OK:
      return "OK";
    case LinkCondition::Level::WARN:
      return "WARN";
    case LinkCondition::Level::ERROR:
      return "ERROR";
  }
  return "?";
}

LinkCondition classifyLink(const RateEstimate& e, const LinkThresholds& t)
{
  LinkCondition s;
  std::ostringstream os;
  os.precision(3);
  if (e.trials < t.min_samples)
  {
    s.level = LinkCondition::Level::WARN;
    os << "not enough samples to estimate the " << t.quantity << " (" << e.trials << " < " << t.min_samples << ")";
  }
  else if (e.upper < t.necessary)
  {
    s.level = LinkCondition::Level::ERROR;
    os << "expected error covariance unbounded at this " << t.quantity << " (" << e.value << " < critical "
       << t.necessary << ")";
  }
  else if (e.lower > t.sufficient)
  {
    s.level = LinkCondition::Level::OK;
    os << t.quantity << " " << e.value << " [" << e.lower << ", " << e.upper << "] above the critical " << t.sufficient;
  }
  else if (e.lower >= t.necessary && e.upper <= t.sufficient)
  {
    s.level = LinkCondition::Level::WARN;
    os << t.quantity << " " << e.value << " inside the undecided band [" << t.necessary << ", " << t.sufficient
       << "]: boundedness not guaranteed";
  }
  else
  {
    s.level = LinkCondition::Level::WARN;
    os << t.quantity << " " << e.value << " [" << e.lower << ", " << e.upper << "] too close to the critical "
       << (e.lower < t.necessary ? t.necessary : t.sufficient);
  }
  s.message = os.str();
  return s;
}

}  // namespace networked_estimation
