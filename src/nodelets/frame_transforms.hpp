// Measurements into the model's frames with tf2, as robot_localization does: positions and
// orientations into world_frame, velocities and accelerations into base_link_frame (rotation
// only; no lever-arm terms). A message whose frame is empty or already the target is left as it
// is. Header-only and master-free: the transform lookup is a function, tf2's Buffer in the nodelet
// and a table in the tests.
#pragma once

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Vector3.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2/LinearMath/Transform.h>
#include <tf2/LinearMath/Vector3.h>

#include <Eigen/Core>

#include <functional>
#include <string>

#include "sensor_adapters.hpp"

namespace networked_estimation
{

struct Frames
{
  std::string world, base;
  /// target <- source at `stamp` (ros::Time(0): the latest); false with `why` naming both frames.
  std::function<bool(const std::string& target, const std::string& source, const ros::Time& stamp, tf2::Transform& out,
                     std::string& why)>
      lookup;
};

inline tf2::Vector3 toTf(const geometry_msgs::Vector3& v)
{
  return tf2::Vector3(v.x, v.y, v.z);
}
inline void fromTf(const tf2::Vector3& t, geometry_msgs::Vector3& v)
{
  v.x = t.x();
  v.y = t.y();
  v.z = t.z();
}
inline tf2::Quaternion toTf(const geometry_msgs::Quaternion& q)
{
  return tf2::Quaternion(q.x, q.y, q.z, q.w);
}
inline void fromTf(const tf2::Quaternion& t, geometry_msgs::Quaternion& q)
{
  q.x = t.x();
  q.y = t.y();
  q.z = t.z();
  q.w = t.w();
}

/// A row-major covariance of `blocks` 3-vectors (3 or 6 rows) rotated: S' = G S G', G = diag(R, ..).
inline void rotateCovariance(double* S, int blocks, const tf2::Matrix3x3& R)
{
  const int n = 3 * blocks;
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n);
  for (int b = 0; b < blocks; ++b)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        G(3 * b + i, 3 * b + j) = R[i][j];
  Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> M(S, n, n);
  const Eigen::MatrixXd rotated = G * M * G.transpose();
  M = rotated;
}

/// The transform target <- frame, or identity when no transform is needed.
inline bool lookupInto(const Frames& f, const std::string& target, const std::string& frame, const ros::Time& stamp,
                       tf2::Transform& T, bool& needed, std::string& why)
{
  needed = !(frame.empty() || frame == target || target.empty()) && static_cast<bool>(f.lookup);
  T.setIdentity();
  return !needed || f.lookup(target, frame, stamp, T, why);
}

/// A pose in `frame` into world: p' = R p + t, q' = q_T q, and its 6 x 6 covariance (if given)
/// rotated by diag(R, R).
inline bool poseToWorld(const Frames& f, const std::string& frame, const ros::Time& stamp, geometry_msgs::Pose& p,
                        std::string& why, double* cov6 = nullptr)
{
  tf2::Transform T;
  bool needed = false;
  if (!lookupInto(f, f.world, frame, stamp, T, needed, why))
    return false;
  if (!needed)
    return true;
  const tf2::Vector3 x = T * tf2::Vector3(p.position.x, p.position.y, p.position.z);
  p.position.x = x.x();
  p.position.y = x.y();
  p.position.z = x.z();
  const double n2 = p.orientation.x * p.orientation.x + p.orientation.y * p.orientation.y +
                    p.orientation.z * p.orientation.z + p.orientation.w * p.orientation.w;
  if (n2 > 0.0)  // a zero quaternion stays zero: readFields refuses it if an orientation is read
    fromTf(T.getRotation() * toTf(p.orientation), p.orientation);
  if (cov6)
    rotateCovariance(cov6, 2, T.getBasis());
  return true;
}

