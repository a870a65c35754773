// Which link each sensor of a model has, from the tools' `--channel` options (the same rule in
// analyze, simulate and montecarlo):
//   --channel FILE         every sensor that has no link of its own
//   --channel NAME=FILE    sensor NAME only (repeatable, one per sensor)
// A sensor with neither is lossless. docs/formats.md, "Channel settings", describes the files.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

struct SensorLinks
{
  /// One entry per sensor of the model, in the model's order: the link's settings, or none
  /// (lossless).
  std::vector<std::optional<ChannelSettings>> link;
  /// Per sensor, where its link came from: the file and the option, or "lossless (no --channel)".
  std::vector<std::string> origin;
  /// The plain --channel, when given (also the default of sensors without their own).
  std::optional<ChannelSettings> common;
  bool any() const;
  /// True when every sensor has the same settings as the common link (or no sensor has any).
  bool uniform() const;
  /// "gps: radio.yaml (--channel gps=radio.yaml)\ncamera: lossless (no --channel)\n", one line per sensor.
  std::string describe() const;
};

/// Resolves the `--channel` arguments (in the order given) for the model's sensors. Throws
/// ConfigError naming the problem: a NAME that is not a sensor of the model (listing the sensors),
/// a sensor given twice, more than one plain FILE, or a channel file that cannot be read or is
/// invalid (the file's own message).
SensorLinks resolveSensorLinks(const Model& model, const std::vector<std::string>& channel_args);
/// The same with FILE read by `load` (e.g. a link given as text rather than a file).
SensorLinks resolveSensorLinks(const Model& model, const std::vector<std::string>& channel_args,
                               const std::function<ChannelSettings(const std::string&)>& load);

}  // namespace networked_estimation
