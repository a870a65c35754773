// What the PlantSimulator publishes for each sensor of the model (docs/ros_interface.md,
// "PlantSimulator"), ROS-free: the message type and the fields that carry y_k (the names of the
// Estimator's inputs, online/sensor_inputs.hpp), the sensor's own rate as a whole number of model
// steps, its frames, and an optional cycle of covariance scales (a receiver whose accuracy changes
// from fix to fix: the j-th sample published is drawn with R_j = s_j R and says so in its
// covariance).
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/online/sensor_inputs.hpp"

namespace networked_estimation
{

class ParamReader;

struct SensorOutput
{
  SensorInput format;          ///< topic, type and fields (rate: the sensor's nominal Hz)
  long every = 1;              ///< published at the steps k with (k - 1) % every == 0
  std::string frame_id;        ///< header.frame_id (empty: the simulator's default for the type)
  std::string child_frame_id;  ///< nav_msgs/Odometry's child_frame_id (empty: the default)
  /// s_j of the j-th published sample (cycled); {1} by default. The noise is sqrt(s_j) v_k.
  std::vector<double> covariance_scales{1.0};

  bool dueAt(long k) const { return k >= 1 && (k - 1) % every == 0; }
  double scaleOf(long published) const
  {
    return covariance_scales[static_cast<std::size_t>(published) % covariance_scales.size()];
  }
};

struct SimulatorOutputs
{
  std::vector<SensorOutput> sensors;  ///< one per sensor of the model, in its order
  std::vector<double> datum;          ///< [lat, lon, alt] of the ENU origin (NavSatFix outputs need it)
};

/// The types the simulator can publish (the stamped sensor types; not the unstamped ones).
const std::vector<InputType>& simulatorOutputTypes();

/// Reads the optional `sensors` (one map per sensor name: topic, type, fields, rate, frame_id,
/// child_frame_id, covariance_scales) and `datum` keys from `p`. A sensor without a block publishes
/// networked_estimation/Measurement on measurement[/<name>] at every step. `period` is the
/// simulator's. Throws ConfigError naming the key: an unknown sensor, type or field, a rate that
/// is not the model's rate divided by a whole number, a scale that is not positive, a NavSatFix
/// without a datum.
SimulatorOutputs parseSimulatorOutputs(ParamReader& p, const Model& model, double period, const std::string& source);

}  // namespace networked_estimation
