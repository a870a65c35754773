// Geodetic latitude/longitude/altitude (WGS84, degrees and metres) to local east-north-up metres
// about a datum, for NavSatFix inputs. The geodesy is GeographicLib's (LocalCartesian); this is a
// thin, validated wrapper so that the core and its tests do not depend on ROS.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <string>

namespace networked_estimation
{

class LocalEnu
{
public:
  /// Throws ConfigError naming `key` when the datum is not finite or out of range
  /// (latitude in [-90, 90], longitude in [-180, 180]).
  LocalEnu(double latitude, double longitude, double altitude, const std::string& key = "datum");
  ~LocalEnu();
  LocalEnu(const LocalEnu&) = delete;
  LocalEnu& operator=(const LocalEnu&) = delete;

  /// East, north, up (m) of a point; its values must be finite (the caller checks).
  Eigen::Vector3d forward(double latitude, double longitude, double altitude) const;
  /// Latitude, longitude, altitude of local (east, north, up).
  Eigen::Vector3d reverse(const Eigen::Vector3d& enu) const;

  double latitude() const { return lat_; }
  double longitude() const { return lon_; }
  double altitude() const { return alt_; }

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double lat_, lon_, alt_;
};

}  // namespace networked_estimation
