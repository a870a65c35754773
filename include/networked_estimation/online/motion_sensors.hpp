// With a built-in motion (omni_2d, omni_3d) the Estimator's `sensors` block alone describes a
// sensor: each field names the state it measures, so its row of C is that state's unit vector, and
// its R comes from the messages' covariances (covariance: message) or a per-field standard deviation
// (`std`). This file derives those model sensors, and the Odometry mapping of every state the motion
// names, so that a user writes each thing once. ROS-free.
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/motion/motion.hpp"
#include "networked_estimation/online/sensor_inputs.hpp"

namespace YAML
{
class Node;
}

namespace networked_estimation
{

struct StateMap;

/// The state of `motion` that `field` measures (its index), or -1 when the motion has none (e.g.
/// position.z under omni_2d, a raw quaternion component, a scalar). `differential`: a pose field
/// read as the velocity of consecutive poses (position -> linear velocity, roll/pitch/yaw ->
/// angular rates), as parseEstimatorNodeConfig turns it.
int motionState(Motion motion, const InputField& field, bool differential);

/// The variance a derived sensor's R holds per field under covariance: message when no `std` is
/// given: it is used only for a message whose covariance block is all zero, and is the smallest
/// variance robot_localization fuses (it replaces zeros with it too).
constexpr double kMessageCovarianceFloor = 1e-9;

/// `model` (a model's YAML) with a `{name, C, R}` entry added to its `sensors` for every sensor of
/// the Estimator's `sensors` block that the model does not list, when the model has a built-in
/// `motion` (otherwise `model` is returned as it is). C: one unit row per field (motionState);
/// R: diag(std^2) from the block's `std` (one positive standard deviation per field), else
/// kMessageCovarianceFloor with covariance: message. The result is a copy; `model` is not changed.
/// The names of the derived sensors are appended to `derived`. Throws ConfigError naming
/// `source: sensors.<name>.<key>` (a field that measures no state of the motion, a state measured
/// twice, neither std nor covariance: message, a bad std) and, when neither the model nor the block
/// gives a sensor, `source: sensors`.
YAML::Node withMotionSensors(const YAML::Node& model, const YAML::Node& sensors, const std::string& source,
                             std::vector<std::string>& derived);

/// Every state of `motion` that the Odometry output carries: x, y, z, roll, pitch, yaw and the
/// linear and angular velocities (omni_2d: x, y, yaw, vx, vy, yaw rate). LINEAR: all -1.
StateMap motionStateMap(Motion motion);

}  // namespace networked_estimation
