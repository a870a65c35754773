// set_pose (robot_localization's topic and service): a pose, with its covariance, turned into the
// estimate the Estimator starts over from. ROS-free: the nodelet reads the message, takes it into
// the world frame and calls poseReset.
#pragma once

#include <Eigen/Core>

#include <array>
#include <string>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"

namespace networked_estimation
{

/// A pose in the world frame: x, y, z (m), roll, pitch, yaw (rad), and its covariance, row-major
/// 6 x 6 in that order (geometry_msgs/PoseWithCovariance).
struct PoseWithCovariance
{
  std::array<double, 6> pose{};
  std::array<double, 36> covariance{};
};

/// The estimate a set_pose resets to: the state entries `map` gives as x, y, z, roll, pitch and yaw
/// take the pose's values (angles wrapped to (-pi, pi]), and their block of P its covariance's; every other entry
/// starts over from the model's x0 and P0 (velocities and the rest, as robot_localization resets
/// its whole state); the two parts are uncorrelated. Throws InputError naming the problem: no
/// entry of x, y, z, roll, pitch, yaw mapped, a non-finite value of a mapped entry, or a covariance block that
/// is not symmetric positive semidefinite.
void poseReset(const Model& model, const StateMap& map, const PoseWithCovariance& in, Eigen::VectorXd& x,
               Eigen::MatrixXd& P);

}  // namespace networked_estimation
