// The Estimator's per-sensor input types and fields (sensor_inputs.hpp).
#include "networked_estimation/online/sensor_inputs.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdlib>
#include <limits>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/param_reader.hpp"
#include "networked_estimation/geodesy/local_enu.hpp"

namespace networked_estimation
{
namespace
{

void addVector(std::vector<InputField>& out, const std::string& prefix, Quantity q)
{
  const char* axes[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i)
    out.push_back({prefix + axes[i], q, i});
}

void addOrientation(std::vector<InputField>& out, const std::string& prefix)
{
  const char* quat[4] = {"x", "y", "z", "w"};
  for (int i = 0; i < 4; ++i)
    out.push_back({prefix + quat[i], Quantity::ORIENTATION, i});
  const char* rpy[3] = {"roll", "pitch", "yaw"};
  for (int i = 0; i < 3; ++i)
    out.push_back({prefix + rpy[i], Quantity::ORIENTATION_RPY, i});
}

std::vector<InputField> pose(const std::string& prefix)
{
  std::vector<InputField> f;
  addVector(f, prefix + "position.", Quantity::POSITION);
  addOrientation(f, prefix + "orientation.");
  return f;
}

std::vector<InputField> twist(const std::string& prefix)
{
  std::vector<InputField> f;
  addVector(f, prefix + "linear.", Quantity::LINEAR_VELOCITY);
  addVector(f, prefix + "angular.", Quantity::ANGULAR_VELOCITY);
  return f;
}

std::vector<InputField> join(std::vector<InputField> a, const std::vector<InputField>& b)
{
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<InputField> vector3(const std::string& prefix, Quantity q)
{
  std::vector<InputField> f;
  addVector(f, prefix, q);
  return f;
}

std::vector<InputField> orientation(const std::string& prefix)
{
  std::vector<InputField> f;
  addOrientation(f, prefix);
  return f;
}

std::vector<InputField> elements()
{
  std::vector<InputField> f;
  for (int i = 0; i < kMaxArrayFields; ++i)
    f.push_back({"data[" + std::to_string(i) + "]", Quantity::ELEMENT, i});
  return f;
}

/// The descriptor table: one row per input type, in the order of the enum. A new message type is
/// a row here (and its message class in the nodelets' list, input_message_types.hpp).
const std::vector<InputTypeInfo>& table()
{
  static const std::vector<InputTypeInfo> rows = []
  {
    const std::vector<InputTypeInfo> r = {
        {InputType::MEASUREMENT, "networked_estimation/Measurement", {}, true, true},
        {InputType::ODOMETRY, "nav_msgs/Odometry", join(pose("pose.pose."), twist("twist.twist.")), true, true},
        {InputType::POSE_WITH_COVARIANCE, "geometry_msgs/PoseWithCovarianceStamped", pose("pose.pose."), true, true},
        {InputType::POSE, "geometry_msgs/PoseStamped", pose("pose."), true, true},
        {InputType::POINT, "geometry_msgs/PointStamped", vector3("point.", Quantity::POSITION), true, true},
        {InputType::TWIST_WITH_COVARIANCE, "geometry_msgs/TwistWithCovarianceStamped", twist("twist.twist."), true,
         true},
        {InputType::TWIST, "geometry_msgs/TwistStamped", twist("twist."), true, true},
        {InputType::IMU, "sensor_msgs/Imu",
         join(join(orientation("orientation."), vector3("angular_velocity.", Quantity::ANGULAR_VELOCITY)),
              vector3("linear_acceleration.", Quantity::LINEAR_ACCELERATION)),
         true, true},
        {InputType::NAVSATFIX,
         "sensor_msgs/NavSatFix",
         {{"east", Quantity::ENU, 0}, {"north", Quantity::ENU, 1}, {"up", Quantity::ENU, 2}},
         true,
         true},
        {InputType::RANGE, "sensor_msgs/Range", {{"range", Quantity::SCALAR, 0}}, true, true},
        {InputType::FLOAT64, "std_msgs/Float64", {{"data", Quantity::SCALAR, 0}}, false, true},
        {InputType::TWIST_UNSTAMPED, "geometry_msgs/Twist", twist(""), false, true},
        {InputType::FLOAT64_ARRAY, "std_msgs/Float64MultiArray", elements(), false, true},
        {InputType::CONTROL_INPUT, "networked_estimation/ControlInput", {}, true, false},
    };
    for (std::size_t i = 0; i < r.size(); ++i)
      if (static_cast<std::size_t>(r[i].type) != i)
        std::abort();  // the rows must follow the enum
    return r;
  }();
  return rows;
}

}  // namespace

const InputTypeInfo& inputTypeInfo(InputType t)
{
  return table().at(static_cast<std::size_t>(t));
}

std::string toString(InputType t)
{
  return inputTypeInfo(t).name;
}

const std::vector<InputType>& inputTypes()
{
  static const std::vector<InputType> all = []
  {
    std::vector<InputType> out;
    for (const InputTypeInfo& row : table())
      out.push_back(row.type);
    return out;
  }();
  return all;
}

const std::vector<InputType>& sensorInputTypes()
{
  static const std::vector<InputType> sensors = []
  {
    std::vector<InputType> out;
    for (const InputTypeInfo& row : table())
      if (row.sensor)
        out.push_back(row.type);
    return out;
  }();
  return sensors;
}

const std::vector<InputType>& commandInputTypes()
{
  // The first is the default of a `command` block.
  static const std::vector<InputType> commands = {InputType::CONTROL_INPUT, InputType::TWIST_UNSTAMPED,
                                                  InputType::TWIST, InputType::FLOAT64_ARRAY};
  return commands;
}

const std::vector<InputField>& inputFields(InputType t)
{
  return inputTypeInfo(t).fields;
}

CovarianceSource covarianceOf(InputType type, const InputField& f)
{
  CovarianceSource c;
  const bool pose_type = type == InputType::ODOMETRY || type == InputType::POSE_WITH_COVARIANCE;
  const bool twist_type = type == InputType::ODOMETRY || type == InputType::TWIST_WITH_COVARIANCE;
  switch (f.quantity)
  {
    case Quantity::POSITION:
      if (pose_type)
        c = {CovarianceBlock::POSE, f.axis};
      break;
    case Quantity::ORIENTATION_RPY:
      if (pose_type)
        c = {CovarianceBlock::POSE, 3 + f.axis};
      else if (type == InputType::IMU)
        c = {CovarianceBlock::ORIENTATION, f.axis};
      break;
    case Quantity::LINEAR_VELOCITY:
      if (twist_type)
        c = {CovarianceBlock::TWIST, f.axis};
      break;
    case Quantity::ANGULAR_VELOCITY:
      if (twist_type)
        c = {CovarianceBlock::TWIST, 3 + f.axis};
      else if (type == InputType::IMU)
        c = {CovarianceBlock::ANGULAR, f.axis};
      break;
    case Quantity::LINEAR_ACCELERATION:
      if (type == InputType::IMU)
        c = {CovarianceBlock::ACCELERATION, f.axis};
      break;
    case Quantity::ENU:
      c = {CovarianceBlock::POSITION_ENU, f.axis};
      break;
    case Quantity::ORIENTATION:
    case Quantity::SCALAR:
    case Quantity::ELEMENT:
      break;
  }
  return c;
}

InputType inputTypeFromString(const std::string& name, const std::string& key, const std::vector<InputType>& allowed)
{
  std::string names;
  for (InputType t : allowed)
  {
    if (toString(t) == name)
      return t;
    names += (names.empty() ? "" : ", ") + toString(t);
  }
  throw ConfigError(key + ": unknown type '" + name + "' (types: " + names + ")");
}

InputField inputFieldFromString(InputType type, const std::string& name, const std::string& key)
{
  std::string names;
  for (const InputField& f : inputFields(type))
  {
    if (f.name == name)
      return f;
    names += (names.empty() ? "" : ", ") + f.name;
  }
  if (type == InputType::MEASUREMENT || type == InputType::CONTROL_INPUT)
    throw ConfigError(key + ": " + toString(type) + " has no field selection (it is taken whole)");
  if (type == InputType::FLOAT64_ARRAY)
    throw ConfigError(key + ": '" + name +
                      "' is not a field of std_msgs/Float64MultiArray (fields: data[i], 0 <= i < " +
                      std::to_string(kMaxArrayFields) + ")");
  throw ConfigError(key + ": '" + name + "' is not a field of " + toString(type) + " (fields: " + names + ")");
}

std::string toString(Transport t)
{
  return t == Transport::UDP ? "udp" : "tcp";
}

InputTransport parseInputTransport(ParamReader& p, const std::string& prefix)
{
  InputTransport out;
  // Read through the reader (so that rejectUnknown knows them); the messages name prefix + key
  // ("...: sensors.gps.transport: ..." in a sensors block, "...: transport: ..." for a nodelet's own).
  const YAML::Node transport = p.take("transport");
  if (transport.IsDefined() && !transport.IsNull())
  {
    const std::string v =
        transport.IsScalar() ? transport.Scalar() : std::string(transport.IsMap() ? "a map" : "a list");
    if (v == "udp")
      out.transport = Transport::UDP;
    else if (v != "tcp")
      throw ConfigError(prefix + "transport: expected tcp or udp, found '" + v + "'");
  }
  const YAML::Node nodelay = p.take("tcp_nodelay");
  if (nodelay.IsDefined() && !nodelay.IsNull())
  {
    if (!nodelay.IsScalar() || !detail::booleanText(nodelay.Scalar(), out.tcp_nodelay))  // the one grammar
      throw ConfigError(prefix + "tcp_nodelay: expected true or false, found '" +
                        (nodelay.IsScalar() ? nodelay.Scalar() : std::string(nodelay.IsMap() ? "a map" : "a list")) +
                        "'");
  }
  return out;
}

void parseInputBlock(ParamReader& p, const std::string& key, const std::vector<InputType>& allowed, int rows,
                     const std::string& what, SensorInput& in)
{
  in.topic = p.text("topic", in.topic);
  if (in.topic.empty())
    throw ConfigError(key + ".topic: expected a topic name, found an empty string");
  in.transport = parseInputTransport(p, key + ".");
  in.type = inputTypeFromString(p.text("type", toString(allowed.front())), key + ".type", allowed);
  const YAML::Node fields = p.take("fields");  // a null node when absent
  in.fields.clear();
  if (inputFields(in.type).empty())
  {
    if (!fields.IsNull())
      throw ConfigError(key + ".fields: " + toString(in.type) + " has no field selection (it is taken whole)");
    return;
  }
  if (!fields.IsSequence() || fields.size() == 0)
    throw ConfigError(key + ".fields: expected a list of " + toString(in.type) + " fields, one per " + what);
  for (std::size_t i = 0; i < fields.size(); ++i)
  {
    const std::string at = key + ".fields[" + std::to_string(i) + "]";
    if (!fields[i].IsScalar())
      throw ConfigError(at + ": expected a field name");
    in.fields.push_back(inputFieldFromString(in.type, fields[i].as<std::string>(), at));
  }
  if (static_cast<int>(in.fields.size()) != rows)
    throw ConfigError(key + ".fields: expected " + std::to_string(rows) + " fields (one per " + what + "), found " +
                      std::to_string(in.fields.size()));
}

std::vector<double> parseDatum(const YAML::Node& d, const std::string& key)
{
  if (!d.IsSequence() || d.size() != 3)
    throw ConfigError(key + ": expected [latitude, longitude, altitude] (degrees, degrees, m), found " +
                      (d.IsSequence() ? std::to_string(d.size()) + (d.size() == 1 ? " entry" : " entries")
                       : d.IsScalar() ? "'" + d.Scalar() + "'"
                       : d.IsMap()    ? std::string("a map")
                                      : std::string("nothing")));
  struct Entry
  {
    const char* name;
    double limit;  ///< |value| at most this (inf: any finite value)
    const char* expected;
  };
  const Entry entries[3] = {{"latitude", 90.0, "a finite number of degrees in [-90, 90]"},
                            {"longitude", 180.0, "a finite number of degrees in [-180, 180]"},
                            {"altitude", std::numeric_limits<double>::infinity(), "a finite number of metres"}};
  std::vector<double> datum;
  for (std::size_t i = 0; i < 3; ++i)
  {
    const std::string at = key + "[" + std::to_string(i) + "] (" + entries[i].name + ")";
    if (!d[i].IsScalar())
      throw ConfigError(at + ": expected a number, found " + (d[i].IsSequence() ? "a list" : "a map"));
    const std::string text = d[i].Scalar();
    double v = 0.0;
    if (!YAML::convert<double>::decode(d[i], v))
    {
      // YAML's .nan / .inf decode above; "nan" and "inf" are how a NaN or infinite ROS parameter arrives
      char* end = nullptr;
      v = std::strtod(text.c_str(), &end);
      if (text.empty() || end != text.c_str() + text.size())
        throw ConfigError(at + ": expected a number, found '" + text + "'");
    }
    if (!std::isfinite(v) || !(std::fabs(v) <= entries[i].limit))
      throw ConfigError(at + ": expected " + entries[i].expected + ", found " + text);
    datum.push_back(v);
  }
  LocalEnu check(datum[0], datum[1], datum[2], key);
  return datum;
}

}  // namespace networked_estimation
