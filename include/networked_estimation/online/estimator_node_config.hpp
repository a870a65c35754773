// The Estimator nodelet's configuration, parsed and validated from its private parameters (as a
// YAML map) without ROS, so that every key's check is unit-tested.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/online/runtime_settings.hpp"
#include "networked_estimation/online/timeline.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/online/sensor_inputs.hpp"

namespace YAML
{
class Node;
}

namespace networked_estimation
{

class ParamReader;

/// Which state entries the Odometry output takes as x, y, z, roll, pitch, yaw, the linear velocity
/// vx, vy, vz and the angular rates (-1: not in the state).
struct StateMap
{
  int x = -1, y = -1, z = -1, roll = -1, pitch = -1, yaw = -1;
  int vx = -1, vy = -1, vz = -1, roll_rate = -1, pitch_rate = -1, yaw_rate = -1;
};

/// How NavSatFix inputs reach world_frame (docs/ros_interface.md "GNSS alignment").
struct GnssAlignment
{
  /// false (gnss_alignment: enu): ENU about the datum is world_frame; true (navsat_transform):
  /// ENU is tied to world_frame at the first usable fix, as robot_localization's navsat_transform.
  bool navsat_transform = false;
  double magnetic_declination = 0.0;  ///< magnetic_declination_radians
  double yaw_offset = 0.0;
  bool zero_altitude = false, use_odometry_yaw = false;
  bool publish_gps_odometry = false, publish_filtered_gps = false, broadcast_utm_transform = false;
  /// gnss_heading: the sensor (model index) whose sensor_msgs/Imu orientation yaw is earth-referenced;
  /// -1 with use_odometry_yaw.
  int heading_sensor = -1;
  /// The state entries of roll and pitch (omni_3d; -1: none, taken as 0) for the lever arm.
  int roll = -1, pitch = -1;
};

struct EstimatorNodeConfig
{
  std::string model_file;
  Model model;
  EstimatorSettings settings;  ///< algorithm, mu, control_link, max_components
  OnlineOptions online;        ///< late_policy, history_length, max_future_steps, max_past_steps
  double period = 0.0;         ///< default: the model's
  /// latency_budget (auto by default: adaptive within latency_budget_min = half a period and
  /// latency_budget_max = min(1 s, max_future_steps periods / 2)), late_policy, trace_bound.
  RuntimeSettings runtime;
  /// max_stamp_ahead (10 s), max_stamp_behind (default: the largest budget + history_length periods).
  TimelineOptions timeline;
  std::string input_type = "measurement";  ///< measurement | range | point (sensors without a block)
  /// Per sensor of the model (model order): its topic, message type, fields and rate, from the
  /// `sensors` block (a sensor without one keeps the input_type topic measurement[/<name>]).
  std::vector<SensorInput> inputs;
  /// The command input (models with control): ControlInput on `command` by default, or a
  /// Twist / TwistStamped / Float64MultiArray topic with the fields that form u.
  SensorInput command;
  /// NavSatFix inputs: the ENU origin [latitude, longitude, altitude] (degrees, m); empty = the
  /// first valid fix.
  std::vector<double> datum;
  /// gnss_alignment and the navsat_transform keys (parseGnssAlignment).
  GnssAlignment gnss;
  std::string frame_id = "map";
  std::string child_frame_id;         ///< default: "<algorithm>_estimate"
  std::vector<int> position_indices;  ///< default: the motion's x, y(, z); else [0, 1] (or [0] for n = 1)
  /// Sensors whose C rows and R were derived from their fields (a built-in motion's model that does
  /// not list them; motion_sensors.hpp), in the model's order.
  std::vector<std::string> derived_sensors;
  bool publish_tf = true;
  /// `odometry/filtered` (and tf) at `frequency` Hz, the last step's estimate predicted to the ROS
  /// time of each tick (predictAhead), instead of once per step on the step grid.
  bool predict_to_current_time = false;
  double frequency = 0.0;  ///< Hz; default: the steps' rate, 1 / period
  /// `odometry/filtered`: header.frame_id and child_frame_id (REP-105 names; world_frame defaults
  /// to frame_id), and the state mapping (default: with a built-in motion every state it names,
  /// else x, y, z from position_indices).
  std::string world_frame, base_link_frame = "base_link";
  /// The robot's odometry frame: with child_frame_id = base_link_frame and world_frame map, an
  /// existing odom -> base_link makes the tf map -> odom (robot_localization's scheme).
  std::string odom_frame = "odom";
  StateMap state_map;
  std::size_t queue_size = 1000;
  bool live_stability = true;  ///< false: no link stability window, verdict or status
  bool markov_link = false;    ///< link_model: markov (recovery rate) instead of iid (arrival rate)
  std::size_t stability_window = 1000;
  std::size_t stability_min_samples = 100;
};

/// Parses the parameters (README "The ROS graph": model, algorithm, mu, control_link,
/// max_components, period, latency_budget, latency_budget_min, latency_budget_max,
/// max_stamp_ahead, max_stamp_behind, late_policy, history_length, max_future_steps,
/// max_past_steps, input_type, frame_id, child_frame_id, position_indices, publish_tf,
/// predict_to_current_time, frequency (only with predict_to_current_time), trace_bound,
/// queue_size, live_stability, link_model, stability_window, stability_min_samples, sensors.<name>.{topic, type,
/// fields, std, rate, transport, tcp_nodelay}, datum, command.{topic, type, fields, transport, tcp_nodelay}, world_frame, base_link_frame, odom_frame, state_mapping.{x, y, z, roll, pitch, yaw, vx, vy, vz, roll_rate, pitch_rate, yaw_rate}, the GNSS keys of parseGnssAlignment; diagnostic_period is left to
/// diagnostic_updater). Throws ConfigError naming `source` and the key, also for an unknown key,
/// a model file that cannot be read, an empty frame name, and ack_kf (the graph does not carry nu_k).
/// gnss_alignment: enu | navsat_transform, and with navsat_transform only:
/// magnetic_declination_radians, yaw_offset, zero_altitude, use_odometry_yaw, publish_gps_odometry,
/// publish_filtered_gps, broadcast_utm_transform, gnss_heading. Takes its keys from `p`; `c` has its
/// model, inputs and state_map already. Throws ConfigError naming the key: a key without
/// navsat_transform, navsat_transform without a NavSatFix input or without x, y and yaw in
/// state_mapping, gnss_heading not an Imu input reading orientation.yaw, no Imu input without
/// use_odometry_yaw.
GnssAlignment parseGnssAlignment(ParamReader& p, const EstimatorNodeConfig& c);

EstimatorNodeConfig parseEstimatorNodeConfig(const YAML::Node& params, const std::string& source);

}  // namespace networked_estimation
