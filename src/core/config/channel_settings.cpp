// Reading and validating the channel settings (docs/formats.md, "Channel settings"), and their
// runtime changes.
#include "networked_estimation/config/channel_settings.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

ChannelSettings parseChannelSettingsImpl(const YAML::Node& node, const std::string& source)
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(node, "",
               {"model", "loss", "p", "r", "loss_bad", "loss_good", "seed", "delay", "jitter",
                "distribution", "reorder", "duplicate", "queue_limit"});

  ChannelSettings settings;
  static const std::vector<std::string> model_names = {"bernoulli", "gilbert_elliott"};
  const YAML::Node model = in.require(node, "", "model");
  const std::size_t model_index = in.choice(model, "model", "loss model", model_names);
  settings.model = model_index == 0 ? LossModelKind::BERNOULLI : LossModelKind::GILBERT_ELLIOTT;

  // Keys of the other model are rejected.
  const std::vector<std::string> other_keys =
      model_index == 0 ? std::vector<std::string>{"p", "r", "loss_bad", "loss_good"}
                       : std::vector<std::string>{"loss"};
  for (auto it = node.begin(); it != node.end(); ++it)
  {
    const std::string key = it->first.Scalar();
    if (std::find(other_keys.begin(), other_keys.end(), key) != other_keys.end())
    {
      in.fail(it->first, key,
              "key '" + key + "' applies only to model " + model_names[1 - model_index] +
                  " (model is " + model_names[model_index] + ")");
    }
  }

  if (settings.model == LossModelKind::BERNOULLI)
  {
    settings.loss =
        in.probability(in.require(node, "", "loss", "model bernoulli needs loss"), "loss");
  }
  else
  {
    settings.p =
        in.probability(in.require(node, "", "p", "model gilbert_elliott needs p and r"), "p");
    settings.r =
        in.probability(in.require(node, "", "r", "model gilbert_elliott needs p and r"), "r");
    if (node["loss_bad"])
    {
      settings.loss_bad = in.probability(node["loss_bad"], "loss_bad");
    }
    if (node["loss_good"])
    {
      settings.loss_good = in.probability(node["loss_good"], "loss_good");
    }
  }

  if (node["seed"])
  {
    settings.seed = in.integer(node["seed"], "seed", 0);
  }
  if (node["delay"])
  {
    settings.delay = in.nonNegative(node["delay"], "delay", "number of seconds");
  }
  if (node["jitter"])
  {
    settings.jitter = in.nonNegative(node["jitter"], "jitter", "number of seconds");
  }
  if (node["distribution"])
  {
    static const std::vector<std::string> names = {"uniform", "normal", "pareto"};
    static const DelayDistribution values[] = {
        DelayDistribution::UNIFORM, DelayDistribution::NORMAL, DelayDistribution::PARETO};
    settings.distribution =
        values[in.choice(node["distribution"], "distribution", "distribution", names)];
  }
  if (node["reorder"])
  {
    settings.reorder = in.boolean(node["reorder"], "reorder");
  }
  if (node["duplicate"])
  {
    settings.duplicate = in.probability(node["duplicate"], "duplicate");
  }
  if (const YAML::Node limit = node["queue_limit"])
  {
    const std::uint64_t value = in.integer(limit, "queue_limit", 1);
    if (value > std::numeric_limits<std::size_t>::max())
    {
      in.fail(limit, "queue_limit", "integer out of range, found " + limit.Scalar());
    }
    settings.queue_limit = static_cast<std::size_t>(value);
  }
  return settings;
}

}  // namespace

ChannelSettings parseChannelSettings(const YAML::Node& node, const std::string& source)
{
  return guarded(source,
                 [&]
                 {
                   return parseChannelSettingsImpl(node, source);
                 });
}

ChannelSettings loadChannelSettings(const std::string& path)
{
  return parseChannelSettings(loadYamlFile(path), path);
}

namespace
{
/// The shortest text that reads back as exactly this double (0.05, not 0.050000000000000003).
YAML::Node shortest(double v)
{
  return YAML::Node(formatNumber(v));
}
}  // namespace

YAML::Node toYaml(const ChannelSettings& settings)
{
  static const char* distributions[] = {"uniform", "normal", "pareto"};
  YAML::Node node;
  if (settings.model == LossModelKind::BERNOULLI)
  {
    node["model"] = "bernoulli";
    node["loss"] = shortest(settings.loss);
  }
  else
  {
    node["model"] = "gilbert_elliott";
    node["p"] = shortest(settings.p);
    node["r"] = shortest(settings.r);
    node["loss_bad"] = shortest(settings.loss_bad);
    node["loss_good"] = shortest(settings.loss_good);
  }
  node["seed"] = settings.seed;
  node["delay"] = shortest(settings.delay);
  node["jitter"] = shortest(settings.jitter);
  node["distribution"] = distributions[static_cast<int>(settings.distribution)];
  node["reorder"] = settings.reorder;
  node["duplicate"] = shortest(settings.duplicate);
  node["queue_limit"] = static_cast<std::uint64_t>(settings.queue_limit);
  return node;
}

ChannelSettings mergeChannelSettings(const ChannelSettings& base, const YAML::Node& changes,
                                     const std::string& source)
{
  return guarded(source, [&] {
    if (!changes.IsMap())
      throw ConfigError(source + ": expected a map of settings to change, e.g. {loss: 0.5}");
    YAML::Node merged = toYaml(base);
    if (changes["model"])
    {
      for (const char* key : {"loss", "p", "r", "loss_bad", "loss_good"})
        merged.remove(key);
    }
    for (auto it = changes.begin(); it != changes.end(); ++it)
      merged[it->first.Scalar()] = it->second;
    return parseChannelSettingsImpl(merged, source);
  });
}

}  // namespace networked_estimation
