// GNSS fixes taken into the robot's world frame the way robot_localization's navsat_transform does
// (docs/ros_interface.md "GNSS alignment"): the local ENU frame of the datum is tied to world_frame
// once, at the first usable fix, from the robot's earth-referenced heading then and its estimated
// world pose then; every later fix's antenna position goes through that transform and the
// antenna's lever arm is removed with the estimated orientation. Rotations between ENU and
// world_frame are about z only (both frames have z up). ROS-free: the nodelet feeds it numbers.
#pragma once

#include <Eigen/Core>

#include <string>

namespace networked_estimation
{

/// A pose of base_link: position (m) and roll, pitch, yaw (rad; R = Rz(yaw) Ry(pitch) Rx(roll)).
struct BasePose
{
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double roll = 0.0, pitch = 0.0, yaw = 0.0;
};

/// R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix3d rotationRpy(double roll, double pitch, double yaw);

/// The ENU heading of base_link (rad, counter-clockwise from east, wrapped to (-pi, pi]) from an
/// earth-referenced yaw reading: reading + magnetic_declination_radians + yaw_offset.
double enuHeading(double yaw_reading, double magnetic_declination, double yaw_offset);

/// UTM coordinates of a point (GeographicLib UTMUPS, the standard zone): easting, northing (m),
/// zone (0 = UPS), hemisphere, and the meridian convergence (rad: the angle from true north to grid
/// north, clockwise, so that a direction's UTM grid bearing is its true bearing minus it).
struct UtmPoint
{
  double easting = 0.0, northing = 0.0, altitude = 0.0, convergence = 0.0;
  int zone = 0;
  bool northp = true;
};
/// False with `why` for a latitude/longitude that is not finite or out of range.
bool utmOf(double latitude, double longitude, double altitude, UtmPoint& out, std::string& why);

class NavSatAlignment
{
public:
  explicit NavSatAlignment(bool zero_altitude = false) : zero_altitude_(zero_altitude) {}

  /// Ties ENU to world_frame: `antenna_enu`, the antenna's ENU position at the first usable fix
  /// (a non-finite up is taken as 0); `enu_heading`, base_link's ENU heading then (enuHeading);
  /// `world`, base_link's estimated world pose then; `lever_arm`, the antenna in base_link.
  /// world_T_enu = world_T_base * inverse(enu_T_base), enu_T_base having world's roll and pitch and
  /// the ENU heading. False with `why` (nothing changes) when an input is not finite.
  bool align(const Eigen::Vector3d& antenna_enu, double enu_heading, const BasePose& world,
             const Eigen::Vector3d& lever_arm, std::string& why);
  bool aligned() const { return aligned_; }

  /// base_link's world position from a fix: antenna_world = world_T_enu * antenna_enu, minus
  /// R(orientation) * lever_arm (the roll, pitch, yaw of `orientation`; its position is unused);
  /// with zero_altitude z = 0. A non-finite up (a 2-D fix) gives a NaN z unless zero_altitude.
  /// False with `why` before align(), or when east, north, the orientation or the lever arm is not
  /// finite.
  bool toWorld(const Eigen::Vector3d& antenna_enu, const BasePose& orientation, const Eigen::Vector3d& lever_arm,
               Eigen::Vector3d& base_world, std::string& why) const;
  /// The antenna's ENU position of a base_link world pose (the inverse of toWorld, z included).
  /// False with `why` before align() or for a pose that is not finite.
  bool toEnu(const BasePose& world, const Eigen::Vector3d& lever_arm, Eigen::Vector3d& antenna_enu,
             std::string& why) const;
  /// A position covariance from ENU into world_frame: R C R^T, R = Rz(yawDelta()).
  Eigen::Matrix3d covarianceToWorld(const Eigen::Matrix3d& enu_covariance) const;

  /// world_T_enu: its rotation about z (rad) and its translation (m).
  double yawDelta() const { return yaw_delta_; }
  const Eigen::Vector3d& translation() const { return translation_; }
  /// world_T_utm from world_T_enu and the UTM coordinates of the ENU origin (the datum):
  /// utm_T_enu rotates by the datum's meridian convergence and translates by its easting,
  /// northing and altitude (the UTM scale factor, within 0.1 % of 1, is not applied).
  void worldFromUtm(const UtmPoint& datum, double& yaw, Eigen::Vector3d& translation) const;

private:
  bool zero_altitude_ = false;
  bool aligned_ = false;
  double yaw_delta_ = 0.0;
  Eigen::Vector3d translation_ = Eigen::Vector3d::Zero();
};

}  // namespace networked_estimation
