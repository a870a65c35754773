// Reads the selected fields of standard ROS messages into a sensor's y (the names and their
// quantities are the core's, online/sensor_inputs.hpp). Header-only and master-free, so that a
// GoogleTest checks every type's fields against the message values.
#pragma once

#include <geometry_msgs/PointStamped.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Float64MultiArray.h>
#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/common/covariance.hpp"
#include "networked_estimation/geodesy/local_enu.hpp"
#include "networked_estimation/online/sensor_inputs.hpp"

namespace networked_estimation
{

/// What one message offers, per quantity (null / NaN where it has none).
struct MessageView
{
  const geometry_msgs::Point* position = nullptr;
  const geometry_msgs::Quaternion* orientation = nullptr;
  const geometry_msgs::Vector3* linear = nullptr;
  const geometry_msgs::Vector3* angular = nullptr;
  const geometry_msgs::Vector3* acceleration = nullptr;
  const Eigen::Vector3d* enu = nullptr;
  const std::vector<double>* array = nullptr;
  double scalar = std::numeric_limits<double>::quiet_NaN();
  // Covariances (row-major; null where the type has none): 6 x 6 pose and twist, 3 x 3 IMU and fix.
  const double* pose_cov = nullptr;
  const double* twist_cov = nullptr;
  const double* orientation_cov = nullptr;
  const double* angular_cov = nullptr;
  const double* acceleration_cov = nullptr;
  const double* enu_cov = nullptr;
  int enu_cov_type = 0;  ///< NavSatFix.position_covariance_type
};

inline MessageView view(const geometry_msgs::Pose& p)
{
  MessageView v;
  v.position = &p.position;
  v.orientation = &p.orientation;
  return v;
}
inline MessageView view(const geometry_msgs::Twist& t)
{
  MessageView v;
  v.linear = &t.linear;
  v.angular = &t.angular;
  return v;
}
inline MessageView view(const nav_msgs::Odometry& m)
{
  MessageView v = view(m.pose.pose);
  v.linear = &m.twist.twist.linear;
  v.angular = &m.twist.twist.angular;
  v.pose_cov = m.pose.covariance.data();
  v.twist_cov = m.twist.covariance.data();
  return v;
}
inline MessageView view(const geometry_msgs::PoseWithCovarianceStamped& m)
{
  MessageView v = view(m.pose.pose);
  v.pose_cov = m.pose.covariance.data();
  return v;
}
inline MessageView view(const geometry_msgs::PoseStamped& m)
{
  return view(m.pose);
}
inline MessageView view(const geometry_msgs::TwistWithCovarianceStamped& m)
{
  MessageView v = view(m.twist.twist);
  v.twist_cov = m.twist.covariance.data();
  return v;
}
inline MessageView view(const geometry_msgs::TwistStamped& m)
{
  return view(m.twist);
}
inline MessageView view(const geometry_msgs::PointStamped& m)
{
  MessageView v;
  v.position = &m.point;
  return v;
}
inline MessageView view(const sensor_msgs::Imu& m)
{
  MessageView v;
  v.orientation = &m.orientation;
  v.angular = &m.angular_velocity;
  v.acceleration = &m.linear_acceleration;
  v.orientation_cov = m.orientation_covariance.data();
  v.angular_cov = m.angular_velocity_covariance.data();
  v.acceleration_cov = m.linear_acceleration_covariance.data();
  return v;
}
inline MessageView view(const sensor_msgs::Range& m)
{
  MessageView v;
  v.scalar = m.range;
  return v;
}
inline MessageView view(const std_msgs::Float64MultiArray& m)
{
  MessageView v;
  v.array = &m.data;
  return v;
}
inline MessageView view(const std_msgs::Float64& m)
{
  MessageView v;
  v.scalar = m.data;
  return v;
}

inline double axisOf(const geometry_msgs::Vector3& v, int axis)
{
  return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
}
inline double axisOf(const geometry_msgs::Point& v, int axis)
{
  return axis == 0 ? v.x : axis == 1 ? v.y : v.z;
}

/// Fills y (fields.size() values) from a message's view. False, with `why` naming the field, when
/// a value is not finite or an orientation is not a rotation (a zero or non-finite quaternion;
/// another length is normalised, as tf2 does).
inline bool readFields(const MessageView& v, const std::vector<InputField>& fields, double* y, std::string& why)
{
  for (std::size_t i = 0; i < fields.size(); ++i)
  {
    const InputField& f = fields[i];
    double value = std::numeric_limits<double>::quiet_NaN();
    switch (f.quantity)
    {
      case Quantity::POSITION:
        value = axisOf(*v.position, f.axis);
        break;
      case Quantity::ORIENTATION:
      {
        const geometry_msgs::Quaternion& q = *v.orientation;
        value = f.axis == 0 ? q.x : f.axis == 1 ? q.y : f.axis == 2 ? q.z : q.w;
        break;
      }
      case Quantity::ORIENTATION_RPY:
      {
        const geometry_msgs::Quaternion& q = *v.orientation;
        const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
        if (!(norm > 1e-9) || !std::isfinite(norm))
        {
          why = f.name + ": the orientation is not a rotation (quaternion length " + std::to_string(norm) + ")";
          return false;
        }
        double rpy[3];
        tf2::Matrix3x3(tf2::Quaternion(q.x / norm, q.y / norm, q.z / norm, q.w / norm)).getRPY(rpy[0], rpy[1], rpy[2]);
        value = rpy[f.axis];
        break;
      }
      case Quantity::LINEAR_VELOCITY:
        value = axisOf(*v.linear, f.axis);
        break;
      case Quantity::ANGULAR_VELOCITY:
        value = axisOf(*v.angular, f.axis);
        break;
      case Quantity::LINEAR_ACCELERATION:
        value = axisOf(*v.acceleration, f.axis);
        break;
      case Quantity::ENU:
        value = (*v.enu)(f.axis);
        break;
      case Quantity::SCALAR:
        value = v.scalar;
        break;
      case Quantity::ELEMENT:
        if (static_cast<std::size_t>(f.axis) >= v.array->size())
        {
          why = f.name + " is out of range: the message has " + std::to_string(v.array->size()) + " values";
          return false;
        }
        value = (*v.array)[static_cast<std::size_t>(f.axis)];
        break;
    }
    if (!std::isfinite(value))
    {
      why = f.name + " is not finite (" + std::to_string(value) + ")";
      return false;
    }
    y[i] = value;
  }
  return true;
}

enum class CovarianceRead
{
  OK,        ///< R holds the message's covariance of the fields
  FALLBACK,  ///< the message says it has none (ROS conventions): use the model's R (why says which)
  BAD,       ///< not finite, not symmetric or not positive definite: refuse the message
  DISABLED   ///< an Imu block with a leading -1: the message has no estimate of these fields
};

/// A message's covariance block `b` (row-major, dim x dim: 6 for pose and twist, 3 otherwise), or
/// null where it has none; for MessageView (read) and MessageSlots (write) alike.
template <class V>
auto covarianceBlockOf(const V& v, CovarianceBlock b, int& dim) -> decltype(v.pose_cov)
{
  dim = b == CovarianceBlock::POSE || b == CovarianceBlock::TWIST ? 6 : 3;
  switch (b)
  {
    case CovarianceBlock::POSE:
      return v.pose_cov;
    case CovarianceBlock::TWIST:
      return v.twist_cov;
    case CovarianceBlock::ORIENTATION:
      return v.orientation_cov;
    case CovarianceBlock::ANGULAR:
      return v.angular_cov;
    case CovarianceBlock::ACCELERATION:
      return v.acceleration_cov;
    case CovarianceBlock::POSITION_ENU:
      return v.enu_cov;
    case CovarianceBlock::NONE:
      break;
  }
  return nullptr;
}

/// sensor_msgs/Imu: "a covariance whose element 0 is -1 means there is no estimate of that data
/// element: disregard it". True (with `why` naming the first such field and its block) when a
/// selected field lies in such a block of the message: the sensor's fields are not fused for it.
inline bool disabledBlock(InputType type, const MessageView& v, const std::vector<InputField>& fields, std::string& why)
{
  for (const InputField& f : fields)
  {
    const CovarianceSource a = covarianceOf(type, f);
    if (a.block != CovarianceBlock::ORIENTATION && a.block != CovarianceBlock::ANGULAR &&
        a.block != CovarianceBlock::ACCELERATION)
      continue;
    int dim = 0;
    const double* c = covarianceBlockOf(v, a.block, dim);
    if (c && c[0] == -1.0)
    {
      why = f.name + ": the message has no estimate of it (its covariance block starts with -1)";
      return true;
    }
  }
  return false;
}

/// R (fields x fields, row-major) from the message's covariances of the fields (covarianceOf);
/// fields of different blocks are uncorrelated. ROS's "unknown" conventions give FALLBACK
/// (NavSatFix COVARIANCE_TYPE_UNKNOWN, all-zero entries); a leading -1 in an Imu block gives
/// DISABLED (disabledBlock).
inline CovarianceRead readCovariance(InputType type, const MessageView& v, const std::vector<InputField>& fields,
                                     double* R, std::string& why)
{
  const std::size_t n = fields.size();
  auto source = [&](CovarianceBlock b, int& dim) { return covarianceBlockOf(v, b, dim); };
  bool any = false;
  for (std::size_t i = 0; i < n; ++i)
  {
    const CovarianceSource a = covarianceOf(type, fields[i]);
    int dim = 0;
    const double* c = source(a.block, dim);
    if (!c)
    {
      why = fields[i].name + ": the message has no covariance";
      return CovarianceRead::FALLBACK;
    }
    const bool imu = a.block == CovarianceBlock::ORIENTATION || a.block == CovarianceBlock::ANGULAR ||
                     a.block == CovarianceBlock::ACCELERATION;
    if (imu && c[0] == -1.0)
    {
      why = fields[i].name + ": the message has no estimate of it (its covariance block starts with -1)";
      return CovarianceRead::DISABLED;
    }
    if (a.block == CovarianceBlock::POSITION_ENU && v.enu_cov_type == sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN)
    {
      why = "position_covariance_type UNKNOWN";
      return CovarianceRead::FALLBACK;
    }
    for (std::size_t j = 0; j < n; ++j)
    {
      const CovarianceSource b = covarianceOf(type, fields[j]);
      const double value = a.block == b.block ? c[a.index * dim + b.index] : 0.0;
      R[i * n + j] = value;
      any = any || value != 0.0;
    }
  }
  if (!any)
  {
    why = "covariance all zeros";
    return CovarianceRead::FALLBACK;
  }
  // R is row-major; its column-major reading is R', whose checks give the same verdict.
  const Eigen::Map<const Eigen::MatrixXd> M(R, static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  const CovarianceCheck check = checkCovariance(M, Definiteness::POSITIVE);
  if (check.ok())
    return CovarianceRead::OK;
  std::string names;
  for (const InputField& f : fields)
    names += (names.empty() ? "" : ", ") + f.name;
  why = "covariance of [" + names + "] is " +
        (check.problem == CovarianceCheck::Problem::NOT_FINITE      ? "not finite"
         : check.problem == CovarianceCheck::Problem::NOT_SYMMETRIC ? "not symmetric"
                                                                    : "not positive definite");
  return CovarianceRead::BAD;
}

/// NavSatFix to local ENU about a datum: the configured one, else the first valid fix.
class NavSatFixEnu
{
public:
  /// `datum`: [lat, lon, alt], or empty to take the first valid fix.
  explicit NavSatFixEnu(const std::vector<double>& datum)
  {
    if (datum.size() == 3)
      enu_ = std::make_unique<LocalEnu>(datum[0], datum[1], datum[2]);
  }
  /// ENU of a fix. False with `why` for status NO_FIX or a latitude or longitude that is not
  /// finite or out of range. A non-finite altitude (a 2-D fix) gives east and north at the datum's
  /// altitude and a NaN up, which readFields rejects only when `up` is selected. `new_datum` is
  /// set when this fix became the datum.
  bool convert(const sensor_msgs::NavSatFix& m, Eigen::Vector3d& out, std::string& why, bool& new_datum)
  {
    new_datum = false;
    if (m.status.status < sensor_msgs::NavSatStatus::STATUS_FIX)
    {
      why = "status NO_FIX (" + std::to_string(static_cast<int>(m.status.status)) + ")";
      return false;
    }
    if (!std::isfinite(m.latitude) || !std::isfinite(m.longitude) || std::fabs(m.latitude) > 90.0 ||
        std::fabs(m.longitude) > 180.0)
    {
      why = "latitude/longitude not finite or out of range (" + std::to_string(m.latitude) + ", " +
            std::to_string(m.longitude) + ")";
      return false;
    }
    const bool has_alt = std::isfinite(m.altitude);
    if (!enu_)
    {
      enu_ = std::make_unique<LocalEnu>(m.latitude, m.longitude, has_alt ? m.altitude : 0.0);
      new_datum = true;
    }
    out = enu_->forward(m.latitude, m.longitude, has_alt ? m.altitude : enu_->altitude());
    if (!has_alt)
      out.z() = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const LocalEnu* datum() const { return enu_.get(); }

private:
  std::unique_ptr<LocalEnu> enu_;
};

}  // namespace networked_estimation
