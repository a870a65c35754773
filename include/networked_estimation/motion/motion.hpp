// Built-in nonlinear motion models of a robot (docs/algorithms.md 7): the state as robot_localization
// defines it, positions and Euler angles in the world frame, velocities, angular rates and
// accelerations in the robot's own frame (base_link), so that every sensor of a robot measures a
// plain selection of the state.
//
//   omni_2d  [x, y, yaw, vx, vy, vyaw, ax, ay]                                           n = 8
//   omni_3d  [x, y, z, roll, pitch, yaw, vx, vy, vz, vroll, vpitch, vyaw, ax, ay, az]    n = 15
//
// One step of dt seconds, x' = f(x, dt), with its Jacobian F = df/dx (omni_motion.hpp), and the
// process noise Q dt (Q per second, as robot_localization's process_noise_covariance).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace networked_estimation
{

enum class Motion
{
  LINEAR,   ///< x_k = A x_{k-1} (+ Bu u_k): the model's A (no `motion` key)
  OMNI_2D,  ///< a robot in the plane, n = 8
  OMNI_3D   ///< a robot in space, n = 15
};

/// "linear", "omni_2d", "omni_3d".
std::string toString(Motion motion);
/// omni_2d or omni_3d; throws ConfigError "<key>: expected omni_2d or omni_3d, found '<name>'".
Motion motionFromString(const std::string& name, const std::string& key);

/// The number of states of a built-in motion (8, 15; 0 for LINEAR).
constexpr int motionStates(Motion motion)
{
  return motion == Motion::OMNI_2D ? 8 : motion == Motion::OMNI_3D ? 15 : 0;
}
/// Their names in order (empty for LINEAR).
const std::vector<std::string>& motionStateNames(Motion motion);
/// The angular states (indices, ascending): [yaw] and [roll, pitch, yaw].
const std::vector<int>& motionAngles(Motion motion);
/// omni_3d's states that two_d_mode holds at 0: z, roll, pitch, vz, vroll, vpitch, az.
const std::vector<int>& planarConstrained();

/// x_out = f(x, dt) and, when F is not null, F = df/dx at x (resized to n x n). For a built-in
/// motion only (x of its n states). x_out must not alias x.
void propagate(Motion motion, const Eigen::VectorXd& x, double dt, Eigen::VectorXd& x_out, Eigen::MatrixXd* F);

}  // namespace networked_estimation
