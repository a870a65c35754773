// NavSatAlignment (navsat_alignment.hpp): ENU <-> world_frame for GNSS fixes.
#include "networked_estimation/geodesy/navsat_alignment.hpp"

#include <GeographicLib/UTMUPS.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdio>
#include <limits>

namespace networked_estimation
{
namespace
{

bool finite(const Eigen::Vector3d& v)
{
  return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
}

bool finite(const BasePose& p)
{
  return finite(p.position) && std::isfinite(p.roll) && std::isfinite(p.pitch) && std::isfinite(p.yaw);
}

Eigen::Matrix3d rotationZ(double yaw)
{
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

std::string text(const Eigen::Vector3d& v)
{
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%g, %g, %g)", v.x(), v.y(), v.z());
  return buf;
}

}  // namespace

Eigen::Matrix3d rotationRpy(double roll, double pitch, double yaw)
{
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

double enuHeading(double yaw_reading, double magnetic_declination, double yaw_offset)
{
  const double h = yaw_reading + magnetic_declination + yaw_offset;
  return std::atan2(std::sin(h), std::cos(h));
}

bool utmOf(double latitude, double longitude, double altitude, UtmPoint& out, std::string& why)
{
  if (!std::isfinite(latitude) || !std::isfinite(longitude) || std::fabs(latitude) > 90.0 ||
      std::fabs(longitude) > 180.0 || !std::isfinite(altitude))
  {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "expected a finite latitude in [-90, 90], longitude in [-180, 180] and altitude, "
                  "found (%g, %g, %g)",
                  latitude, longitude, altitude);
    why = buf;
    return false;
  }
  double gamma = 0.0, k = 1.0;
  GeographicLib::UTMUPS::Forward(latitude, longitude, out.zone, out.northp, out.easting, out.northing, gamma, k);
  out.altitude = altitude;
  out.convergence = gamma * (3.14159265358979323846 / 180.0);
  return true;
}

bool NavSatAlignment::align(const Eigen::Vector3d& antenna_enu, double enu_heading, const BasePose& world,
                            const Eigen::Vector3d& lever_arm, std::string& why)
{
  Eigen::Vector3d antenna = antenna_enu;
  if (!std::isfinite(antenna.z()))
    antenna.z() = 0.0;  // a 2-D fix: the datum's altitude
  if (!finite(antenna) || !std::isfinite(enu_heading) || !finite(world) || !finite(lever_arm))
  {
    why = "alignment refused: not finite: antenna ENU " + text(antenna_enu) + ", heading " +
          std::to_string(enu_heading) + ", world position " + text(world.position) + ", world rpy " +
          text(Eigen::Vector3d(world.roll, world.pitch, world.yaw)) + " or lever arm " + text(lever_arm);
    return false;
  }
  const Eigen::Vector3d base_enu = antenna - rotationRpy(world.roll, world.pitch, enu_heading) * lever_arm;
  yaw_delta_ = std::atan2(std::sin(world.yaw - enu_heading), std::cos(world.yaw - enu_heading));
  translation_ = world.position - rotationZ(yaw_delta_) * base_enu;
  aligned_ = true;
  return true;
}

bool NavSatAlignment::toWorld(const Eigen::Vector3d& antenna_enu, const BasePose& orientation,
                              const Eigen::Vector3d& lever_arm, Eigen::Vector3d& base_world, std::string& why) const
{
  if (!aligned_)
  {
    why = "no ENU -> world_frame transform yet";
    return false;
  }
  const bool has_up = std::isfinite(antenna_enu.z());
  const Eigen::Vector3d antenna(antenna_enu.x(), antenna_enu.y(), has_up ? antenna_enu.z() : 0.0);
  if (!finite(antenna) || !std::isfinite(orientation.roll) || !std::isfinite(orientation.pitch) ||
      !std::isfinite(orientation.yaw) || !finite(lever_arm))
  {
    why = "not finite: antenna ENU " + text(antenna_enu) + ", orientation rpy " +
          text(Eigen::Vector3d(orientation.roll, orientation.pitch, orientation.yaw)) + " or lever arm " +
          text(lever_arm);
    return false;
  }
  base_world = rotationZ(yaw_delta_) * antenna + translation_ -
               rotationRpy(orientation.roll, orientation.pitch, orientation.yaw) * lever_arm;
  if (zero_altitude_)
    base_world.z() = 0.0;
  else if (!has_up)
    base_world.z() = std::numeric_limits<double>::quiet_NaN();
  return true;
}

bool NavSatAlignment::toEnu(const BasePose& world, const Eigen::Vector3d& lever_arm, Eigen::Vector3d& antenna_enu,
                            std::string& why) const
{
  if (!aligned_)
  {
    why = "no ENU -> world_frame transform yet";
    return false;
  }
  if (!finite(world) || !finite(lever_arm))
  {
    why = "not finite: world position " + text(world.position) + ", rpy " +
          text(Eigen::Vector3d(world.roll, world.pitch, world.yaw)) + " or lever arm " + text(lever_arm);
    return false;
  }
  const Eigen::Vector3d antenna_world = world.position + rotationRpy(world.roll, world.pitch, world.yaw) * lever_arm;
  antenna_enu = rotationZ(-yaw_delta_) * (antenna_world - translation_);
  return true;
}

Eigen::Matrix3d NavSatAlignment::covarianceToWorld(const Eigen::Matrix3d& enu_covariance) const
{
  const Eigen::Matrix3d R = rotationZ(yaw_delta_);
  return R * enu_covariance * R.transpose();
}

void NavSatAlignment::worldFromUtm(const UtmPoint& datum, double& yaw, Eigen::Vector3d& translation) const
{
  // utm_T_enu = (Rz(convergence), (E, N, alt)); world_T_utm = world_T_enu * inverse(utm_T_enu).
  const Eigen::Vector3d utm_origin(datum.easting, datum.northing, datum.altitude);
  const Eigen::Matrix3d enu_R_utm = rotationZ(-datum.convergence);
  yaw = std::atan2(std::sin(yaw_delta_ - datum.convergence), std::cos(yaw_delta_ - datum.convergence));
  translation = rotationZ(yaw_delta_) * (-(enu_R_utm * utm_origin)) + translation_;
}

}  // namespace networked_estimation
