// NavSatAlignment: GNSS fixes into world_frame as robot_localization's navsat_transform takes them
// (heading from an earth-referenced yaw + declination + yaw_offset, the antenna's lever arm, the
// datum's UTM coordinates).
#include <gtest/gtest.h>

#include <GeographicLib/UTMUPS.hpp>

#include <Eigen/Geometry>

#include <cmath>
#include <limits>

#include "networked_estimation/geodesy/local_enu.hpp"
#include "networked_estimation/geodesy/navsat_alignment.hpp"

namespace ne = networked_estimation;

namespace
{

constexpr double kDeg = M_PI / 180.0;

/// The scene of the tests: the robot's world frame (odom) has its x axis along base_link's heading
/// at start, which is 30 deg in ENU (north of east); the antenna is 0.5 m ahead of base_link; the
/// IMU reads the earth-referenced heading minus the declination (a magnetic heading) minus the
/// yaw_offset, so that adding both recovers 30 deg.
struct Scene
{
  double declination = 0.1, yaw_offset = -0.05;
  double heading = 30.0 * kDeg;  // base_link's true ENU heading at start
  Eigen::Vector3d lever{0.5, 0.0, 0.0};
  Eigen::Vector3d base_enu0{12.0, -4.0, 1.5};  // base_link in ENU at the first fix
  double imuReading() const { return heading - declination - yaw_offset; }
  /// ENU -> world (odom) of the truth: odom's origin at base_enu0, its x along `heading`.
  Eigen::Vector3d worldOf(const Eigen::Vector3d& enu) const
  {
    return Eigen::AngleAxisd(-heading, Eigen::Vector3d::UnitZ()) * (enu - base_enu0);
  }
  Eigen::Vector3d antennaEnu(const Eigen::Vector3d& base_enu, double enu_yaw) const
  {
    return base_enu + ne::rotationRpy(0, 0, enu_yaw) * lever;
  }
};

ne::NavSatAlignment aligned(const Scene& s, bool zero_altitude = false)
{
  ne::NavSatAlignment a(zero_altitude);
  ne::BasePose world0;  // odom at start: base_link at the origin, heading 0
  std::string why;
  const double theta = ne::enuHeading(s.imuReading(), s.declination, s.yaw_offset);
  EXPECT_NEAR(theta, s.heading, 1e-12);
  EXPECT_TRUE(a.align(s.antennaEnu(s.base_enu0, s.heading), theta, world0, s.lever, why)) << why;
  return a;
}

}  // namespace

TEST(NavSatAlignment, HeadingIsReadingPlusDeclinationPlusOffsetWrapped)
{
  EXPECT_NEAR(ne::enuHeading(0.2, 0.1, 0.3), 0.6, 1e-12);
  EXPECT_NEAR(ne::enuHeading(3.0, 0.2, 0.0), 3.2 - 2 * M_PI, 1e-12);  // wrapped into (-pi, pi]
  EXPECT_NEAR(ne::enuHeading(0.0, 0.0, M_PI / 2), M_PI / 2, 1e-12);   // an IMU reading 0 facing north
}

TEST(NavSatAlignment, FixesOfAKnownDriveLandOnTheWorldTrack)
{
  const Scene s;
  const ne::NavSatAlignment a = aligned(s);
  EXPECT_NEAR(a.yawDelta(), -s.heading, 1e-12);
  // The first fix: base_link at the world origin (the lever arm removed).
  std::string why;
  Eigen::Vector3d w;
  ASSERT_TRUE(a.toWorld(s.antennaEnu(s.base_enu0, s.heading), ne::BasePose(), s.lever, w, why)) << why;
  EXPECT_LT(w.norm(), 1e-9);
  // Later: base_link somewhere else, turned by 70 deg (world yaw 70 deg, ENU heading 100 deg).
  for (const double turn : {0.0, 70.0 * kDeg, -120.0 * kDeg, 179.0 * kDeg})
  {
    const Eigen::Vector3d base_enu = s.base_enu0 + Eigen::Vector3d(-7.0, 23.0, -0.5);
    ne::BasePose orientation;
    orientation.yaw = turn;
    ASSERT_TRUE(a.toWorld(s.antennaEnu(base_enu, s.heading + turn), orientation, s.lever, w, why)) << why;
    const Eigen::Vector3d truth = s.worldOf(base_enu);
    EXPECT_LT((w - truth).norm(), 1e-9) << "turn " << turn << ": " << w.transpose() << " vs " << truth.transpose();
    // and back: the antenna's ENU of the world pose
    ne::BasePose pose = orientation;
    pose.position = w;
    Eigen::Vector3d back;
    ASSERT_TRUE(a.toEnu(pose, s.lever, back, why)) << why;
    EXPECT_LT((back - s.antennaEnu(base_enu, s.heading + turn)).norm(), 1e-9);
  }
}

