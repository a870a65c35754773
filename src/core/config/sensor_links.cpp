// Which link each sensor has, from `--channel FILE` and `--channel NAME=FILE` (sensor_links.hpp).
#include "networked_estimation/config/sensor_links.hpp"

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace
{

bool sameSettings(const ChannelSettings& a, const ChannelSettings& b)
{
  return a.model == b.model && a.loss == b.loss && a.p == b.p && a.r == b.r && a.loss_bad == b.loss_bad &&
         a.loss_good == b.loss_good && a.seed == b.seed && a.delay == b.delay && a.jitter == b.jitter &&
         a.distribution == b.distribution && a.reorder == b.reorder && a.duplicate == b.duplicate &&
         a.queue_limit == b.queue_limit && a.trace == b.trace && a.trace_topic == b.trace_topic &&
         a.trace_rate == b.trace_rate;
}

std::string sensorList(const Model& model)
{
  std::string out;
  for (const Sensor& s : model.sensors)
    out += (out.empty() ? "" : ", ") + s.name;
  return out;
}

}  // namespace

bool SensorLinks::any() const
{
  for (const auto& l : link)
    if (l)
      return true;
  return false;
}

bool SensorLinks::uniform() const
{
  for (const auto& l : link)
  {
    if (l.has_value() != common.has_value())
      return false;
    if (l && !sameSettings(*l, *common))
      return false;
  }
  return true;
}

std::string SensorLinks::describe() const
{
  std::string out;
  for (std::size_t i = 0; i < origin.size(); ++i)
    out += origin[i] + "\n";
  return out;
}

SensorLinks resolveSensorLinks(const Model& model, const std::vector<std::string>& channel_args)
{
  return resolveSensorLinks(model, channel_args, &loadChannelSettings);
}

SensorLinks resolveSensorLinks(const Model& model, const std::vector<std::string>& channel_args,
                               const std::function<ChannelSettings(const std::string&)>& load)
{
  const std::size_t S = model.sensors.size();
  SensorLinks links;
  links.link.assign(S, std::nullopt);
  links.origin.assign(S, "");
  std::vector<bool> own(S, false);
  std::string common_file;
  for (const std::string& arg : channel_args)
  {
    const std::string::size_type eq = arg.find('=');
    std::string name, file = arg;
    if (eq != std::string::npos)
    {
      name = arg.substr(0, eq);
      file = arg.substr(eq + 1);
    }
    if (name.empty())
    {
      if (eq != std::string::npos)
        throw ConfigError("--channel '" + arg + "': expected FILE or NAME=FILE with NAME a sensor of model '" +
                          model.name + "' (" + sensorList(model) + ")");
      if (file.empty())
        throw ConfigError("--channel '': expected FILE or NAME=FILE, found nothing");
      if (links.common)
        throw ConfigError("--channel: more than one channel for every sensor ('" + common_file + "' and '" + file +
                          "'); give the others as NAME=FILE");
      links.common = load(file);
      common_file = file;
      continue;
    }
    std::size_t index = S;
    for (std::size_t i = 0; i < S; ++i)
      if (model.sensors[i].name == name)
        index = i;
    if (index == S)
      throw ConfigError("--channel " + arg + ": '" + name + "' is not a sensor of model '" + model.name +
                        "' (its sensors: " + sensorList(model) + ")");
    if (own[index])
      throw ConfigError("--channel " + arg + ": sensor '" + name + "' has a channel already");
    if (file.empty())
      throw ConfigError("--channel " + arg + ": no file after '" + name + "='");
    links.link[index] = load(file);
    links.origin[index] = name + ": " + file + " (--channel " + arg + ")";
    own[index] = true;
  }
  for (std::size_t i = 0; i < S; ++i)
  {
    if (own[i])
      continue;
    if (links.common)
    {
      links.link[i] = links.common;
      links.origin[i] = model.sensors[i].name + ": " + common_file + " (--channel " + common_file + ")";
    }
    else
    {
      links.origin[i] = model.sensors[i].name + ": lossless (no --channel for it)";
    }
  }
  return links;
}

}  // namespace networked_estimation
