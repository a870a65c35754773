// The Estimator's nav_msgs/Odometry output (`odometry/filtered`, as robot_localization names it):
// which state entries are the pose and the twist (EstimatorNodeConfig::state_map),
// their block of P as the pose and twist covariances, and a large variance for what the state
// does not estimate. Header-only and master-free (tested without ROS running).
#pragma once

#include <nav_msgs/Odometry.h>
#include <tf2/LinearMath/Quaternion.h>

#include <Eigen/Core>

#include <cmath>
#include <string>

#include "networked_estimation/online/estimator_node_config.hpp"

namespace networked_estimation
{

/// The variance written for an entry the state does not estimate (and no correlation with it).
constexpr double kUnmappedVariance = 1e6;

/// The pose of the mapped entries of x: position x, y, z and the rotation of roll, pitch, yaw
/// (fixed axes x, y, z, REP-103); unmapped entries are 0.
inline geometry_msgs::Pose poseOf(const Eigen::Ref<const Eigen::VectorXd>& x, const StateMap& map)
{
  auto value = [&](int i) { return i >= 0 ? x(i) : 0.0; };
  geometry_msgs::Pose p;
  p.position.x = value(map.x);
  p.position.y = value(map.y);
  p.position.z = value(map.z);
  tf2::Quaternion q;
  q.setRPY(value(map.roll), value(map.pitch), value(map.yaw));
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

/// x_{k|k} and P_{k|k} as an Odometry in `world_frame` with child `base_link_frame`. The pose is
/// [x y z roll pitch yaw], the twist [vx vy vz wx wy wz], each entry from its mapped state (an
/// unmapped one is 0 with kUnmappedVariance), taken as the state has them: the built-in motions'
/// velocities are in base_link, as REP-105 wants the twist; a linear model's are what its
/// state_mapping names. Cross-covariances of pose and twist are not representable in the message
/// and are left out.
inline nav_msgs::Odometry toOdometry(const Eigen::Ref<const Eigen::VectorXd>& x,
                                     const Eigen::Ref<const Eigen::MatrixXd>& P, const StateMap& map,
                                     const ros::Time& stamp, const std::string& world_frame,
                                     const std::string& base_link_frame)
{
  nav_msgs::Odometry o;
  o.header.stamp = stamp;
  o.header.frame_id = world_frame;
  o.child_frame_id = base_link_frame;
  const int pose[6] = {map.x, map.y, map.z, map.roll, map.pitch, map.yaw};
  const int twist[6] = {map.vx, map.vy, map.vz, map.roll_rate, map.pitch_rate, map.yaw_rate};
  auto value = [&](int i) { return i >= 0 ? x(i) : 0.0; };
  o.pose.pose = poseOf(x, map);
  o.twist.twist.linear.x = value(map.vx);
  o.twist.twist.linear.y = value(map.vy);
  o.twist.twist.linear.z = value(map.vz);
  o.twist.twist.angular.x = value(map.roll_rate);
  o.twist.twist.angular.y = value(map.pitch_rate);
  o.twist.twist.angular.z = value(map.yaw_rate);
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
    {
      const int i = pose[a], j = pose[b], u = twist[a], v = twist[b];
      o.pose.covariance[static_cast<std::size_t>(6 * a + b)] =
          i >= 0 && j >= 0 ? P(i, j) : (a == b ? kUnmappedVariance : 0.0);  // row-major
      o.twist.covariance[static_cast<std::size_t>(6 * a + b)] =
          u >= 0 && v >= 0 ? P(u, v) : (a == b ? kUnmappedVariance : 0.0);
    }
  return o;
}

}  // namespace networked_estimation
