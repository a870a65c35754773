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
#include "networked_estimation/link/channel_trace.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

/// `reuse`: settings whose loaded trace is taken again when the trace keys are the same (runtime
/// changes do not read the file again); `base_dir`: where a relative trace file is.
ChannelSettings parseChannelSettingsImpl(const YAML::Node& node, const std::string& source,
                                         const ChannelSettings* reuse = nullptr, const std::string& base_dir = "")
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(node, "",
               {"model", "loss", "p", "r", "loss_bad", "loss_good", "seed", "delay", "jitter", "distribution",
                "reorder", "duplicate", "queue_limit", "trace", "trace_topic", "trace_rate"});

  ChannelSettings settings;
  static const std::vector<std::string> model_names = {"bernoulli", "gilbert_elliott", "trace"};
  const YAML::Node model = in.require(node, "", "model");
  const std::size_t model_index = in.choice(model, "model", "loss model", model_names);
  settings.model = model_index == 0   ? LossModelKind::BERNOULLI
                   : model_index == 1 ? LossModelKind::GILBERT_ELLIOTT
                                      : LossModelKind::TRACE;

  // Keys of the other models are rejected.
  for (auto it = node.begin(); it != node.end(); ++it)
  {
    const std::string key = it->first.Scalar();
    std::string owner;
    if (key == "loss")
      owner = "bernoulli";
    else if (key == "p" || key == "r" || key == "loss_bad" || key == "loss_good")
      owner = "gilbert_elliott";
    else if (key.rfind("trace", 0) == 0)
      owner = "trace";
    if (!owner.empty() && owner != model_names[model_index])
    {
      in.fail(it->first, key,
              "key '" + key + "' applies only to model " + owner + " (model is " + model_names[model_index] + ")");
    }
    if (settings.model == LossModelKind::TRACE && (key == "delay" || key == "jitter" || key == "distribution"))
      in.fail(it->first, key, "key '" + key + "' does not apply to model trace (a trace replays its recorded delays)");
  }

  if (settings.model == LossModelKind::BERNOULLI)
  {
    settings.loss = in.probability(in.require(node, "", "loss", "model bernoulli needs loss"), "loss");
  }
  else if (settings.model == LossModelKind::TRACE)
  {
    const YAML::Node file = in.require(node, "", "trace",
                                       "model trace needs trace: a trace CSV (stamp,receipt[,seq]), a LossyChannel's "
                                       "events CSV, or a ROS bag with trace_topic");
    if (!file.IsScalar() || file.Scalar().empty())
      in.fail(file, "trace", "expected a file name, found " + describe(file));
    settings.trace = file.Scalar();
    if (!base_dir.empty() && settings.trace.front() != '/')
      settings.trace = base_dir + "/" + settings.trace;
    if (const YAML::Node topic = node["trace_topic"])
    {
      if (!topic.IsScalar() || topic.Scalar().empty())
        in.fail(topic, "trace_topic", "expected a topic name, found " + describe(topic));
      settings.trace_topic = topic.Scalar();
    }
    if (const YAML::Node rate = node["trace_rate"])
    {
      settings.trace_rate = in.nonNegative(rate, "trace_rate", "number of Hz (0: learnt from the stamps)");
    }
    if (reuse && reuse->replay && reuse->trace == settings.trace && reuse->trace_topic == settings.trace_topic &&
        reuse->trace_rate == settings.trace_rate)
      settings.replay = reuse->replay;
    else
    {
      try
      {
        settings.replay = loadChannelTrace(settings.trace, settings.trace_topic, settings.trace_rate);
      }
      catch (const InputError& e)
      {
        in.fail(file, "trace", e.what());
      }
    }
  }
  else
  {
    settings.p = in.probability(in.require(node, "", "p", "model gilbert_elliott needs p and r"), "p");
    settings.r = in.probability(in.require(node, "", "r", "model gilbert_elliott needs p and r"), "r");
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
    static const DelayDistribution values[] = {DelayDistribution::UNIFORM, DelayDistribution::NORMAL,
                                               DelayDistribution::PARETO};
    settings.distribution = values[in.choice(node["distribution"], "distribution", "distribution", names)];
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
  return guarded(source, [&] { return parseChannelSettingsImpl(node, source); });
}

ChannelSettings loadChannelSettings(const std::string& path)
{
  const YAML::Node node = loadYamlFile(path);
  const std::string::size_type slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
  return guarded(path, [&] { return parseChannelSettingsImpl(node, path, nullptr, dir); });
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
  else if (settings.model == LossModelKind::TRACE)
  {
    node["model"] = "trace";
    node["trace"] = settings.trace;
    if (!settings.trace_topic.empty())
      node["trace_topic"] = settings.trace_topic;
    if (settings.trace_rate != 0.0)
      node["trace_rate"] = shortest(settings.trace_rate);
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
  if (settings.model != LossModelKind::TRACE)  // a trace replays its own delays
  {
    node["delay"] = shortest(settings.delay);
    node["jitter"] = shortest(settings.jitter);
    node["distribution"] = distributions[static_cast<int>(settings.distribution)];
  }
  node["reorder"] = settings.reorder;
  node["duplicate"] = shortest(settings.duplicate);
  node["queue_limit"] = static_cast<std::uint64_t>(settings.queue_limit);
  return node;
}

ChannelSettings mergeChannelSettings(const ChannelSettings& base, const YAML::Node& changes, const std::string& source)
{
  return guarded(
      source,
      [&]
      {
        if (!changes.IsMap())
          throw ConfigError(source + ": expected a map of settings to change, e.g. {loss: 0.5}");
        const YAML::Node base_yaml = toYaml(base);
        YAML::Node merged = toYaml(base);
        if (changes["model"])
        {
          for (const char* key : {"loss", "p", "r", "loss_bad", "loss_good", "trace", "trace_topic", "trace_rate"})
            merged.remove(key);
          if (base.model == LossModelKind::TRACE)  // from a trace: the delay keys start again from their defaults
            for (const char* key : {"delay", "jitter", "distribution"})
              merged.remove(key);
          if (changes["model"].IsScalar() && changes["model"].Scalar() == "trace")
          {
            for (const char* key : {"delay", "jitter", "distribution"})
              merged.remove(key);
            // the same model: its trace stays unless the change names another
            if (base.model == LossModelKind::TRACE)
              for (const char* key : {"trace", "trace_topic", "trace_rate"})
                if (base_yaml[key])
                  merged[key] = base_yaml[key];
          }
        }
        for (auto it = changes.begin(); it != changes.end(); ++it)
          merged[it->first.Scalar()] = it->second;
        return parseChannelSettingsImpl(merged, source, &base);
      });
}

}  // namespace networked_estimation
