// The LossyChannel nodelet's settings as its dynamic_reconfigure config and back
// (lossy_channel_nodelet.cpp; cfg/LossyChannel.cfg).
#pragma once

#include <yaml-cpp/yaml.h>

#include <string>
#include <utility>

#include "networked_estimation/LossyChannelConfig.h"
#include "networked_estimation/config/channel_settings.hpp"

namespace networked_estimation
{

/// The settings as the dynamic_reconfigure config (the other model's keys at their defaults).
inline LossyChannelConfig toConfig(const ChannelSettings& s)
{
  LossyChannelConfig c = LossyChannelConfig::__getDefault__();
  const YAML::Node y = toYaml(s);
  c.model = y["model"].as<std::string>();
  for (auto& kv : {std::make_pair("loss", &c.loss), std::make_pair("p", &c.p), std::make_pair("r", &c.r),
                   std::make_pair("loss_bad", &c.loss_bad), std::make_pair("loss_good", &c.loss_good)})
    if (y[kv.first])
      *kv.second = y[kv.first].as<double>();
  c.delay = s.delay;
  c.jitter = s.jitter;
  c.distribution = y["distribution"] ? y["distribution"].as<std::string>() : c.distribution;
  c.reorder = s.reorder;
  c.duplicate = s.duplicate;
  c.queue_limit = static_cast<int>(s.queue_limit);
  return c;
}

/// The config's keys that apply to its model, as a YAML map for mergeChannelSettings.
inline YAML::Node toChanges(const LossyChannelConfig& c)
{
  YAML::Node y(YAML::NodeType::Map);
  y["model"] = c.model;
  if (c.model == "bernoulli")
    y["loss"] = c.loss;
  else if (c.model != "trace")  // a trace keeps its file and replays its own delays
  {
    y["p"] = c.p;
    y["r"] = c.r;
    y["loss_bad"] = c.loss_bad;
    y["loss_good"] = c.loss_good;
  }
  if (c.model != "trace")
  {
    y["delay"] = c.delay;
    y["jitter"] = c.jitter;
    y["distribution"] = c.distribution;
  }
  y["reorder"] = c.reorder;
  y["duplicate"] = c.duplicate;
  y["queue_limit"] = c.queue_limit;
  return y;
}

}  // namespace networked_estimation
