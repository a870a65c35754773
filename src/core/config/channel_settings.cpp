// Reading and validating the channel settings (docs/formats.md, "Channel settings"), and their
// runtime changes.
#include "networked_estimation/config/channel_settings.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "config/field.hpp"
#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/link/channel_trace.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

const std::vector<std::string>& modelNames()
{
  static const std::vector<std::string> names = {"bernoulli", "gilbert_elliott", "trace"};
  return names;
}

/// The settings being read, with the map they come from (the model's row checks its other keys).
struct ChannelParse
{
  ChannelSettings settings;
  Field map;
};

/// The model a key belongs to ("" for a key of every model).
std::string ownerOf(const std::string& key)
{
  if (key == "loss")
    return "bernoulli";
  if (key == "p" || key == "r" || key == "loss_bad" || key == "loss_good")
    return "gilbert_elliott";
  if (key.rfind("trace", 0) == 0)
    return "trace";
  return "";
}

/// `model`, then the keys of the other models are refused.
void readModel(const Field& f, ChannelParse& p)
{
  const std::size_t index = f.oneOf("loss model", modelNames());
  p.settings.model = index == 0   ? LossModelKind::BERNOULLI
                     : index == 1 ? LossModelKind::GILBERT_ELLIOTT
                                  : LossModelKind::TRACE;
  const std::string& model = modelNames()[index];
  for (auto it = p.map.node().begin(); it != p.map.node().end(); ++it)
  {
    const std::string key = it->first.Scalar();
    const std::string owner = ownerOf(key);
    if (!owner.empty() && owner != model)
    {
      Field(it->first, p.map.source())
          .failAt(childKey(p.map.key(), key),
                  "key '" + key + "' applies only to model " + owner + " (model is " + model + ")");
    }
    if (p.settings.model == LossModelKind::TRACE && (key == "delay" || key == "jitter" || key == "distribution"))
    {
      Field(it->first, p.map.source())
          .failAt(childKey(p.map.key(), key),
                  "key '" + key + "' does not apply to model trace (a trace replays its recorded delays)");
    }
  }
}

/// A key that `model` needs (`why` names it) and the others refuse.
std::function<void(const Field&, ChannelParse&)> neededBy(LossModelKind model, const std::string& key,
                                                          const std::string& why)
{
  return [model, key, why](const Field& map, ChannelParse& p)
  {
    if (p.settings.model == model)
    {
      map.required(key, why);
    }
  };
}

/// A non-empty scalar: a file or topic name.
std::string name(const Field& f, const std::string& what)
{
  if (!f.isScalar() || f.text().empty())
  {
    f.fail("expected " + what + ", found " + f.found());
  }
  return f.text();
}

const std::vector<KeyRule<ChannelParse>>& channelTable()
{
  using P = ChannelParse;
  static const std::string ge_needs = "model gilbert_elliott needs p and r";
  static const std::vector<KeyRule<P>> table = {
      requiredKey<P>("model", readModel),
      optionalKey<P>(
          "loss", [](const Field& f, P& p) { p.settings.loss = f.probability(); },
          neededBy(LossModelKind::BERNOULLI, "loss", "model bernoulli needs loss")),
      optionalKey<P>(
          "p", [](const Field& f, P& p) { p.settings.p = f.probability(); },
          neededBy(LossModelKind::GILBERT_ELLIOTT, "p", ge_needs)),
      optionalKey<P>(
          "r", [](const Field& f, P& p) { p.settings.r = f.probability(); },
          neededBy(LossModelKind::GILBERT_ELLIOTT, "r", ge_needs)),
      optionalKey<P>("loss_bad", [](const Field& f, P& p) { p.settings.loss_bad = f.probability(); }),
      optionalKey<P>("loss_good", [](const Field& f, P& p) { p.settings.loss_good = f.probability(); }),
      optionalKey<P>(
          "trace", [](const Field& f, P& p) { p.settings.trace = name(f, "a file name"); },
          neededBy(LossModelKind::TRACE, "trace",
                   "model trace needs trace: a trace CSV (stamp,receipt[,seq]), a LossyChannel's events CSV, or a "
                   "ROS bag with trace_topic")),
      optionalKey<P>("trace_topic", [](const Field& f, P& p) { p.settings.trace_topic = name(f, "a topic name"); }),
      optionalKey<P>("trace_rate", [](const Field& f, P& p)
                     { p.settings.trace_rate = f.nonNegative("number of Hz (0: learnt from the stamps)"); }),
      optionalKey<P>("seed", [](const Field& f, P& p) { p.settings.seed = f.integer(0); }),
      optionalKey<P>("delay", [](const Field& f, P& p) { p.settings.delay = f.nonNegative("number of seconds"); }),
      optionalKey<P>("jitter", [](const Field& f, P& p) { p.settings.jitter = f.nonNegative("number of seconds"); }),
      optionalKey<P>("distribution",
                     [](const Field& f, P& p)
                     {
                       static const std::vector<std::string> names = {"uniform", "normal", "pareto"};
                       static const DelayDistribution values[] = {DelayDistribution::UNIFORM, DelayDistribution::NORMAL,
                                                                  DelayDistribution::PARETO};
                       p.settings.distribution = values[f.oneOf("distribution", names)];
                     }),
      optionalKey<P>("reorder", [](const Field& f, P& p) { p.settings.reorder = f.boolean(); }),
      optionalKey<P>("duplicate", [](const Field& f, P& p) { p.settings.duplicate = f.probability(); }),
      optionalKey<P>("queue_limit",
                     [](const Field& f, P& p)
                     {
                       const std::uint64_t value = f.integer(1);
                       if (value > std::numeric_limits<std::size_t>::max())
                       {
                         f.fail("integer out of range, found " + f.text());
                       }
                       p.settings.queue_limit = static_cast<std::size_t>(value);
                     }),
  };
  return table;
}

/// `reuse`: settings whose loaded trace is taken again when the trace keys are the same (runtime
/// changes do not read the file again); `base_dir`: where a relative trace file is.
ChannelSettings parseChannelSettingsImpl(const YAML::Node& node, const std::string& source,
                                         const ChannelSettings* reuse = nullptr, const std::string& base_dir = "")
{
  const Field root(node, source);
  root.requireTopMap();
  ChannelParse p{ChannelSettings(), root};
  readKeys(root, channelTable(), p);
  ChannelSettings& settings = p.settings;
  if (settings.model != LossModelKind::TRACE)
  {
    return settings;
  }
  if (!base_dir.empty() && settings.trace.front() != '/')
    settings.trace = base_dir + "/" + settings.trace;
  if (reuse && reuse->replay && reuse->trace == settings.trace && reuse->trace_topic == settings.trace_topic &&
      reuse->trace_rate == settings.trace_rate)
  {
    settings.replay = reuse->replay;
    return settings;
  }
  try
  {
    settings.replay = loadChannelTrace(settings.trace, settings.trace_topic, settings.trace_rate);
  }
  catch (const InputError& e)
  {
    root["trace"].fail(e.what());
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