/// Vectors in `frame` rotated into base_link (and a 6 x 6 twist covariance, if given).
inline bool vectorsToBase(const Frames& f, const std::string& frame, const ros::Time& stamp,
                          std::initializer_list<geometry_msgs::Vector3*> vectors, std::string& why,
                          double* cov6 = nullptr)
{
  tf2::Transform T;
  bool needed = false;
  if (!lookupInto(f, f.base, frame, stamp, T, needed, why))
    return false;
  if (needed)
  {
    for (geometry_msgs::Vector3* v : vectors)
      fromTf(T.getBasis() * toTf(*v), *v);
    if (cov6)
      rotateCovariance(cov6, 2, T.getBasis());
  }
  return true;
}

// Per type: the copy of a message in the model's frames. False with `why` when a transform is
// missing.
inline bool intoFrames(const Frames& f, nav_msgs::Odometry& m, std::string& why)
{
  return poseToWorld(f, m.header.frame_id, m.header.stamp, m.pose.pose, why, m.pose.covariance.data()) &&
         vectorsToBase(f, m.child_frame_id, m.header.stamp, {&m.twist.twist.linear, &m.twist.twist.angular}, why,
                       m.twist.covariance.data());
}
inline bool intoFrames(const Frames& f, geometry_msgs::PoseWithCovarianceStamped& m, std::string& why)
{
  return poseToWorld(f, m.header.frame_id, m.header.stamp, m.pose.pose, why, m.pose.covariance.data());
}
inline bool intoFrames(const Frames& f, geometry_msgs::PoseStamped& m, std::string& why)
{
  return poseToWorld(f, m.header.frame_id, m.header.stamp, m.pose, why);
}
inline bool intoFrames(const Frames& f, geometry_msgs::PointStamped& m, std::string& why)
{
  geometry_msgs::Pose p;
  p.position = m.point;
  if (!poseToWorld(f, m.header.frame_id, m.header.stamp, p, why))
    return false;
  m.point = p.position;
  return true;
}
inline bool intoFrames(const Frames& f, geometry_msgs::TwistWithCovarianceStamped& m, std::string& why)
{
  return vectorsToBase(f, m.header.frame_id, m.header.stamp, {&m.twist.twist.linear, &m.twist.twist.angular}, why,
                       m.twist.covariance.data());
}
inline bool intoFrames(const Frames& f, geometry_msgs::TwistStamped& m, std::string& why)
{
  return vectorsToBase(f, m.header.frame_id, m.header.stamp, {&m.twist.linear, &m.twist.angular}, why);
}
/// An IMU in its own frame: rates and accelerations rotated into base_link, and the orientation
/// (of the IMU frame in the world) turned into base_link's: q_base = q_imu q_(base <- imu)^-1.
inline bool intoFrames(const Frames& f, sensor_msgs::Imu& m, std::string& why)
{
  tf2::Transform T;
  bool needed = false;
  if (!lookupInto(f, f.base, m.header.frame_id, m.header.stamp, T, needed, why))
    return false;
  if (!needed)
    return true;
  fromTf(T.getBasis() * toTf(m.angular_velocity), m.angular_velocity);
  fromTf(T.getBasis() * toTf(m.linear_acceleration), m.linear_acceleration);
  const tf2::Quaternion q = toTf(m.orientation);
  if (q.length2() > 0.0)
    fromTf(q * T.getRotation().inverse(), m.orientation);
  for (auto* cov : {&m.orientation_covariance, &m.angular_velocity_covariance, &m.linear_acceleration_covariance})
    if ((*cov)[0] != -1.0)  // -1: unknown, kept as the marker
      rotateCovariance(cov->data(), 1, T.getBasis());
  return true;
}
/// Frame-free types: NavSatFix (its ENU is the world's by construction), Range and Float64 (scalars
/// along the sensor's own axis), and the unstamped command types.
template <class M>
bool intoFrames(const Frames&, M&, std::string&)
{
  return true;
}

}  // namespace networked_estimation
