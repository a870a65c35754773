// A recorded link to replay (channel_trace.hpp).
#include "networked_estimation/link/channel_trace.hpp"

#include <fstream>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/link/link_fit.hpp"
#include "networked_estimation/link/link_trace.hpp"

namespace networked_estimation
{

bool isRosBag(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  char head[7] = {0};
  in.read(head, 7);
  return in && std::string(head, 7) == "#ROSBAG";
}

std::shared_ptr<const ChannelTrace> loadChannelTrace(const std::string& path, const std::string& topic, double rate)
{
  SlotTrace slots;
  TraceOptions options;
  options.rate = rate;
  if (isRosBag(path))
  {
    if (topic.empty())
      throw InputError(path + ": a ROS bag: trace_topic must name the topic to replay");
    slots = analyseLink(readBagLinks(path, {topic}).front(), options);
  }
  else
  {
    if (!topic.empty())
      throw InputError(path + ": not a ROS bag, so trace_topic ('" + topic + "') does not apply");
    if (isEventsCsv(path))
    {
      if (rate > 0.0)
        throw InputError(path + ": a LossyChannel's events: trace_rate does not apply (one slot per event)");
      slots = readEventSlots(path);
    }
    else
      slots = analyseLink(readLinkCsv(path), options);
  }
  auto trace = std::make_shared<ChannelTrace>();
  trace->source = slots.source;
  trace->period = slots.period;
  trace->arrived = slots.arrived;
  trace->delay = slots.delay;
  trace->copies = slots.copies;
  // The loss model analyze takes for the trace: fit_link's, by the same fit.
  const LossFit fit = fitLoss(slots.arrived);
  trace->fitted = settingsOf(fittedLink(fit, IntervalEnd::POINT));
  trace->fitted_note = "fitted to the trace: " + fit.chosen + ", " + fit.choice_note;
  return trace;
}

}  // namespace networked_estimation