TEST(NavSatAlignment, WithoutTheLeverArmTheTrackIsOffByIt)
{
  // The lever arm matters: ignoring it puts base_link 0.5 m off when the robot has turned round.
  const Scene s;
  const ne::NavSatAlignment a = aligned(s);
  ne::BasePose turned;
  turned.yaw = M_PI;
  const Eigen::Vector3d base_enu = s.base_enu0 + Eigen::Vector3d(3.0, 3.0, 0.0);
  std::string why;
  Eigen::Vector3d with, without;
  ASSERT_TRUE(a.toWorld(s.antennaEnu(base_enu, s.heading + M_PI), turned, s.lever, with, why));
  ASSERT_TRUE(a.toWorld(s.antennaEnu(base_enu, s.heading + M_PI), turned, Eigen::Vector3d::Zero(), without, why));
  EXPECT_LT((with - s.worldOf(base_enu)).norm(), 1e-9);
  EXPECT_NEAR((without - with).norm(), 0.5, 1e-9);
}

TEST(NavSatAlignment, AlignedAtAnEstimatedPoseThatIsNotTheOrigin)
{
  // The first usable fix comes after the robot moved: world_T_enu from the estimate then.
  const Scene s;
  ne::BasePose world;
  world.position = Eigen::Vector3d(2.0, 1.0, 0.0);
  world.yaw = 20.0 * kDeg;  // and its ENU heading is then 50 deg
  ne::NavSatAlignment a;
  std::string why;
  const Eigen::Vector3d base_enu(5.0, 6.0, 0.0);
  ASSERT_TRUE(a.align(s.antennaEnu(base_enu, 50.0 * kDeg), 50.0 * kDeg, world, s.lever, why)) << why;
  EXPECT_NEAR(a.yawDelta(), -30.0 * kDeg, 1e-12);
  // A point 10 m east of base_link then: in world, 10 m along -30 deg from the world position.
  Eigen::Vector3d w;
  ne::BasePose o;
  o.yaw = world.yaw;
  ASSERT_TRUE(a.toWorld(s.antennaEnu(base_enu + Eigen::Vector3d(10, 0, 0), 50.0 * kDeg), o, s.lever, w, why));
  EXPECT_NEAR(w.x(), 2.0 + 10.0 * std::cos(-30.0 * kDeg), 1e-9);
  EXPECT_NEAR(w.y(), 1.0 + 10.0 * std::sin(-30.0 * kDeg), 1e-9);
}

