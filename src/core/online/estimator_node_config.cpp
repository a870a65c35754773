#include "networked_estimation/online/estimator_node_config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "config/yaml_reader.hpp"
#include "io/tokens.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/param_reader.hpp"
#include "networked_estimation/online/motion_sensors.hpp"

namespace networked_estimation
{
namespace
{

/// The one rule for angles is the model's (angularRows): a field that is an angle (roll, pitch or
/// yaw of a quaternion) must feed a row that measures an angular state, or its jumps between pi and
/// -pi would reach the filter unwrapped.
void checkAngleFields(const Model& model, std::size_t sensor, const SensorInput& in, const std::string& key)
{
  const Sensor& s = model.sensors[sensor];
  const std::vector<int> rows = angularRows(model);
  for (std::size_t i = 0; i < in.fields.size(); ++i)
  {
    const int row = s.offset + static_cast<int>(i);
    if (in.fields[i].quantity != Quantity::ORIENTATION_RPY || std::find(rows.begin(), rows.end(), row) != rows.end())
      continue;
    throw ConfigError(key + ".fields[" + std::to_string(i) + "]: " + in.fields[i].name +
                      " is an angle in (-pi, pi], but row " + std::to_string(i) + " of sensor '" + s.name +
                      "' does not measure an angular state of the model: make that row of C the unit vector of "
                      "the state it measures and list the state in the model's angles (docs/formats.md 1.2b)");
  }
}

/// The `sensors` block: one map per sensor of the model, keyed by the sensor's name.
void parseSensorInputs(const YAML::Node& block, const std::string& source, EstimatorNodeConfig& c)
{
  const Model& model = c.model;
  const double model_rate = 1.0 / c.period;
  if (!block.IsMap())
    throw ConfigError(source + ": sensors: expected a map from sensor names to input settings");
  for (const auto& entry : block)
  {
    const std::string name = entry.first.as<std::string>();
    const std::string key = source + ": sensors." + name;
    const std::size_t index = sensorIndex(model, name, key);
    SensorInput& in = c.inputs[index];
    if (!entry.second.IsMap())
      throw ConfigError(key + ": expected a map (keys: topic, type, fields, rate)");
    ParamReader p(entry.second, key);
    parseInputBlock(p, key, sensorInputTypes(), model.sensors[index].size, "row of sensor '" + name + "'", in);
    const bool pose_type =
        in.type == InputType::ODOMETRY || in.type == InputType::POSE_WITH_COVARIANCE || in.type == InputType::POSE;
    const std::string pose_types =
        "a pose (nav_msgs/Odometry, geometry_msgs/PoseWithCovarianceStamped, geometry_msgs/PoseStamped)";
    in.differential = p.flag("differential", false);
    if (in.differential)
    {
      if (!pose_type)
        throw ConfigError(key + ".differential: only for " + pose_types + ", found " + toString(in.type));
      for (std::size_t i = 0; i < in.fields.size(); ++i)
      {
        InputField& f = in.fields[i];
        if (f.quantity == Quantity::POSITION)
          f.quantity = Quantity::LINEAR_VELOCITY;  // the pose's change per second, in base_link
        else if (f.quantity == Quantity::ORIENTATION_RPY)
          f.quantity = Quantity::ANGULAR_VELOCITY;
        else
          throw ConfigError(key + ".fields[" + std::to_string(i) + "]: " + f.name +
                            ": differential reads positions and roll / pitch / yaw of the pose, not this field");
      }
    }
    else
      checkAngleFields(model, index, in, key);
    in.message_covariance = p.choice("covariance", "model", {"model", "message"}) == "message";
    if (in.message_covariance && in.differential)
      throw ConfigError(key +
                        ".covariance: message: not with differential (a velocity's covariance is not in the "
                        "pose's message): use covariance: model, the model's R of the velocity rows");
    if (in.message_covariance && in.fields.empty())
      throw ConfigError(key + ".covariance: message: " + toString(in.type) +
                        " carries no covariance (use covariance: model)");
    for (const InputField& f : in.fields)
      if (in.message_covariance && covarianceOf(in.type, f).block == CovarianceBlock::NONE)
        throw ConfigError(key + ".covariance: message: " + toString(in.type) + " has no covariance of '" + f.name +
                          "' (use covariance: model)");
    const double inf = std::numeric_limits<double>::infinity();
    in.rejection_threshold = p.number("rejection_threshold", inf, 0.0, inf);
    if (!(in.rejection_threshold > 0.0))
      throw ConfigError(key + ".rejection_threshold: expected a Mahalanobis distance > 0, found " +
                        std::to_string(in.rejection_threshold));
    in.remove_gravity = p.flag("remove_gravitational_acceleration", false);
    if (in.remove_gravity && in.type != InputType::IMU)
      throw ConfigError(key + ".remove_gravitational_acceleration: only for sensor_msgs/Imu, found " +
                        toString(in.type));
    if (in.remove_gravity &&
        std::none_of(in.fields.begin(), in.fields.end(),
                     [](const InputField& f) { return f.quantity == Quantity::LINEAR_ACCELERATION; }))
      throw ConfigError(key + ".remove_gravitational_acceleration: the sensor reads no linear_acceleration field");
    in.relative = p.flag("relative", false);
    if (in.relative && !pose_type)
      throw ConfigError(key + ".relative: only for " + pose_types + ", found " + toString(in.type));
    if (in.relative && in.differential)
      throw ConfigError(key + ".relative: not with differential (a velocity has no origin)");
    const bool derived = std::find(c.derived_sensors.begin(), c.derived_sensors.end(), name) != c.derived_sensors.end();
    if (p.has("std") && !derived)
      throw ConfigError(key +
                        ".std: only for a sensor the model does not list (its rows of C and R then follow from "
                        "the fields); sensor '" +
                        name + "' is the model's, with its R");
    p.take("std");  // read by withMotionSensors
    in.rate = p.number("rate", model_rate, 0.0, 1e9);
    if (!(in.rate > 0.0) || in.rate > model_rate * (1.0 + 1e-9))
      throw ConfigError(key + ".rate: expected > 0 and at most the model's rate " + std::to_string(model_rate) +
                        " Hz, found " + std::to_string(in.rate));
    p.rejectUnknown();
  }
}

}  // namespace

GnssAlignment parseGnssAlignment(ParamReader& p, const EstimatorNodeConfig& c)
{
  const std::string& source = p.source();
  GnssAlignment g;
  const char* keys[] = {
      "magnetic_declination_radians", "yaw_offset",           "zero_altitude",           "use_odometry_yaw",
      "publish_gps_odometry",         "publish_filtered_gps", "broadcast_utm_transform", "gnss_heading"};
  g.navsat_transform = p.choice("gnss_alignment", "enu", {"enu", "navsat_transform"}) == "navsat_transform";
  const bool has_fix = std::any_of(c.inputs.begin(), c.inputs.end(),
                                   [](const SensorInput& in) { return in.type == InputType::NAVSATFIX; });
  if (!g.navsat_transform)
  {
    for (const char* key : keys)
      if (p.has(key))
        throw ConfigError(source + ": " + key +
                          ": only with gnss_alignment: navsat_transform (found gnss_alignment: "
                          "enu, where world_frame is the ENU frame of the datum)");
    return g;
  }
  if (!has_fix)
    throw ConfigError(source +
                      ": gnss_alignment: navsat_transform needs a sensor_msgs/NavSatFix input (a sensors "
                      "entry with type sensor_msgs/NavSatFix); found none");
  const std::pair<const char*, int> needed[] = {{"x", c.state_map.x}, {"y", c.state_map.y}, {"yaw", c.state_map.yaw}};
  for (const auto& n : needed)
    if (n.second < 0)
      throw ConfigError(source +
                        ": gnss_alignment: navsat_transform needs base_link's world pose from the estimate: "
                        "state_mapping." +
                        n.first + " is not mapped");
  // The motion's roll and pitch states (omni_3d; none under omni_2d or a linear model).
  const StateMap motion_states = motionStateMap(c.model.motion);
  g.roll = motion_states.roll;
  g.pitch = motion_states.pitch;
  const double pi = 3.14159265358979323846;
  g.magnetic_declination = p.number("magnetic_declination_radians", 0.0, -pi, pi);
  g.yaw_offset = p.number("yaw_offset", 0.0, -2.0 * pi, 2.0 * pi);
  g.zero_altitude = p.flag("zero_altitude", false);
  g.use_odometry_yaw = p.flag("use_odometry_yaw", false);
  g.publish_gps_odometry = p.flag("publish_gps_odometry", false);
  g.publish_filtered_gps = p.flag("publish_filtered_gps", false);
  g.broadcast_utm_transform = p.flag("broadcast_utm_transform", false);
  if (p.has("gnss_heading"))
  {
    const std::string name = p.text("gnss_heading", "");
    const std::string key = source + ": gnss_heading";
    if (g.use_odometry_yaw)
      throw ConfigError(key + ": not with use_odometry_yaw: true (the heading is then the fused yaw)");
    const std::size_t i = sensorIndex(c.model, name, key);
    if (c.inputs[i].type != InputType::IMU)
      throw ConfigError(key + ": sensor '" + name + "' is " + toString(c.inputs[i].type) +
                        ", expected sensor_msgs/Imu (its orientation yaw, earth-referenced)");
    g.heading_sensor = static_cast<int>(i);
  }
  else if (!g.use_odometry_yaw)
  {
    for (std::size_t i = 0; i < c.inputs.size() && g.heading_sensor < 0; ++i)
      if (c.inputs[i].type == InputType::IMU)
        g.heading_sensor = static_cast<int>(i);
    if (g.heading_sensor < 0)
      throw ConfigError(source +
                        ": gnss_heading: gnss_alignment: navsat_transform needs base_link's earth-referenced "
                        "heading at the first fix: from a sensor_msgs/Imu input (none is configured) or, with "
                        "use_odometry_yaw: true, from the fused yaw");
  }
  return g;
}

namespace
{

/// `model`: a model file, or the model itself (a map with the keys of a model file).
void readModel(ParamReader& p, const YAML::Node& params, const std::string& source, EstimatorNodeConfig& c)
{
  // model: a model file, or the model itself (a map with the keys of a model file). With a built-in
  // motion, the sensors the model does not list come from the `sensors` block's fields.
  const YAML::Node sensors_block = params["sensors"];
  if (p.has("model") && p.take("model").IsMap())
  {
    c.model_file = "(inline)";
    c.model =
        parseModel(withMotionSensors(params["model"], sensors_block, source, c.derived_sensors), source + ": model");
  }
  else
  {
    c.model_file = p.required("model");
    YAML::Node root;
    try
    {
      root = detail::loadYamlFile(c.model_file);
    }
    catch (const ConfigError& e)
    {
      throw ConfigError(source + ": model: " + e.what());
    }
    const YAML::Node amended = withMotionSensors(root, sensors_block, source, c.derived_sensors);
    try
    {
      c.model = parseModel(amended, c.model_file);
    }
    catch (const ConfigError& e)
    {
      throw ConfigError(source + ": model: " + e.what());
    }
    if (!root["name"])
      c.model.name = std::filesystem::path(c.model_file).stem().string();
  }
}

/// The filter: algorithm, mu, control_link, max_components, as the estimator settings.
void readFilter(ParamReader& p, const std::string& source, EstimatorNodeConfig& c)
{
  const Model& model = c.model;
  YAML::Node est(YAML::NodeType::Map);
  for (const char* key : {"algorithm", "mu", "control_link", "max_components"})
    if (p.has(key))
      est[key] = p.take(key);
  if (!est["algorithm"])
    est["algorithm"] = "kfio";
  c.settings = parseEstimatorSettings(est, source);
  if (c.settings.algorithm == Algorithm::ACK_KF)
    throw ConfigError(source +
                      ": algorithm: ack_kf needs nu_k (whether each command arrived), which the graph "
                      "does not carry; use it offline with replay");
  try
  {
    makeEstimator(model, c.settings);  // the combination of model and settings (e.g. aoe needs control_link)
  }
  catch (const ConfigError& e)
  {
    throw ConfigError(source + ": " + e.what());
  }
}

/// The steps and the timeline: period, late_policy, the history and step windows, latency_budget
/// and the stamps accepted ahead and behind.
void readTiming(ParamReader& p, const std::string& source, EstimatorNodeConfig& c)
{
  const Model& model = c.model;
  c.period = p.number("period", model.period, 0.0, 3600.0);
  if (!(c.period > 0.0))
    throw ConfigError(source + ": period: the model '" + c.model_file + "' has no period and none was given");
  if (!(c.period <= 3600.0))  // the model's, which ~period would not have accepted
    throw ConfigError(source + ": period: the model '" + c.model_file + "' has period " + tokens::format(c.period, 6) +
                      " s: expected a number of seconds in (0, 3600], the range of "
                      "~period (give ~period to override it)");
  RuntimeSettings& rt = c.runtime;
  rt.late_policy = p.text("late_policy", "drop");
  c.online.late_policy = latePolicyFromString(rt.late_policy, source);
  c.online.step_duration = c.period;  // a built-in motion predicts over the steps' spacing
  c.online.history_length = static_cast<std::size_t>(p.integer("history_length", 100, 1, 100000));
  c.online.max_future_steps = p.integer("max_future_steps", 1000, 1, 1000000);
  c.online.max_past_steps =
      p.integer("max_past_steps", std::max<long>(1000, static_cast<long>(c.online.history_length)), 1, 1000000);
  validateOnlineOptions(c.online, source);

  // latency_budget: auto (adaptive within [min, max]) or a fixed number of seconds.
  const YAML::Node budget = p.take("latency_budget");
  if (budget.IsDefined() && !budget.IsNull() && !(budget.IsScalar() && budget.Scalar() == "auto"))
  {
    if (!budget.IsScalar() || !YAML::convert<double>::decode(budget, rt.latency_budget))
      throw ConfigError(source + ": latency_budget: expected auto or a number of seconds, found '" +
                        (budget.IsScalar() ? budget.Scalar() : std::string("a ") + (budget.IsMap() ? "map" : "list")) +
                        "'");
    rt.adaptive_latency = false;
  }
  rt.latency_budget_min = p.number("latency_budget_min", 0.5 * c.period, 0.0, 3600.0);
  rt.latency_budget_max =
      p.number("latency_budget_max", std::min(1.0, 0.5 * static_cast<double>(c.online.max_future_steps) * c.period),
               0.0, 3600.0);
  c.timeline.period = c.period;
  c.timeline.max_ahead = p.number("max_stamp_ahead", 10.0, 0.0, 1e9);
  if (!(c.timeline.max_ahead > 0.0))
    throw ConfigError(source + ": max_stamp_ahead: expected a number of seconds > 0, found 0");
  const double longest = rt.adaptive_latency ? rt.latency_budget_max : rt.latency_budget;
  c.timeline.max_behind = p.number(
      "max_stamp_behind",
      (std::isfinite(longest) ? std::max(0.0, longest) : 0.0) + static_cast<double>(c.online.history_length) * c.period,
      0.0, 1e9);
  if (!(c.timeline.max_behind > 0.0))
    throw ConfigError(source + ": max_stamp_behind: expected a number of seconds > 0, found 0");
}

/// Every sensor's input (input_type, the `sensors` block) and the command's.
void readInputs(ParamReader& p, const std::string& source, EstimatorNodeConfig& c)
{
  const Model& model = c.model;
  c.input_type = p.choice("input_type", "measurement", {"measurement", "range", "point"});
  for (const Sensor& s : model.sensors)
  {
    if (c.input_type == "range" && s.size != 1)
      throw ConfigError(source + ": input_type: range needs sensors of 1 row; sensor '" + s.name + "' has " +
                        std::to_string(s.size));
    if (c.input_type == "point" && s.size > 3)
      throw ConfigError(source + ": input_type: point gives at most 3 values; sensor '" + s.name + "' has " +
                        std::to_string(s.size));
  }
  // Every sensor's input: the input_type topic by default, then the `sensors` block.
  const double model_rate = 1.0 / c.period;
  for (const Sensor& s : model.sensors)
  {
    SensorInput in;
    in.topic = model.sensors.size() == 1 ? "measurement" : "measurement/" + s.name;
    in.rate = model_rate;
    if (c.input_type == "range")
    {
      in.type = InputType::RANGE;
      in.fields = inputFields(InputType::RANGE);
    }
    else if (c.input_type == "point")
    {
      in.type = InputType::POINT;
      in.fields.assign(inputFields(InputType::POINT).begin(), inputFields(InputType::POINT).begin() + s.size);
    }
    c.inputs.push_back(in);
  }
  if (p.has("sensors"))
    parseSensorInputs(p.take("sensors"), source, c);
  c.command.topic = "command";
  c.command.type = InputType::CONTROL_INPUT;
  if (p.has("command"))
  {
    const YAML::Node block = p.take("command");
    if (!model.hasControl())
      throw ConfigError(source + ": command: model '" + model.name + "' has no control input");
    if (!block.IsMap())
      throw ConfigError(source + ": command: expected a map (keys: topic, type, fields)");
    ParamReader q(block, source + ": command");
    parseInputBlock(q, source + ": command", commandInputTypes(), model.p(), "entry of u", c.command);
    q.rejectUnknown();
  }
  for (const SensorInput& in : c.inputs)
  {
    c.online.rate_ratio.push_back(model_rate / in.rate);
    c.online.rejection_threshold.push_back(in.rejection_threshold);
  }
  validateOnlineOptions(c.online, source);
}

/// The datum, the frames, the position indices and the state mapping.
void readFrames(ParamReader& p, const std::string& source, EstimatorNodeConfig& c)
{
  const Model& model = c.model;
  if (p.has("datum"))
    c.datum = parseDatum(p.take("datum"), source + ": datum");
  c.frame_id = p.text("frame_id", "map");
  c.child_frame_id = p.text("child_frame_id", toString(c.settings.algorithm) + "_estimate");
  const StateMap motion_map = motionStateMap(model.motion);
  std::vector<int> positions = model.n() >= 2 ? std::vector<int>{0, 1} : std::vector<int>{0};
  if (model.nonlinear())
  {
    positions = {motion_map.x, motion_map.y};
    if (motion_map.z >= 0)
      positions.push_back(motion_map.z);
  }
  c.position_indices = p.indices("position_indices", positions, model.n());
  c.publish_tf = p.flag("publish_tf", true);
  c.predict_to_current_time = p.flag("predict_to_current_time", false);
  if (p.has("frequency") && !c.predict_to_current_time)
    throw ConfigError(source +
                      ": frequency: the rate of the predict_to_current_time output, which is off (set "
                      "predict_to_current_time: true, or leave frequency out: the steps' rate is 1 / period)");
  c.frequency = p.number("frequency", 1.0 / c.period, 0.0, 1000.0);
  if (!(c.frequency > 0.0))
    throw ConfigError(source + ": frequency: expected a rate in (0, 1000] Hz, found 0");
  c.world_frame = p.text("world_frame", c.frame_id);
  c.base_link_frame = p.text("base_link_frame", "base_link");
  c.odom_frame = p.text("odom_frame", "odom");
  const std::pair<const char*, const std::string*> frames[] = {{"frame_id", &c.frame_id},
                                                               {"child_frame_id", &c.child_frame_id},
                                                               {"world_frame", &c.world_frame},
                                                               {"base_link_frame", &c.base_link_frame},
                                                               {"odom_frame", &c.odom_frame}};
  for (const auto& f : frames)
    if (f.second->empty())
      throw ConfigError(source + ": " + f.first + ": expected a frame name, found an empty string");
  if (model.nonlinear())
    c.state_map = motion_map;  // every state the motion names
  else
  {
    int* slots[3] = {&c.state_map.x, &c.state_map.y, &c.state_map.z};
    for (std::size_t i = 0; i < c.position_indices.size(); ++i)
      *slots[i] = c.position_indices[i];
  }
  if (p.has("state_mapping"))
  {
    const YAML::Node m = p.take("state_mapping");
    if (!m.IsMap())
      throw ConfigError(source +
                        ": state_mapping: expected a map from x, y, z, roll, pitch, yaw, vx, vy, vz, "
                        "roll_rate, pitch_rate, yaw_rate to state indices");
    c.state_map = StateMap();
    ParamReader q(m, source + ": state_mapping");
    int* entries[12] = {&c.state_map.x,     &c.state_map.y,         &c.state_map.z,          &c.state_map.roll,
                        &c.state_map.pitch, &c.state_map.yaw,       &c.state_map.vx,         &c.state_map.vy,
                        &c.state_map.vz,    &c.state_map.roll_rate, &c.state_map.pitch_rate, &c.state_map.yaw_rate};
    const char* names[12] = {"x",  "y",  "z",  "roll",      "pitch",      "yaw",
                             "vx", "vy", "vz", "roll_rate", "pitch_rate", "yaw_rate"};
    std::vector<int> used;
    for (int i = 0; i < 12; ++i)
    {
      if (!q.has(names[i]))
        continue;
      *entries[i] = static_cast<int>(q.integer(names[i], -1, 0, model.n() - 1));
      if (std::find(used.begin(), used.end(), *entries[i]) != used.end())
        throw ConfigError(source + ": state_mapping." + names[i] + ": state index " + std::to_string(*entries[i]) +
                          " is mapped twice");
      used.push_back(*entries[i]);
    }
    q.rejectUnknown();
  }
}

/// The GNSS alignment, the runtime limits, the queue and the live stability settings.
void readOutputsAndLinks(ParamReader& p, const std::string& source, EstimatorNodeConfig& c)
{
  const Model& model = c.model;
  RuntimeSettings& rt = c.runtime;
  c.gnss = parseGnssAlignment(p, c);
  const double inf = std::numeric_limits<double>::infinity();
  rt.trace_bound = p.number("trace_bound", inf, 0.0, inf);
  RuntimeLimits limits;
  limits.period = c.period;
  limits.max_future_steps = c.online.max_future_steps;
  limits.max_stamp_behind = c.timeline.max_behind;
  validateRuntimeSettings(rt, limits, source);
  c.queue_size = static_cast<std::size_t>(p.integer("queue_size", 1000, 1, 1000000));
  c.live_stability = p.flag("live_stability", true);
  c.markov_link = p.choice("link_model", "iid", {"iid", "markov"}) == "markov";
  const long window = p.integer("stability_window", 1000, 10, 1000000);
  c.stability_window = static_cast<std::size_t>(window);
  c.stability_min_samples = static_cast<std::size_t>(p.integer("stability_min_samples", 100, 1, window));
  p.take("diagnostic_period");  // read by diagnostic_updater
  p.take("reconfigure");        // dynamic_reconfigure's own namespace
}

}  // namespace

EstimatorNodeConfig parseEstimatorNodeConfig(const YAML::Node& params, const std::string& source)
{
  ParamReader p(params, source);
  EstimatorNodeConfig c;
  readModel(p, params, source, c);
  readFilter(p, source, c);
  readTiming(p, source, c);
  readInputs(p, source, c);
  readFrames(p, source, c);
  readOutputsAndLinks(p, source, c);
  p.rejectUnknown();
  return c;
}

}  // namespace networked_estimation
