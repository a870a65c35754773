// The other direction of sensor_adapters.hpp: a sensor's y_k and R_k written into the selected
// fields of a standard ROS message and into its covariance, so that the PlantSimulator publishes
// what a robot's drivers publish and the Estimator's adapters read back exactly y_k and R_k.
// Header-only and master-free (test_sensor_adapters checks the round trip for every type).
#pragma once

#include <tf2/LinearMath/Quaternion.h>

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "sensor_adapters.hpp"

namespace networked_estimation
{

/// The variance written for the entries of a covariance block that y does not set (the other axes
/// of a pose whose x and y are the sensor's): "not measured", as odometry/filtered's unmapped states.
constexpr double kUnmeasuredVariance = 1e6;

/// Where the fields of one message go (null where the type has no such part).
struct MessageSlots
{
  geometry_msgs::Point* position = nullptr;
  geometry_msgs::Quaternion* orientation = nullptr;
  geometry_msgs::Vector3* linear = nullptr;
  geometry_msgs::Vector3* angular = nullptr;
  geometry_msgs::Vector3* acceleration = nullptr;
  float* range = nullptr;      ///< sensor_msgs/Range.range (single precision)
  double* pose_cov = nullptr;  ///< 6 x 6, row-major
  double* twist_cov = nullptr;
  double* orientation_cov = nullptr;  ///< 3 x 3
  double* angular_cov = nullptr;
  double* acceleration_cov = nullptr;
  double* enu_cov = nullptr;
};

inline MessageSlots slots(nav_msgs::Odometry& m)
{
  MessageSlots s;
  s.position = &m.pose.pose.position;
  s.orientation = &m.pose.pose.orientation;
  s.linear = &m.twist.twist.linear;
  s.angular = &m.twist.twist.angular;
  s.pose_cov = m.pose.covariance.data();
  s.twist_cov = m.twist.covariance.data();
  return s;
}
inline MessageSlots slots(geometry_msgs::PoseWithCovarianceStamped& m)
{
  MessageSlots s;
  s.position = &m.pose.pose.position;
  s.orientation = &m.pose.pose.orientation;
  s.pose_cov = m.pose.covariance.data();
  return s;
}
inline MessageSlots slots(geometry_msgs::PoseStamped& m)
{
  MessageSlots s;
  s.position = &m.pose.position;
  s.orientation = &m.pose.orientation;
  return s;
}
inline MessageSlots slots(geometry_msgs::PointStamped& m)
{
  MessageSlots s;
  s.position = &m.point;
  return s;
}
inline MessageSlots slots(geometry_msgs::TwistWithCovarianceStamped& m)
{
  MessageSlots s;
  s.linear = &m.twist.twist.linear;
  s.angular = &m.twist.twist.angular;
  s.twist_cov = m.twist.covariance.data();
  return s;
}
inline MessageSlots slots(geometry_msgs::TwistStamped& m)
{
  MessageSlots s;
  s.linear = &m.twist.linear;
  s.angular = &m.twist.angular;
  return s;
}
inline MessageSlots slots(sensor_msgs::Imu& m)
{
  MessageSlots s;
  s.orientation = &m.orientation;
  s.angular = &m.angular_velocity;
  s.acceleration = &m.linear_acceleration;
  s.orientation_cov = m.orientation_covariance.data();
  s.angular_cov = m.angular_velocity_covariance.data();
  s.acceleration_cov = m.linear_acceleration_covariance.data();
  return s;
}
inline MessageSlots slots(sensor_msgs::Range& m)
{
  MessageSlots s;
  s.range = &m.range;
  return s;
}

/// The fields' values of y into the message. Orientation fields: a rotation built from the given
/// roll/pitch/yaw (the others 0), or the raw quaternion components given (an orientation without
/// fields stays the identity). ENU fields go to `enu` (east, north, up; the caller turns them
/// into a fix). Range.range is a float: it carries y rounded to single precision.
inline void writeFields(const MessageSlots& s, const std::vector<InputField>& fields, const double* y,
                        Eigen::Vector3d* enu = nullptr)
{
  auto axis = [](auto& v, int a) -> double& {
    return a == 0 ? v.x : a == 1 ? v.y : v.z;
  };
  std::array<double, 3> rpy{0.0, 0.0, 0.0};
  bool any_rpy = false;
  if (s.orientation)
    s.orientation->w = 1.0;
  for (std::size_t i = 0; i < fields.size(); ++i)
  {
    const InputField& f = fields[i];
    switch (f.quantity)
    {
      case Quantity::POSITION:
        axis(*s.position, f.axis) = y[i];
        break;
      case Quantity::ORIENTATION:
        (f.axis == 0   ? s.orientation->x
         : f.axis == 1 ? s.orientation->y
         : f.axis == 2 ? s.orientation->z
                       : s.orientation->w) = y[i];
        break;
      case Quantity::ORIENTATION_RPY:
        rpy[static_cast<std::size_t>(f.axis)] = y[i];
        any_rpy = true;
        break;
      case Quantity::LINEAR_VELOCITY:
        axis(*s.linear, f.axis) = y[i];
        break;
      case Quantity::ANGULAR_VELOCITY:
        axis(*s.angular, f.axis) = y[i];
        break;
      case Quantity::LINEAR_ACCELERATION:
        axis(*s.acceleration, f.axis) = y[i];
        break;
      case Quantity::ENU:
        if (enu)
          (*enu)(f.axis) = y[i];
        break;
      case Quantity::SCALAR:
        *s.range = static_cast<float>(y[i]);
        break;
      case Quantity::ELEMENT:
        break;  // Float64MultiArray: not a simulator output
    }
  }
  if (any_rpy)
  {
    tf2::Quaternion q;
    q.setRPY(rpy[0], rpy[1], rpy[2]);
    s.orientation->x = q.x();
    s.orientation->y = q.y();
    s.orientation->z = q.z();
    s.orientation->w = q.w();
  }
}

/// R (fields x fields, row-major) into the message's covariance blocks of the fields
/// (covarianceOf). In a block that holds a field, the entries of the fields are R's and the other
/// diagonal entries kUnmeasuredVariance; an Imu block without a field gets its leading -1 ("no
/// such estimate", sensor_msgs/Imu). Fields without a covariance in the message are skipped.
inline void writeCovariance(InputType type, const MessageSlots& s, const std::vector<InputField>& fields,
                            const double* R)
{
  const CovarianceBlock all[] = {CovarianceBlock::POSE,         CovarianceBlock::TWIST,
                                 CovarianceBlock::ORIENTATION,  CovarianceBlock::ANGULAR,
                                 CovarianceBlock::ACCELERATION, CovarianceBlock::POSITION_ENU};
  const std::size_t n = fields.size();
  for (CovarianceBlock b : all)
  {
    int dim = 0;
    double* c = covarianceBlockOf(s, b, dim);
    if (!c)
      continue;
    bool used = false;
    for (const InputField& f : fields)
      used = used || covarianceOf(type, f).block == b;
    for (int i = 0; i < dim * dim; ++i)
      c[i] = 0.0;
    if (!used)
    {
      if (b == CovarianceBlock::ORIENTATION || b == CovarianceBlock::ANGULAR || b == CovarianceBlock::ACCELERATION)
        c[0] = -1.0;
      continue;
    }
    for (int i = 0; i < dim; ++i)
      c[i * dim + i] = kUnmeasuredVariance;
    for (std::size_t i = 0; i < n; ++i)
    {
      const CovarianceSource a = covarianceOf(type, fields[i]);
      if (a.block != b)
        continue;
      for (std::size_t j = 0; j < n; ++j)
      {
        const CovarianceSource o = covarianceOf(type, fields[j]);
        if (o.block == b)
          c[a.index * dim + o.index] = R[i * n + j];
      }
    }
  }
}

/// A fix at local ENU `enu` about `datum` (status FIX, service GPS), with R's ENU block as its
/// position covariance (COVARIANCE_TYPE_KNOWN).
inline sensor_msgs::NavSatFix fixAt(const LocalEnu& datum, const Eigen::Vector3d& enu,
                                    const std::vector<InputField>& fields, const double* R)
{
  sensor_msgs::NavSatFix f;
  f.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
  f.status.service = sensor_msgs::NavSatStatus::SERVICE_GPS;
  const Eigen::Vector3d lla = datum.reverse(enu);
  f.latitude = lla(0);
  f.longitude = lla(1);
  f.altitude = lla(2);
  MessageSlots s;
  s.enu_cov = f.position_covariance.data();
  writeCovariance(InputType::NAVSATFIX, s, fields, R);
  f.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_KNOWN;
  return f;
}

}  // namespace networked_estimation
