// What robot_localization does to some inputs before fusing them, per sensor (sensor_inputs.hpp):
// - relative: the first pose of the sensor is the origin; every pose is read as T0^-1 T (position
//   R0' (p - p0), orientation q0^-1 q, the pose covariance rotated by R0');
// - remove_gravitational_acceleration (sensor_msgs/Imu): linear_acceleration - R' (0, 0, g), R
//   the message's orientation (base_link in the world, after frame_transforms.hpp).
// Applied after the message is taken into the model's frames. Header-only and master-free.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <tf2/LinearMath/Transform.h>

#include <string>

#include "frame_transforms.hpp"
#include "networked_estimation/online/sensor_inputs.hpp"

namespace networked_estimation
{

/// Per subscription: what preprocessing remembers (the relative origin).
struct InputMemory
{
  bool have_origin = false;
  tf2::Transform origin;
};

/// A pose relative to the first one seen (which becomes the origin). False with `why` when the
/// first pose has no valid orientation (it is not taken as the origin then).
inline bool relativePose(InputMemory& mem, geometry_msgs::Pose& p, double* cov6, std::string& why)
{
  const tf2::Quaternion q = toTf(p.orientation);
  if (!mem.have_origin)
  {
    if (!(q.length2() > 0.0) || !std::isfinite(q.length2()) || !std::isfinite(p.position.x) ||
        !std::isfinite(p.position.y) || !std::isfinite(p.position.z))
    {
      why = "relative: the first pose must be finite with an orientation that is a rotation, to be the origin";
      return false;
    }
    mem.origin = tf2::Transform(q.normalized(), tf2::Vector3(p.position.x, p.position.y, p.position.z));
    mem.have_origin = true;
  }
  const tf2::Transform inv = mem.origin.inverse();
  const tf2::Vector3 x = inv * tf2::Vector3(p.position.x, p.position.y, p.position.z);
  p.position.x = x.x();
  p.position.y = x.y();
  p.position.z = x.z();
  if (q.length2() > 0.0)  // a zero quaternion stays zero: readFields refuses it if an orientation is read
    fromTf(inv.getRotation() * q, p.orientation);
  if (cov6)
    rotateCovariance(cov6, 2, inv.getBasis());
  return true;
}

/// Gravity out of an IMU's linear_acceleration (in base_link), by the message's orientation.
inline bool removeGravity(sensor_msgs::Imu& m, std::string& why)
{
  const tf2::Quaternion q = toTf(m.orientation);
  if (m.orientation_covariance[0] == -1.0 || !(q.length2() > 0.0) || !std::isfinite(q.length2()))
  {
    why = "remove_gravitational_acceleration: the message has no orientation to rotate gravity by "
          "(orientation_covariance[0] = -1 or a zero quaternion)";
    return false;
  }
  const tf2::Vector3 g = tf2::Matrix3x3(q.normalized()).transpose() * tf2::Vector3(0.0, 0.0, kGravity);
  m.linear_acceleration.x -= g.x();
  m.linear_acceleration.y -= g.y();
  m.linear_acceleration.z -= g.z();
  return true;
}

template <class M>
bool preprocess(const SensorInput&, InputMemory&, M&, std::string&)
{
  return true;
}
inline bool preprocess(const SensorInput& in, InputMemory& mem, nav_msgs::Odometry& m, std::string& why)
{
  return !in.relative || relativePose(mem, m.pose.pose, m.pose.covariance.data(), why);
}
inline bool preprocess(const SensorInput& in, InputMemory& mem, geometry_msgs::PoseWithCovarianceStamped& m,
                       std::string& why)
{
  return !in.relative || relativePose(mem, m.pose.pose, m.pose.covariance.data(), why);
}
inline bool preprocess(const SensorInput& in, InputMemory& mem, geometry_msgs::PoseStamped& m, std::string& why)
{
  return !in.relative || relativePose(mem, m.pose, nullptr, why);
}
inline bool preprocess(const SensorInput& in, InputMemory&, sensor_msgs::Imu& m, std::string& why)
{
  return !in.remove_gravity || removeGravity(m, why);
}

}  // namespace networked_estimation