TEST(NavSatAlignment, ZeroAltitudeAndTwoDimensionalFixes)
{
  const Scene s;
  const ne::NavSatAlignment flat = aligned(s, true), full = aligned(s, false);
  const Eigen::Vector3d base_enu = s.base_enu0 + Eigen::Vector3d(1.0, 2.0, 4.0);
  std::string why;
  Eigen::Vector3d w;
  ASSERT_TRUE(full.toWorld(s.antennaEnu(base_enu, s.heading), ne::BasePose(), s.lever, w, why));
  EXPECT_NEAR(w.z(), 4.0, 1e-9);
  ASSERT_TRUE(flat.toWorld(s.antennaEnu(base_enu, s.heading), ne::BasePose(), s.lever, w, why));
  EXPECT_EQ(w.z(), 0.0);
  EXPECT_LT((w.head<2>() - s.worldOf(base_enu).head<2>()).norm(), 1e-9);
  // A 2-D fix (no altitude): NaN up, unless zero_altitude.
  Eigen::Vector3d no_up = s.antennaEnu(base_enu, s.heading);
  no_up.z() = std::numeric_limits<double>::quiet_NaN();
  ASSERT_TRUE(full.toWorld(no_up, ne::BasePose(), s.lever, w, why));
  EXPECT_TRUE(std::isnan(w.z()));
  EXPECT_LT((w.head<2>() - s.worldOf(base_enu).head<2>()).norm(), 1e-9);
  ASSERT_TRUE(flat.toWorld(no_up, ne::BasePose(), s.lever, w, why));
  EXPECT_EQ(w.z(), 0.0);
}

TEST(NavSatAlignment, CovarianceRotatesFromEnuIntoWorld)
{
  // 4 m^2 along east, 1 m^2 along north: in odom (x along 30 deg ENU), east is at -30 deg.
  const Scene s;
  const ne::NavSatAlignment a = aligned(s);
  Eigen::Matrix3d enu = Eigen::Vector3d(4.0, 1.0, 9.0).asDiagonal();
  const Eigen::Matrix3d w = a.covarianceToWorld(enu);
  const double c = std::cos(-s.heading), sn = std::sin(-s.heading);
  EXPECT_NEAR(w(0, 0), 4.0 * c * c + 1.0 * sn * sn, 1e-12);
  EXPECT_NEAR(w(1, 1), 4.0 * sn * sn + 1.0 * c * c, 1e-12);
  EXPECT_NEAR(w(0, 1), (4.0 - 1.0) * c * sn, 1e-12);
  EXPECT_NEAR(w(1, 0), w(0, 1), 1e-15);
  EXPECT_NEAR(w(2, 2), 9.0, 1e-12);
  EXPECT_NEAR(w.trace(), enu.trace(), 1e-12);
  // The variance along the world direction of east is east's.
  const Eigen::Vector3d east_in_world(c, sn, 0.0);
  EXPECT_NEAR(east_in_world.dot(w * east_in_world), 4.0, 1e-12);
}

TEST(NavSatAlignment, LatitudeLongitudeToWorldAndBack)
{
  // Real fixes: a datum, fixes through LocalEnu, into world and back to latitude/longitude.
  const Scene s;
  const ne::LocalEnu datum(48.137, 11.575, 520.0);
  const Eigen::Vector3d antenna0 = datum.forward(48.1371, 11.5752, 521.0);
  ne::NavSatAlignment a;
  std::string why;
  ASSERT_TRUE(a.align(antenna0, s.heading, ne::BasePose(), s.lever, why)) << why;
  const Eigen::Vector3d fix = datum.forward(48.1379, 11.5761, 519.0);
  ne::BasePose o;
  o.yaw = 0.4;
  Eigen::Vector3d w, enu;
  ASSERT_TRUE(a.toWorld(fix, o, s.lever, w, why)) << why;
  o.position = w;
  ASSERT_TRUE(a.toEnu(o, s.lever, enu, why)) << why;
  const Eigen::Vector3d lla = datum.reverse(enu);
  EXPECT_NEAR(lla.x(), 48.1379, 1e-10);
  EXPECT_NEAR(lla.y(), 11.5761, 1e-10);
  EXPECT_NEAR(lla.z(), 519.0, 1e-6);
}

