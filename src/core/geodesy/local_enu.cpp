// LocalEnu (local_enu.hpp) over GeographicLib::LocalCartesian on the WGS84 ellipsoid.
#include "networked_estimation/geodesy/local_enu.hpp"

#include <GeographicLib/LocalCartesian.hpp>

#include <cmath>
#include <cstdio>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

struct LocalEnu::Impl
{
  GeographicLib::LocalCartesian frame;
};

LocalEnu::LocalEnu(double latitude, double longitude, double altitude, const std::string& key)
  : lat_(latitude), lon_(longitude), alt_(altitude)
{
  if (!std::isfinite(latitude) || !std::isfinite(longitude) || !std::isfinite(altitude) || std::fabs(latitude) > 90.0 ||
      std::fabs(longitude) > 180.0)
  {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "expected [latitude in [-90, 90], longitude in [-180, 180], altitude] (finite), "
                  "found [%g, %g, %g]",
                  latitude, longitude, altitude);
    throw ConfigError(key + ": " + buf);
  }
  impl_ = std::make_unique<Impl>();
  impl_->frame.Reset(latitude, longitude, altitude);
}

LocalEnu::~LocalEnu() = default;

Eigen::Vector3d LocalEnu::forward(double latitude, double longitude, double altitude) const
{
  Eigen::Vector3d enu;
  impl_->frame.Forward(latitude, longitude, altitude, enu.x(), enu.y(), enu.z());
  return enu;
}

Eigen::Vector3d LocalEnu::reverse(const Eigen::Vector3d& enu) const
{
  Eigen::Vector3d lla;
  impl_->frame.Reverse(enu.x(), enu.y(), enu.z(), lla.x(), lla.y(), lla.z());
  return lla;
}

}  // namespace networked_estimation
