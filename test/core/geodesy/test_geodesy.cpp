// LocalEnu: NavSatFix latitude/longitude/altitude to local ENU metres about a datum.
#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>

#include <cmath>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/geodesy/local_enu.hpp"

namespace ne = networked_estimation;

namespace
{

/// ENU of (lat, lon, alt) about a datum, the long way: both points to earth-centred coordinates
/// (GeographicLib's WGS84 Geocentric), then the difference rotated into the datum's east, north, up.
Eigen::Vector3d enuByHand(double lat0, double lon0, double alt0, double lat, double lon, double alt)
{
  const GeographicLib::Geocentric& g = GeographicLib::Geocentric::WGS84();
  Eigen::Vector3d a, b;
  g.Forward(lat0, lon0, alt0, a.x(), a.y(), a.z());
  g.Forward(lat, lon, alt, b.x(), b.y(), b.z());
  const double d = M_PI / 180.0, sp = std::sin(lat0 * d), cp = std::cos(lat0 * d), sl = std::sin(lon0 * d),
               cl = std::cos(lon0 * d);
  Eigen::Matrix3d R;
  R << -sl, cl, 0, -sp * cl, -sp * sl, cp, cp * cl, cp * sl, sp;
  return R * (b - a);
}

}  // namespace

TEST(LocalEnu, MatchesEarthCentredRotationAndRoundTrips)
{
  struct Case
  {
    double lat0, lon0, alt0, lat, lon, alt;
  };
  const Case cases[] = {
      {48.137, 11.575, 520.0, 48.1375, 11.5762, 523.5},  // 100 m scale
      {-33.86, 151.21, 10.0, -33.87, 151.19, 60.0},      // southern/eastern hemisphere, km scale
      {0.0, -0.0001, 0.0, 0.0001, 0.0001, 0.0},          // across the prime meridian at the equator
      {64.1, -21.9, 30.0, 64.1, -21.9, 30.0},            // the datum itself
  };
  for (const Case& c : cases)
  {
    const ne::LocalEnu enu(c.lat0, c.lon0, c.alt0);
    const Eigen::Vector3d e = enu.forward(c.lat, c.lon, c.alt);
    const Eigen::Vector3d ref = enuByHand(c.lat0, c.lon0, c.alt0, c.lat, c.lon, c.alt);
    // Exact maths on both sides; the tolerance is rounding of ~6.4e6 m earth-centred coordinates
    // (about 1e-9 m each) plus the local frame's small curvature terms, at most 1e-6 m at 2 km.
    EXPECT_LT((e - ref).norm(), 1e-6) << e.transpose() << " vs " << ref.transpose();
    const Eigen::Vector3d back = enu.reverse(e);
    EXPECT_NEAR(back.x(), c.lat, 1e-11);
    EXPECT_NEAR(back.y(), c.lon, 1e-11);
    EXPECT_NEAR(back.z(), c.alt, 1e-6);
  }
  // A physical check: 1e-4 degrees of latitude at the equator is 11.0574 m of meridian arc.
  const ne::LocalEnu eq(0.0, 0.0, 0.0);
  EXPECT_NEAR(eq.forward(1e-4, 0.0, 0.0).y(), 11.0574, 1e-3);
  EXPECT_NEAR(eq.forward(0.0, 1e-4, 0.0).x(), 11.1319, 1e-3);  // along the equator: a 6378137 m radius
}

TEST(LocalEnu, BadDatumNamesTheKey)
{
  try
  {
    ne::LocalEnu bad(91.0, 0.0, 0.0, "/est parameters: datum");
    ADD_FAILURE() << "accepted";
  }
  catch (const ne::ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("/est parameters: datum: expected [latitude in [-90, 90]"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("found [91, 0, 0]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ne::LocalEnu(0.0, std::nan(""), 0.0), ne::ConfigError);
  EXPECT_THROW(ne::LocalEnu(0.0, 181.0, 0.0), ne::ConfigError);
}