TEST(NavSatAlignment, WorldFromUtmPutsUtmCoordinatesOnTheWorldTrack)
{
  // world_T_utm applied to a point's UTM coordinates gives (within the UTM scale factor's and the
  // plane's error over 200 m: k - 1 <= 4e-4 of the distance, and the map projection's curvature,
  // under 0.1 m together) the world position of that point.
  const Scene s;
  const double lat0 = 48.137, lon0 = 11.575, alt0 = 520.0;  // 2.4 deg east of zone 32's meridian
  const ne::LocalEnu datum(lat0, lon0, alt0);
  ne::NavSatAlignment a;
  std::string why;
  ASSERT_TRUE(a.align(Eigen::Vector3d(0.5 * std::cos(s.heading), 0.5 * std::sin(s.heading), 0.0), s.heading,
                      ne::BasePose(), s.lever, why))
      << why;
  ne::UtmPoint u;
  ASSERT_TRUE(ne::utmOf(lat0, lon0, alt0, u, why)) << why;
  EXPECT_GT(std::fabs(u.convergence), 1.0 * kDeg);  // so that a missing rotation would show
  double yaw;
  Eigen::Vector3d t;
  a.worldFromUtm(u, yaw, t);
  const Eigen::Vector3d enu(120.0, 160.0, 0.0);
  const Eigen::Vector3d lla = datum.reverse(enu);
  ne::UtmPoint p;
  ASSERT_TRUE(ne::utmOf(lla.x(), lla.y(), lla.z(), p, why)) << why;
  const Eigen::Vector3d from_utm =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d(p.easting, p.northing, p.altitude) + t;
  Eigen::Vector3d from_enu;
  ASSERT_TRUE(a.toWorld(enu, ne::BasePose(), Eigen::Vector3d::Zero(), from_enu, why)) << why;
  EXPECT_LT((from_utm - from_enu).norm(), 0.1) << from_utm.transpose() << " vs " << from_enu.transpose();
}

TEST(NavSatAlignment, NonFiniteInputsAreRefusedWithTheirValues)
{
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  ne::NavSatAlignment a;
  std::string why;
  Eigen::Vector3d w;
  EXPECT_FALSE(a.toWorld(Eigen::Vector3d(1, 2, 3), ne::BasePose(), Eigen::Vector3d::Zero(), w, why));
  EXPECT_NE(why.find("no ENU -> world_frame transform yet"), std::string::npos) << why;
  EXPECT_FALSE(a.align(Eigen::Vector3d(nan, 0, 0), 0.0, ne::BasePose(), Eigen::Vector3d::Zero(), why));
  EXPECT_NE(why.find("nan"), std::string::npos) << why;
  EXPECT_FALSE(a.align(Eigen::Vector3d::Zero(), inf, ne::BasePose(), Eigen::Vector3d::Zero(), why));
  ne::BasePose bad;
  bad.yaw = nan;
  EXPECT_FALSE(a.align(Eigen::Vector3d::Zero(), 0.0, bad, Eigen::Vector3d::Zero(), why));
  EXPECT_FALSE(a.align(Eigen::Vector3d::Zero(), 0.0, ne::BasePose(), Eigen::Vector3d(0, inf, 0), why));
  EXPECT_FALSE(a.aligned());
  ASSERT_TRUE(a.align(Eigen::Vector3d::Zero(), 0.0, ne::BasePose(), Eigen::Vector3d::Zero(), why));
  EXPECT_FALSE(a.toWorld(Eigen::Vector3d(nan, 0, 0), ne::BasePose(), Eigen::Vector3d::Zero(), w, why));
  EXPECT_FALSE(a.toWorld(Eigen::Vector3d(0, 0, 0), bad, Eigen::Vector3d::Zero(), w, why));
  EXPECT_FALSE(a.toWorld(Eigen::Vector3d(0, 0, 0), ne::BasePose(), Eigen::Vector3d(nan, 0, 0), w, why));
  Eigen::Vector3d enu;
  EXPECT_FALSE(a.toEnu(bad, Eigen::Vector3d::Zero(), enu, why));
  ne::UtmPoint u;
  EXPECT_FALSE(ne::utmOf(nan, 0.0, 0.0, u, why));
  EXPECT_FALSE(ne::utmOf(91.0, 0.0, 0.0, u, why));
  EXPECT_NE(why.find("latitude"), std::string::npos) << why;
}
