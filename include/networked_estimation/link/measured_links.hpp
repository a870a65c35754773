// The verdict for the links a robot has (analyze --bag): each sensor's link fitted from a topic of
// a recorded bag (fit_link's fit, the bag read once), put in place of a typed channel file, and the
// verdict taken on the fits and at the ends of their 95 % intervals, every measured link at its
// bad (good) end at once, as the live JointLinkMonitor takes it (link_estimates.hpp's ends). ROS-free.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/link/link_fit.hpp"
#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

struct MeasuredLink
{
  std::string sensor, topic;
  LinkFit fit;
};

/// Fits the links of a bag's topics and gives them to the model's sensors in `links`: `every_topic`
/// (when not empty) to every sensor without a link of its own, `sensor_topics` ("SENSOR=TOPIC") to
/// one sensor each. Throws ConfigError naming the option: an unknown sensor, a sensor given twice
/// or already given a --channel, --topic beside a plain --channel; InputError from the bag and fits.
std::vector<MeasuredLink> fitBagLinks(const Model& model, const std::string& bag, const std::string& every_topic,
                                      const std::vector<std::string>& sensor_topics, SensorLinks& links,
                                      const TraceOptions& options = {});

/// The links' verdicts with the measured links at the fits and at the ends of their intervals.
struct MeasuredVerdict
{
  VerdictReport point, pessimistic, optimistic;
  /// "bounded at the fitted links and at the intervals' worst ends", ...
  std::string summary;
  bool bounded_at_fit = false, bounded_at_worst_end = false;
};

MeasuredVerdict measuredVerdict(const Model& model, const SensorLinks& links,
                                const std::vector<MeasuredLink>& measured);

/// analyze's text of the measured links and their verdict.
std::string measuredText(const std::vector<MeasuredLink>& measured, const MeasuredVerdict& verdict);
/// The same as a JSON member value ({"links": [...], "point": ..., "pessimistic": ..., ...}).
std::string measuredJson(const std::vector<MeasuredLink>& measured, const MeasuredVerdict& verdict);

}  // namespace networked_estimation
