// Constant-velocity and constant-acceleration models of a robot in 1-D, 2-D or 3-D at any rate, the
// process noise derived from the spectral density of a continuous white noise (docs/formats.md,
// "Kinematic models for robots (make_model)").
//
// State order: all positions, then all velocities (then all accelerations), e.g.
//   2-D constant_velocity      [x, y, vx, vy]
//   3-D constant_acceleration  [x, y, z, vx, vy, vz, ax, ay, az]
// With a heading (heading_density > 0; 2-D and 3-D), the yaw is one more axis of the same motion,
// last in each group, and an angle (the model's `angles`):
//   2-D constant_velocity      [x, y, yaw, vx, vy, vyaw]
//
// With T = 1 / rate, per axis (the axes are independent and alike):
//   constant_velocity      A = [[1, T], [0, 1]]
//                          Q = q [[T^3/3, T^2/2], [T^2/2, T]]                 q in m^2/s^3
//   constant_acceleration  A = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]]
//                          Q = q [[T^5/20, T^4/8, T^3/6], [T^4/8, T^3/3, T^2/2], [T^3/6, T^2/2, T]]
//                                                                             q in m^2/s^5
// the exact discretisation of dx/dt = F x + G w(t), w white with E[w(t) w(s)'] = q I delta(t - s):
// A = e^{F T}, Q = integral_0^T e^{F s} G q G' e^{F' s} ds, and B = identity.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// One sensor measuring one quantity of every axis: C selects it, R = sigma^2 I (dims x dims).
struct KinematicSensor
{
  std::string name;
  /// "position", "velocity" or "acceleration" (constant_acceleration only) of every axis; with a
  /// heading also "yaw", "yaw_rate" or "yaw_acceleration" (constant_acceleration only), one row
  std::string quantity;
  double sigma = 0.0;  ///< standard deviation per axis: m, m/s or m/s^2 (rad, rad/s, rad/s^2)
};

struct KinematicSpec
{
  std::string name = "kinematic";
  std::string motion;                    ///< "constant_velocity" or "constant_acceleration"
  int dims = 0;                          ///< 1, 2 or 3
  double rate = 0.0;                     ///< Hz; the period is 1 / rate
  double density = 0.0;                  ///< q: of the acceleration (constant_velocity, m^2/s^3) or of the jerk
                                         ///< (constant_acceleration, m^2/s^5)
  std::vector<KinematicSensor> sensors;  ///< at least one
  Eigen::VectorXd x0;                    ///< empty: zeros
  double p0_position = 1.0;              ///< P0 = diag of these variances (m^2, m^2/s^2, m^2/s^4)
  double p0_velocity = 1.0;
  double p0_acceleration = 1.0;  ///< constant_acceleration only
  /// How a message names a key ("dims", "sensors[1].sigma", ...): make_model names the option the
  /// user typed. Empty: the key itself.
  std::function<std::string(const std::string& key)> key_name;
  /// > 0: the robot has a heading (yaw, an angle) moving like the axes, driven by white angular
  /// acceleration (constant_velocity, rad^2/s^3) or jerk (constant_acceleration, rad^2/s^5) of this
  /// spectral density; 0: no heading.
  double heading_density = 0.0;
  double p0_yaw = 1.0;       ///< P0 of the heading and its derivatives: rad^2, (rad/s)^2,
  double p0_yaw_rate = 1.0;  ///< (rad/s^2)^2 (the last for constant_acceleration only)
  double p0_yaw_acceleration = 1.0;
};

/// Order of the motion: 2 (position, velocity) or 3 (and acceleration). Throws ConfigError for an
/// unknown motion.
int kinematicOrder(const std::string& motion);

/// The name of the density option of a motion: "accel-density" or "jerk-density".
std::string densityKey(const std::string& motion);

/// Names of the state entries in order, e.g. {"x", "y", "vx", "vy"}; with a heading
/// {"x", "y", "yaw", "vx", "vy", "vyaw"}.
std::vector<std::string> kinematicStateNames(int order, int dims, bool heading = false);

/// Builds and validates (validateModel) the model, its states named and the heading (if any) an
/// angle. Throws ConfigError naming the option (motion, dims, rate, accel-density / jerk-density,
/// heading, sensors[i].name / .quantity / .sigma, x0, p0-*, each through spec.key_name when given)
/// and the
/// value found versus the one expected. Every rate is accepted (the model checks' definiteness test
/// is scale-aware, and Q scaled to unit diagonal does not depend on the rate) until Q's entries,
/// q T^5 (q T^3) to q T, leave the normal doubles (for q = 1 a rate above about 1.9e61 Hz, 2.5e102
/// Hz for constant velocity): "rate" then names the rate and the density.
Model makeKinematicModel(const KinematicSpec& spec);

/// The comment that describes a model built from `spec`: motion, rate, state order, the formulas
/// of A and Q, the sensors (one line each, without the leading "# ").
std::string kinematicModelComment(const KinematicSpec& spec);

}  // namespace networked_estimation
