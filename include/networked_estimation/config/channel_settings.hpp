// Channel settings: the loss model of a link and, for the LossyChannel nodelet, its delay,
// reordering, duplication and queue (docs/formats.md, "Channel settings").
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace YAML
{
class Node;
}

namespace networked_estimation
{

struct ChannelTrace;

enum class LossModelKind
{
  BERNOULLI,
  GILBERT_ELLIOTT,
  TRACE  ///< a recorded link replayed message for message (link/channel_trace.hpp)
};

enum class DelayDistribution
{
  UNIFORM,
  NORMAL,
  PARETO
};

struct ChannelSettings
{
  LossModelKind model = LossModelKind::BERNOULLI;
  double loss = 0.0;       ///< bernoulli: P(lost)
  double p = 0.0;          ///< gilbert_elliott: P(good -> bad)
  double r = 1.0;          ///< gilbert_elliott: P(bad -> good)
  double loss_bad = 1.0;   ///< P(lost | bad)
  double loss_good = 0.0;  ///< P(lost | good)
  std::uint64_t seed = 0;
  // nodelet only
  double delay = 0.0;
  double jitter = 0.0;
  DelayDistribution distribution = DelayDistribution::UNIFORM;
  bool reorder = false;
  double duplicate = 0.0;
  std::size_t queue_limit = 1000;
  // trace: the recorded link (its file, the bag's topic, the rate; loaded with the settings)
  std::string trace;
  std::string trace_topic;
  double trace_rate = 0.0;  ///< Hz; 0: learnt from the stamps
  std::shared_ptr<const ChannelTrace> replay;
};

/// Parses and validates channel settings. Throws ConfigError naming the key. A relative `trace`
/// file is taken from the current directory (parseChannelSettings) or from the channel file's
/// (loadChannelSettings).
ChannelSettings parseChannelSettings(const YAML::Node& node, const std::string& source);
ChannelSettings loadChannelSettings(const std::string& path);

/// The settings as a YAML map that parseChannelSettings accepts (only the current model's keys).
YAML::Node toYaml(const ChannelSettings& settings);

/// `base` with the keys of the map `changes` replaced, validated as a whole (runtime changes).
/// When `changes` names another model, the old model's keys are dropped first. Throws ConfigError
/// naming the key; `base` is never modified.
ChannelSettings mergeChannelSettings(const ChannelSettings& base, const YAML::Node& changes, const std::string& source);

}  // namespace networked_estimation
