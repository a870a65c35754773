// What robot_localization does to some inputs before fusing them, per sensor (sensor_inputs.hpp):
// - relative: the first pose of the sensor is the origin; every pose is read as T0^-1 T (position
//   R0' (p - p0), orientation q0^-1 q, the pose covariance rotated by R0');
// - remove_gravitational_acceleration (sensor_msgs/Imu): linear_acceleration - R' (0, 0, g), R
//   the message's orientation (base_link in the world, after frame_transforms.hpp);
// - differential (a pose): consecutive poses T_prev, T as the velocity of D = T_prev^-1 T over the
//   stamps' difference dt: linear D's translation / dt, angular D's roll, pitch, yaw / dt (in
//   base_link, as the pose's own axes).
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
  // differential: the previous pose and its stamp, and the velocities read from the latest pair
  bool have_previous = false;
  tf2::Transform previous;
  double previous_stamp = 0.0;
  geometry_msgs::Vector3 linear, angular;
};

enum class Differential
{
  OK,     ///< the view reads the velocity
  FIRST,  ///< the first pose: only the reference of the next, nothing to fuse
  BAD     ///< refused (why)
};

/// The velocity between the previous pose of the sensor and this one, into `v` (its linear and
/// angular), or why not. The pose becomes the previous one unless it is refused.
inline Differential differentiate(InputMemory& mem, const geometry_msgs::Pose* p, double stamp, MessageView& v,
                                  std::string& why)
{
  if (!p)
  {
    why = "differential: the message has no pose";
    return Differential::BAD;
  }
  const tf2::Quaternion q = toTf(p->orientation);
  if (!(q.length2() > 0.0) || !std::isfinite(q.length2()) || !std::isfinite(p->position.x) ||
      !std::isfinite(p->position.y) || !std::isfinite(p->position.z) || !std::isfinite(stamp))
  {
    why = "differential: the pose must be finite with an orientation that is a rotation";
    return Differential::BAD;
  }
  const tf2::Transform T(q.normalized(), tf2::Vector3(p->position.x, p->position.y, p->position.z));
  if (!mem.have_previous)
  {
    mem.previous = T;
    mem.previous_stamp = stamp;
    mem.have_previous = true;
    why = "differential: the first pose is only the reference of the next";
    return Differential::FIRST;
  }
  const double dt = stamp - mem.previous_stamp;
  if (!(dt > 0.0))
  {
    why = "differential: stamp " + std::to_string(stamp) + " s is not after the previous pose's " +
          std::to_string(mem.previous_stamp) + " s";
    return Differential::BAD;
  }
  const tf2::Transform D = mem.previous.inverseTimes(T);
  double roll = 0.0, pitch = 0.0, yaw = 0.0;
  D.getBasis().getRPY(roll, pitch, yaw);
  fromTf(D.getOrigin() / dt, mem.linear);
  fromTf(tf2::Vector3(roll, pitch, yaw) / dt, mem.angular);
  mem.previous = T;
  mem.previous_stamp = stamp;
  v.linear = &mem.linear;
  v.angular = &mem.angular;
  v.twist_cov = nullptr;  // covariance: model (refused at load with differential)
  return Differential::OK;
}

/// The pose a message carries (null for the other types).
template <class M>
const geometry_msgs::Pose* poseOf(const M&)
{
  return nullptr;
}
inline const geometry_msgs::Pose* poseOf(const nav_msgs::Odometry& m)
{
  return &m.pose.pose;
}
inline const geometry_msgs::Pose* poseOf(const geometry_msgs::PoseWithCovarianceStamped& m)
{
  return &m.pose.pose;
}
inline const geometry_msgs::Pose* poseOf(const geometry_msgs::PoseStamped& m)
{
  return &m.pose;
}

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
    why =
        "remove_gravitational_acceleration: the message has no orientation to rotate gravity by "
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
