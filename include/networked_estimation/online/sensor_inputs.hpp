// The Estimator's per-sensor inputs (docs/ros_interface.md, "Per-sensor inputs"), ROS-free: which
// standard message type feeds a sensor of the model, and which of its fields, in order, form that
// sensor's y. The names are the field paths `rostopic echo` prints (`pose.pose.position.x`), plus
// derived ones: `<quaternion path>.roll|pitch|yaw` and, for NavSatFix, `east`, `north`, `up`
// (local ENU metres about a datum). The nodelet maps each field's quantity and axis onto the
// message; this file only names and validates them.
#pragma once

#include <limits>
#include <string>
#include <vector>

namespace YAML
{
class Node;
}

namespace networked_estimation
{

enum class InputType
{
  MEASUREMENT,            ///< networked_estimation/Measurement (y whole, step given)
  ODOMETRY,               ///< nav_msgs/Odometry
  POSE_WITH_COVARIANCE,   ///< geometry_msgs/PoseWithCovarianceStamped
  POSE,                   ///< geometry_msgs/PoseStamped
  POINT,                  ///< geometry_msgs/PointStamped
  TWIST_WITH_COVARIANCE,  ///< geometry_msgs/TwistWithCovarianceStamped
  TWIST,                  ///< geometry_msgs/TwistStamped
  IMU,                    ///< sensor_msgs/Imu
  NAVSATFIX,              ///< sensor_msgs/NavSatFix
  RANGE,                  ///< sensor_msgs/Range
  FLOAT64,                ///< std_msgs/Float64 (no header: stamped by its arrival)
  TWIST_UNSTAMPED,        ///< geometry_msgs/Twist (/cmd_vel; no header: stamped by its arrival)
  FLOAT64_ARRAY,          ///< std_msgs/Float64MultiArray (no header: stamped by its arrival)
  CONTROL_INPUT           ///< networked_estimation/ControlInput (commands only: u whole, step given)
};

/// "nav_msgs/Odometry" etc.
std::string toString(InputType t);
/// Every type, in the order of the enum.
const std::vector<InputType>& inputTypes();

/// What a field reads from its message.
enum class Quantity
{
  POSITION,             ///< axis 0..2 = x, y, z
  ORIENTATION,          ///< axis 0..3 = quaternion x, y, z, w
  ORIENTATION_RPY,      ///< axis 0..2 = roll, pitch, yaw (derived, radians)
  LINEAR_VELOCITY,      ///< axis 0..2
  ANGULAR_VELOCITY,     ///< axis 0..2
  LINEAR_ACCELERATION,  ///< axis 0..2
  ENU,                  ///< axis 0..2 = east, north, up (NavSatFix, derived)
  SCALAR,               ///< Range.range, Float64.data
  ELEMENT               ///< Float64MultiArray.data[axis]
};

struct InputField
{
  std::string name;
  Quantity quantity = Quantity::SCALAR;
  int axis = 0;
};

/// Float64MultiArray fields are data[0] .. data[kMaxArrayFields - 1].
constexpr int kMaxArrayFields = 64;

/// One row of the input types' descriptor table.
struct InputTypeInfo
{
  InputType type;
  std::string name;                ///< "nav_msgs/Odometry"
  std::vector<InputField> fields;  ///< the fields a sensor may select, in the message's order
  bool stamped = true;             ///< has a header (else stamped by its arrival)
  bool sensor = true;              ///< may feed a sensor (ControlInput: commands only)
};
/// The row of a type.
const InputTypeInfo& inputTypeInfo(InputType t);

/// The fields a type offers (empty for MEASUREMENT and CONTROL_INPUT, taken whole).
const std::vector<InputField>& inputFields(InputType t);

/// Where a field's variance sits in its message (covariance: message).
enum class CovarianceBlock
{
  NONE,          ///< the type has no covariance for this field
  POSE,          ///< 6 x 6 [x y z roll pitch yaw] (Odometry, PoseWithCovarianceStamped)
  TWIST,         ///< 6 x 6 [vx vy vz wx wy wz] (Odometry, TwistWithCovarianceStamped)
  ORIENTATION,   ///< Imu.orientation_covariance, 3 x 3 [roll pitch yaw]
  ANGULAR,       ///< Imu.angular_velocity_covariance, 3 x 3
  ACCELERATION,  ///< Imu.linear_acceleration_covariance, 3 x 3
  POSITION_ENU   ///< NavSatFix.position_covariance, 3 x 3 [east north up]
};

struct CovarianceSource
{
  CovarianceBlock block = CovarianceBlock::NONE;
  int index = 0;  ///< row/column of the field in its block
};

/// The covariance entry of a field of `type` (NONE where the message has none, e.g. a raw
/// quaternion component, or a type without covariances).
CovarianceSource covarianceOf(InputType type, const InputField& field);

/// How an input's messages cross the network (roscpp's transports): TCPROS (every message
/// arrives, a lost packet arrives late, after TCP's retransmission) or UDPROS (a lost packet is a
/// lost message, the others arrive at once). UDPROS needs a publisher that can serve it (roscpp,
/// rosbag play); with any other (rospy) the subscription falls back to TCPROS.
enum class Transport
{
  TCP,
  UDP
};

/// "tcp" | "udp", the parameter's values.
std::string toString(Transport t);

/// An input's `transport` (default tcp) and `tcp_nodelay` (default true: TCPROS segments are sent
/// at once, not coalesced by Nagle's algorithm; with udp it applies to the TCPROS fallback).
struct InputTransport
{
  Transport transport = Transport::TCP;
  bool tcp_nodelay = true;
};

struct SensorInput
{
  std::string topic;
  InputTransport transport;  ///< transport, tcp_nodelay
  InputType type = InputType::MEASUREMENT;
  std::vector<InputField> fields;  ///< the sensor's rows, in order (empty for MEASUREMENT)
  double rate = 0.0;               ///< nominal Hz (the model's rate by default)
  /// covariance: message: R_k is the message's covariance of the fields (per field: covarianceOf);
  /// false (model): the model's R.
  bool message_covariance = false;
  /// Largest Mahalanobis distance of the innovation still fused (+inf: off; OnlineOptions).
  double rejection_threshold = std::numeric_limits<double>::infinity();
  /// sensor_msgs/Imu: subtract gravity (kGravity along the world's z, rotated into base_link by
  /// the message's orientation) from linear_acceleration (robot_localization's
  /// imuN_remove_gravitational_acceleration).
  bool remove_gravity = false;
  /// A pose type (Odometry, PoseWithCovarianceStamped, PoseStamped): the first message's pose is
  /// the origin, every pose read relative to it, T0^-1 T (robot_localization's poseN_relative).
  bool relative = false;
  /// A pose type: consecutive poses T_prev, T fused as the velocity of T_prev^-1 T over their
  /// stamps' difference, in base_link (robot_localization's *_differential): its position fields
  /// read the linear velocity and its roll/pitch/yaw fields the angular rates (parse turns them
  /// into LINEAR_VELOCITY and ANGULAR_VELOCITY fields).
  bool differential = false;
};

/// Standard gravity (m/s^2), what remove_gravitational_acceleration subtracts.
constexpr double kGravity = 9.80665;

/// Parses a type name (e.g. "sensor_msgs/NavSatFix") among `allowed`; throws ConfigError naming
/// `key` and listing them.
InputType inputTypeFromString(const std::string& name, const std::string& key, const std::vector<InputType>& allowed);
/// The types a sensor can read (all but CONTROL_INPUT), and those a command can.
const std::vector<InputType>& sensorInputTypes();
const std::vector<InputType>& commandInputTypes();
/// The field of `type` called `name`; throws ConfigError naming `key` and listing the fields.
InputField inputFieldFromString(InputType type, const std::string& name, const std::string& key);

/// A NavSatFix datum [latitude, longitude, altitude] (degrees, degrees, m) from a YAML list;
/// throws ConfigError naming `key` when it is not a list of three, or naming the entry ("<key>[0]
/// (latitude): expected a finite number of degrees in [-90, 90], found nan") that is not a number,
/// not finite (YAML's .nan / .inf, or a ROS parameter's nan / inf) or out of range.
std::vector<double> parseDatum(const YAML::Node& node, const std::string& key);

class ParamReader;
/// `transport` (tcp | udp) and `tcp_nodelay` (true | false) read from `p` (defaults: tcp, true).
/// Throws ConfigError naming `prefix` + the key ("<source>: sensors.gps." + "transport: expected
/// tcp or udp, found 'sctp'").
InputTransport parseInputTransport(ParamReader& p, const std::string& prefix);

/// The topic, type (among `allowed`, default the first), fields (`rows` of them, unless the
/// type is taken whole) and transport (parseInputTransport) of one input block `key` (`what` names
/// its rows in errors), read from `p` into `in` (its topic is the default). Throws ConfigError
/// naming the key.
void parseInputBlock(ParamReader& p, const std::string& key, const std::vector<InputType>& allowed, int rows,
                     const std::string& what, SensorInput& in);

}  // namespace networked_estimation
