// The live per-sensor stability verdict (joint_link_monitor.hpp).
#include "networked_estimation/stability/joint_link_monitor.hpp"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace networked_estimation
{
namespace
{

std::string rates(const std::vector<SensorLinkEstimate>& sensors, bool markov)
{
  std::ostringstream os;
  os.precision(3);
  for (std::size_t i = 0; i < sensors.size(); ++i)
  {
    const SensorLinkEstimate& s = sensors[i];
    os << (i ? ", " : "") << s.sensor << " ";
    if (markov)
      os << "p " << s.failure.value << " r " << s.recovery.value;
    else
      os << s.arrival.value << " [" << s.arrival.lower << ", " << s.arrival.upper << "]";
  }
  return os.str();
}

}  // namespace

namespace
{

/// The live verdicts: no per-set analyses, and no MARE fallback (evaluated every second; where
/// Theorem 14 cannot decide, the verdict is undecided and analyze says more).
AnalysisOptions liveOptions()
{
  AnalysisOptions o;
  o.per_sensor = false;
  o.use_mare = false;
  return o;
}

std::vector<int> everySensor(const Model& model)
{
  std::vector<int> all;
  for (std::size_t s = 0; s < model.sensors.size(); ++s)
    all.push_back(static_cast<int>(s));
  return all;
}

}  // namespace

JointLinkMonitor::JointLinkMonitor(const Model& model, std::size_t window, bool markov, std::size_t min_samples)
  : model_(model), verdicts_(model, everySensor(model), liveOptions()), markov_(markov), min_samples_(min_samples)
{
  for (std::size_t s = 0; s < model.sensors.size(); ++s)
  {
    monitors_.emplace_back(window);
  }
  skipped_.assign(monitors_.size(), 0);
  all_due_.assign(monitors_.size(), true);
}

void JointLinkMonitor::add(const std::vector<bool>& arrived)
{
  add(arrived, all_due_);
}

void JointLinkMonitor::add(const std::vector<bool>& arrived, const std::vector<bool>& due)
{
  if (due.size() != monitors_.size())
    throw std::invalid_argument("JointLinkMonitor: " + std::to_string(due.size()) + " due flags for " +
                                std::to_string(monitors_.size()) + " sensors");
  if (arrived.size() != monitors_.size())
    throw std::invalid_argument("JointLinkMonitor: " + std::to_string(arrived.size()) + " arrival flags for " +
                                std::to_string(monitors_.size()) + " sensors");
  for (std::size_t s = 0; s < monitors_.size(); ++s)
  {
    if (!due[s])
    {
      skipped_[s] = 1;
      continue;
    }
    monitors_[s].add(arrived[s], !skipped_[s]);
    skipped_[s] = 0;
  }
}

void JointLinkMonitor::clear()
{
  for (LinkMonitor& m : monitors_)
    m.clear();
  std::fill(skipped_.begin(), skipped_.end(), 0);
}

void JointLinkMonitor::takeWindows(const JointLinkMonitor& from)
{
  if (from.monitors_.size() != monitors_.size() || from.markov_ != markov_)
    throw std::invalid_argument("JointLinkMonitor::takeWindows: the other monitor has " +
                                std::to_string(from.monitors_.size()) + " sensors (" +
                                (from.markov_ ? "markov" : "iid") + "), this one " + std::to_string(monitors_.size()) +
                                " (" + (markov_ ? "markov" : "iid") + ")");
  for (std::size_t s = 0; s < monitors_.size(); ++s)
    if (from.model_.sensors[s].name != model_.sensors[s].name)
      throw std::invalid_argument("JointLinkMonitor::takeWindows: sensor " + std::to_string(s) + " is '" +
                                  from.model_.sensors[s].name + "' there, '" + model_.sensors[s].name + "' here");
  monitors_ = from.monitors_;
  skipped_ = from.skipped_;
}

JointLinkStatus JointLinkMonitor::evaluate() const
{
  JointLinkStatus out;
  std::size_t fewest = static_cast<std::size_t>(-1);
  std::string fewest_sensor;
  for (std::size_t s = 0; s < monitors_.size(); ++s)
  {
    const LinkMonitor& m = monitors_[s];
    // The estimates and the links at the ends of their intervals: link_estimates.hpp, the same
    // functions as the offline fit (fit_link, analyze --bag).
    const LinkEstimate le = m.estimates();
    SensorLinkEstimate e;
    e.sensor = model_.sensors[s].name;
    e.arrival = le.arrival;
    e.recovery = le.recovery;
    e.failure = le.failure;
    const std::size_t trials = linkTrials(le, markov_);
    if (trials < fewest)
    {
      fewest = trials;
      fewest_sensor = e.sensor;
    }
    out.pessimistic_links.push_back(linkAt(le, markov_, IntervalEnd::PESSIMISTIC));
    out.optimistic_links.push_back(linkAt(le, markov_, IntervalEnd::OPTIMISTIC));
    out.point_links.push_back(linkAt(le, markov_, IntervalEnd::POINT));
    out.sensors.push_back(e);
  }
  // The links' verdicts: the level concerns what the links can change. Modes that no sensor observes
  // (a robot's dead-reckoned position) grow whatever the links do; the message names them.
  out.pessimistic = verdicts_.linksVerdict(out.pessimistic_links);
  out.optimistic = verdicts_.linksVerdict(out.optimistic_links);
  out.point = verdicts_.linksVerdict(out.point_links);

  std::ostringstream os;
  const std::string what = markov_ ? "links (p, r)" : "arrival rates";
  if (fewest < min_samples_)
  {
    out.status.level = LinkCondition::Level::WARN;
    os << "not enough samples to estimate sensor " << fewest_sensor << "'s link (" << fewest << " < " << min_samples_
       << ")";
  }
  else if (out.pessimistic.kind == Verdict::Kind::STABLE)
  {
    out.status.level = LinkCondition::Level::OK;
    os << "bounded even at the low ends of the intervals (" << rates(out.sensors, markov_) << ")";
  }
  else if (out.optimistic.kind == Verdict::Kind::UNSTABLE)
  {
    out.status.level = LinkCondition::Level::ERROR;
    os << "expected error covariance unbounded at these " << what << " (" << rates(out.sensors, markov_)
       << "), even at the high ends of the intervals: " << out.optimistic.reason;
  }
  else
  {
    out.status.level = LinkCondition::Level::WARN;
    os << "boundedness not guaranteed at these " << what << " (" << rates(out.sensors, markov_)
       << "): at the estimates " << toString(out.point.kind) << ", " << out.point.reason;
  }
  if (!verdicts_.deadStates().empty())
    os << "; dead-reckoned: " << growRegardless(verdicts_.deadStates()) << " (no sensor observes them)";
  out.status.message = os.str();
  return out;
}

}  // namespace networked_estimation
