// A built-in motion's sensors from the Estimator's fields (motion_sensors.hpp).
#include "networked_estimation/online/motion_sensors.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/param_reader.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"

namespace networked_estimation
{
namespace
{

/// The state name a field measures under a 3-D motion, or "" when it measures none.
std::string stateName(const InputField& field, bool differential)
{
  static const char* const position[3] = {"x", "y", "z"};
  static const char* const angle[3] = {"roll", "pitch", "yaw"};
  static const char* const velocity[3] = {"vx", "vy", "vz"};
  static const char* const rate[3] = {"vroll", "vpitch", "vyaw"};
  static const char* const acceleration[3] = {"ax", "ay", "az"};
  if (field.axis < 0 || field.axis > 2)
    return "";
  const auto a = static_cast<std::size_t>(field.axis);
  switch (field.quantity)
  {
    case Quantity::POSITION:
      return differential ? velocity[a] : position[a];
    case Quantity::ENU:  // NavSatFix east, north, up: the world position
      return position[a];
    case Quantity::ORIENTATION_RPY:
      return differential ? rate[a] : angle[a];
    case Quantity::LINEAR_VELOCITY:
      return velocity[a];
    case Quantity::ANGULAR_VELOCITY:
      return rate[a];
    case Quantity::LINEAR_ACCELERATION:
      return acceleration[a];
    case Quantity::ORIENTATION:  // a raw quaternion component is no state
    case Quantity::SCALAR:
    case Quantity::ELEMENT:
      break;
  }
  return "";
}

/// One derived sensor: {name, C, R}.
YAML::Node deriveSensor(Motion motion, const std::string& name, const YAML::Node& block, const std::string& key)
{
  if (!block.IsMap())
    throw ConfigError(key + ": expected a map (keys: topic, type, fields, std, covariance, ...)");
  // A reader of its own: the nodelet's parse reads these keys again and rejects unknown ones.
  ParamReader p(YAML::Clone(block), key);
  if (!p.has("type"))
    throw ConfigError(key + ".type: needed: the model lists no sensor '" + name +
                      "', so its rows of C follow from its type and fields");
  std::vector<InputType> allowed;
  for (InputType t : sensorInputTypes())
    if (!inputFields(t).empty())
      allowed.push_back(t);
  // The type and fields by the sensors block's own grammar (parseInputBlock), one row per field.
  const YAML::Node listed = block["fields"];
  SensorInput in;
  in.topic = "-";  // read (and defaulted) by the nodelet's parse
  parseInputBlock(p, key, allowed, listed.IsDefined() && listed.IsSequence() ? static_cast<int>(listed.size()) : 0,
                  "row (each names the state of motion " + toString(motion) + " it measures)", in);
  const bool differential = p.flag("differential", false);
  const std::vector<std::string>& states = motionStateNames(motion);
  const int n = motionStates(motion);
  const int rows = static_cast<int>(in.fields.size());
  YAML::Node C(YAML::NodeType::Sequence);
  std::vector<int> measured;
  for (int i = 0; i < rows; ++i)
  {
    const std::string at = key + ".fields[" + std::to_string(i) + "]";
    const InputField& f = in.fields[static_cast<std::size_t>(i)];
    const int state = motionState(motion, f, differential);
    if (state < 0)
    {
      const std::string s = stateName(f, differential);
      throw ConfigError(at + ": " + f.name +
                        (s.empty() ? " measures no state of motion " + toString(motion)
                                   : " measures " + s + ", which motion " + toString(motion) + " has not") +
                        " (its states: " + detail::joinList(states) + "); leave the field out" +
                        (s.empty() ? "" : " or use motion omni_3d"));
    }
    if (std::find(measured.begin(), measured.end(), state) != measured.end())
      throw ConfigError(at + ": " + f.name + " measures " + states[static_cast<std::size_t>(state)] +
                        ", which an earlier field of this sensor measures already");
    measured.push_back(state);
    YAML::Node row(YAML::NodeType::Sequence);
    for (int j = 0; j < n; ++j)
      row.push_back(j == state ? 1 : 0);
    row.SetStyle(YAML::EmitterStyle::Flow);
    C.push_back(row);
  }
  std::vector<double> variance(static_cast<std::size_t>(rows), kMessageCovarianceFloor);
  const YAML::Node sd = p.take("std");
  const bool message = p.text("covariance", "model") == "message";
  if (!sd.IsNull())
  {
    if (!sd.IsSequence() || static_cast<int>(sd.size()) != rows)
      throw ConfigError(key + ".std: expected a list of " + std::to_string(rows) +
                        " standard deviations, one per field (REP-103 units), found " +
                        (sd.IsSequence() ? std::to_string(sd.size()) + " entries" : detail::describe(sd)));
    for (int i = 0; i < rows; ++i)
    {
      double v = 0.0;
      if (!sd[i].IsScalar() || !YAML::convert<double>::decode(sd[i], v) || !std::isfinite(v) || !(v > 0.0))
        throw ConfigError(key + ".std[" + std::to_string(i) + "]: expected a finite standard deviation > 0, found " +
                          detail::describe(sd[i]));
      variance[static_cast<std::size_t>(i)] = v * v;
    }
  }
  else if (!message)
    throw ConfigError(key +
                      ": give std (one standard deviation per field) or covariance: message (the messages' "
                      "own covariances): the model lists no sensor '" +
                      name + "' whose R could be used");
  YAML::Node R(YAML::NodeType::Sequence);
  for (int i = 0; i < rows; ++i)
  {
    YAML::Node row(YAML::NodeType::Sequence);
    for (int j = 0; j < rows; ++j)
      row.push_back(i == j ? variance[static_cast<std::size_t>(i)] : 0.0);
    row.SetStyle(YAML::EmitterStyle::Flow);
    R.push_back(row);
  }
  YAML::Node s(YAML::NodeType::Map);
  s["name"] = name;
  s["C"] = C;
  s["R"] = R;
  return s;
}

}  // namespace

int motionState(Motion motion, const InputField& field, bool differential)
{
  const std::vector<std::string>& states = motionStateNames(motion);
  const std::string name = stateName(field, differential);
  const auto it = std::find(states.begin(), states.end(), name);
  return name.empty() || it == states.end() ? -1 : static_cast<int>(it - states.begin());
}

YAML::Node withMotionSensors(const YAML::Node& model, const YAML::Node& sensors, const std::string& source,
                             std::vector<std::string>& derived)
{
  if (!model.IsMap() || !model["motion"] || !model["motion"].IsScalar())
    return model;  // a linear model (or one parseModel will refuse with its own message)
  const Motion motion = motionFromString(model["motion"].Scalar(), source + ": model.motion");
  std::vector<std::string> listed;
  const YAML::Node given = model["sensors"];
  if (given && given.IsSequence())
    for (const YAML::Node& s : given)
      if (s.IsMap() && s["name"] && s["name"].IsScalar())
        listed.push_back(s["name"].Scalar());
  if (given && !given.IsSequence())
    return model;  // parseModel names the problem
  if (model["C"] || model["R"])
    return model;  // C and R given whole: the sensors block maps onto their single sensor
  YAML::Node out = YAML::Clone(model);
  YAML::Node list = given ? out["sensors"] : YAML::Node(YAML::NodeType::Sequence);
  if (sensors.IsDefined() && !sensors.IsNull())
  {
    if (!sensors.IsMap())
      throw ConfigError(source + ": sensors: expected a map from sensor names to input settings");
    for (const auto& entry : sensors)
    {
      const std::string name = entry.first.as<std::string>();
      if (std::find(listed.begin(), listed.end(), name) != listed.end())
        continue;
      list.push_back(deriveSensor(motion, name, entry.second, source + ": sensors." + name));
      derived.push_back(name);
    }
  }
  if (list.size() == 0)
    throw ConfigError(source + ": sensors: the model (motion " + toString(motion) +
                      ") lists no sensors: give each input under sensors.<name> with its type and fields (the "
                      "fields name the states it measures)");
  out["sensors"] = list;
  return out;
}

StateMap motionStateMap(Motion motion)
{
  StateMap m;
  const std::pair<int*, const char*> entries[] = {{&m.x, "x"},
                                                  {&m.y, "y"},
                                                  {&m.z, "z"},
                                                  {&m.roll, "roll"},
                                                  {&m.pitch, "pitch"},
                                                  {&m.yaw, "yaw"},
                                                  {&m.vx, "vx"},
                                                  {&m.vy, "vy"},
                                                  {&m.vz, "vz"},
                                                  {&m.roll_rate, "vroll"},
                                                  {&m.pitch_rate, "vpitch"},
                                                  {&m.yaw_rate, "vyaw"}};
  const std::vector<std::string>& states = motionStateNames(motion);
  for (const auto& e : entries)
  {
    const auto it = std::find(states.begin(), states.end(), e.second);
    *e.first = it == states.end() ? -1 : static_cast<int>(it - states.begin());
  }
  return m;
}

}  // namespace networked_estimation
