// The PlantSimulator's per-sensor outputs (sensor_outputs.hpp).
#include "networked_estimation/simulation/sensor_outputs.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/param_reader.hpp"

namespace networked_estimation
{

const std::vector<InputType>& simulatorOutputTypes()
{
  static const std::vector<InputType> types = {
      InputType::MEASUREMENT, InputType::ODOMETRY, InputType::POSE_WITH_COVARIANCE,
      InputType::POSE,        InputType::POINT,    InputType::TWIST_WITH_COVARIANCE,
      InputType::TWIST,       InputType::IMU,      InputType::NAVSATFIX,
      InputType::RANGE};
  return types;
}

namespace
{

std::vector<double> numbers(const YAML::Node& node, const std::string& key)
{
  std::vector<double> out;
  if (!node.IsSequence() || node.size() == 0)
    throw ConfigError(key + ": expected a list of numbers");
  for (std::size_t i = 0; i < node.size(); ++i)
  {
    double v = 0.0;
    try
    {
      v = node[i].as<double>();
    }
    catch (const YAML::Exception&)
    {
      throw ConfigError(key + "[" + std::to_string(i) + "]: expected a number, found '" +
                        (node[i].IsScalar() ? node[i].as<std::string>() : std::string("a list or map")) + "'");
    }
    out.push_back(v);
  }
  return out;
}

void parseOne(const YAML::Node& block, const std::string& key, const Sensor& sensor, double model_rate,
              SensorOutput& out)
{
  if (!block.IsMap())
    throw ConfigError(key +
                      ": expected a map (keys: topic, type, fields, rate, frame_id, child_frame_id, "
                      "covariance_scales)");
  ParamReader p(block, key);
  parseInputBlock(p, key, simulatorOutputTypes(), sensor.size, "row of sensor '" + sensor.name + "'", out.format);
  out.format.rate = p.number("rate", model_rate, 0.0, 1e9);
  const double ratio = model_rate / out.format.rate;
  out.every = std::lround(ratio);
  if (!(out.format.rate > 0.0) || out.every < 1 || std::fabs(ratio - static_cast<double>(out.every)) > 1e-9 * ratio)
    throw ConfigError(key + ".rate: expected the model's rate " + std::to_string(model_rate) +
                      " Hz divided by a whole number, found " + std::to_string(out.format.rate));
  out.frame_id = p.text("frame_id", "");
  out.child_frame_id = p.text("child_frame_id", "");
  if (p.has("covariance_scales"))
  {
    out.covariance_scales = numbers(p.take("covariance_scales"), key + ".covariance_scales");
    for (std::size_t i = 0; i < out.covariance_scales.size(); ++i)
      if (!(std::isfinite(out.covariance_scales[i]) && out.covariance_scales[i] > 0.0))
        throw ConfigError(key + ".covariance_scales[" + std::to_string(i) + "]: expected a finite number > 0, found " +
                          std::to_string(out.covariance_scales[i]));
  }
  p.rejectUnknown();
}

}  // namespace

SimulatorOutputs parseSimulatorOutputs(ParamReader& p, const Model& model, double period, const std::string& source)
{
  SimulatorOutputs o;
  const double model_rate = 1.0 / period;
  for (const Sensor& s : model.sensors)
  {
    SensorOutput out;
    out.format.topic = model.sensors.size() == 1 ? "measurement" : "measurement/" + s.name;
    out.format.rate = model_rate;
    o.sensors.push_back(out);
  }
  if (p.has("sensors"))
  {
    const YAML::Node block = p.take("sensors");
    if (!block.IsMap())
      throw ConfigError(source + ": sensors: expected a map from sensor names to output settings");
    for (const auto& entry : block)
    {
      const std::string name = entry.first.as<std::string>();
      const std::string key = source + ": sensors." + name;
      const std::size_t index = sensorIndex(model, name, key);
      parseOne(entry.second, key, model.sensors[index], model_rate, o.sensors[index]);
    }
  }
  if (p.has("datum"))
    o.datum = parseDatum(p.take("datum"), source + ": datum");
  for (std::size_t i = 0; i < o.sensors.size(); ++i)
    if (o.sensors[i].format.type == InputType::NAVSATFIX && o.datum.empty())
      throw ConfigError(source + ": sensors." + model.sensors[i].name +
                        ": sensor_msgs/NavSatFix needs a datum: [lat, lon, alt] (the ENU origin of the fixes)");
  return o;
}

}  // namespace networked_estimation
