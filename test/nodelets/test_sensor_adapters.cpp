// The Estimator's standard-message adapters (src/nodelets/sensor_adapters.hpp): every type's fields
// read the message values they name, the derived roll/pitch/yaw and ENU values are right, and bad
// values are refused naming the field. No ROS master: messages are plain structs.
#include <gtest/gtest.h>

#include <GeographicLib/LocalCartesian.hpp>
#include <tf2/LinearMath/Matrix3x3.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "networked_estimation/common/random.hpp"
#include "frame_transforms.hpp"
#include "gnss_alignment.hpp"
#include "input_message_types.hpp"
#include "input_preprocessing.hpp"
#include "networked_estimation/online/motion_sensors.hpp"
#include "odometry_output.hpp"
#include "tf_output.hpp"
#include "sensor_adapters.hpp"
#include "sensor_writers.hpp"
#include "transport_watch.hpp"

namespace ne = networked_estimation;

namespace
{

/// Reads every field of `type` from `m`; each must equal `expected(name)` exactly.
template <class M, class F>
void expectAllFields(ne::InputType type, const M& m, F expected)
{
  const std::vector<ne::InputField>& fields = ne::inputFields(type);
  ASSERT_FALSE(fields.empty());
  std::vector<double> y(fields.size());
  std::string why;
  ASSERT_TRUE(ne::readFields(ne::view(m), fields, y.data(), why)) << why;
  for (std::size_t i = 0; i < fields.size(); ++i)
    EXPECT_EQ(y[i], expected(fields[i].name)) << ne::toString(type) << " " << fields[i].name;
}

/// Fills x, y, z with distinct values from `base`.
template <class V>
void fill(V& v, double base)
{
  v.x = base + 0.1;
  v.y = base + 0.2;
  v.z = base + 0.3;
}

/// A unit quaternion of roll, pitch, yaw (tf2's fixed-axis convention).
geometry_msgs::Quaternion quat(double r, double p, double y)
{
  tf2::Quaternion q;
  q.setRPY(r, p, y);
  geometry_msgs::Quaternion out;
  out.x = q.x();
  out.y = q.y();
  out.z = q.z();
  out.w = q.w();
  return out;
}

}  // namespace

TEST(SensorAdapters, EveryFieldOfEveryTypeReadsItsValue)
{
  const double r = 0.3, p = -0.2, yaw = 2.5;
  nav_msgs::Odometry odom;
  fill(odom.pose.pose.position, 1.0);
  odom.pose.pose.orientation = quat(r, p, yaw);
  fill(odom.twist.twist.linear, 2.0);
  fill(odom.twist.twist.angular, 3.0);
  // The expected values by path, written out independently of the field table.
  auto poseValue = [&](const geometry_msgs::Pose& pose, const std::string& prefix, const std::string& name)
  {
    const std::string rest = name.substr(prefix.size());
    const std::map<std::string, double> values = {{"position.x", pose.position.x},
                                                  {"position.y", pose.position.y},
                                                  {"position.z", pose.position.z},
                                                  {"orientation.x", pose.orientation.x},
                                                  {"orientation.y", pose.orientation.y},
                                                  {"orientation.z", pose.orientation.z},
                                                  {"orientation.w", pose.orientation.w},
                                                  {"orientation.roll", r},
                                                  {"orientation.pitch", p},
                                                  {"orientation.yaw", yaw}};
    return values.count(rest) ? values.at(rest) : std::nan("");
  };
  auto twistValue = [](const geometry_msgs::Twist& t, const std::string& prefix, const std::string& name)
  {
    const std::string rest = name.substr(prefix.size());
    const std::map<std::string, double> values = {{"linear.x", t.linear.x},   {"linear.y", t.linear.y},
                                                  {"linear.z", t.linear.z},   {"angular.x", t.angular.x},
                                                  {"angular.y", t.angular.y}, {"angular.z", t.angular.z}};
    return values.count(rest) ? values.at(rest) : std::nan("");
  };
  // roll/pitch/yaw come back through a quaternion: equal to 1e-12, not bit for bit.
  auto near = [&](ne::InputType type, const auto& m, auto expected)
  {
    const std::vector<ne::InputField>& fields = ne::inputFields(type);
    std::vector<double> y(fields.size());
    std::string why;
    ASSERT_TRUE(ne::readFields(ne::view(m), fields, y.data(), why)) << why;
    for (std::size_t i = 0; i < fields.size(); ++i)
      EXPECT_NEAR(y[i], expected(fields[i].name), 1e-12) << ne::toString(type) << " " << fields[i].name;
  };
  near(ne::InputType::ODOMETRY, odom,
       [&](const std::string& n)
       {
         return n.rfind("pose.pose.", 0) == 0 ? poseValue(odom.pose.pose, "pose.pose.", n)
                                              : twistValue(odom.twist.twist, "twist.twist.", n);
       });
  geometry_msgs::PoseWithCovarianceStamped pc;
  pc.pose.pose = odom.pose.pose;
  near(ne::InputType::POSE_WITH_COVARIANCE, pc,
       [&](const std::string& n) { return poseValue(pc.pose.pose, "pose.pose.", n); });
  geometry_msgs::PoseStamped ps;
  ps.pose = odom.pose.pose;
  near(ne::InputType::POSE, ps, [&](const std::string& n) { return poseValue(ps.pose, "pose.", n); });
  geometry_msgs::TwistWithCovarianceStamped tc;
  tc.twist.twist = odom.twist.twist;
  expectAllFields(ne::InputType::TWIST_WITH_COVARIANCE, tc,
                  [&](const std::string& n) { return twistValue(tc.twist.twist, "twist.twist.", n); });
  geometry_msgs::TwistStamped ts;
  ts.twist = odom.twist.twist;
  expectAllFields(ne::InputType::TWIST, ts, [&](const std::string& n) { return twistValue(ts.twist, "twist.", n); });
  geometry_msgs::PointStamped pt;
  fill(pt.point, 4.0);
  expectAllFields(
      ne::InputType::POINT, pt,
      [&](const std::string& n) {
        return n == "point.x" ? pt.point.x : n == "point.y" ? pt.point.y : n == "point.z" ? pt.point.z : std::nan("");
      });
  sensor_msgs::Imu imu;
  imu.orientation = quat(r, p, yaw);
  fill(imu.angular_velocity, 5.0);
  fill(imu.linear_acceleration, 6.0);
  near(ne::InputType::IMU, imu,
       [&](const std::string& n)
       {
         const std::map<std::string, double> v = {{"orientation.x", imu.orientation.x},
                                                  {"orientation.y", imu.orientation.y},
                                                  {"orientation.z", imu.orientation.z},
                                                  {"orientation.w", imu.orientation.w},
                                                  {"orientation.roll", r},
                                                  {"orientation.pitch", p},
                                                  {"orientation.yaw", yaw},
                                                  {"angular_velocity.x", imu.angular_velocity.x},
                                                  {"angular_velocity.y", imu.angular_velocity.y},
                                                  {"angular_velocity.z", imu.angular_velocity.z},
                                                  {"linear_acceleration.x", imu.linear_acceleration.x},
                                                  {"linear_acceleration.y", imu.linear_acceleration.y},
                                                  {"linear_acceleration.z", imu.linear_acceleration.z}};
         return v.count(n) ? v.at(n) : std::nan("");
       });
  sensor_msgs::Range range;
  range.range = 7.25f;
  expectAllFields(ne::InputType::RANGE, range, [&](const std::string&) { return 7.25; });
  std_msgs::Float64 f;
  f.data = -8.5;
  expectAllFields(ne::InputType::FLOAT64, f, [&](const std::string&) { return -8.5; });
}

TEST(SensorAdapters, YawOfRandomRotationsAndANonUnitQuaternion)
{
  ne::Rng rng(3);
  const std::vector<ne::InputField> yaw = {ne::inputFieldFromString(ne::InputType::POSE, "pose.orientation.yaw", "k")};
  for (int i = 0; i < 200; ++i)
  {
    const double y0 = rng.uniform(-M_PI + 1e-6, M_PI - 1e-6), p0 = rng.uniform(-1.5, 1.5), r0 = rng.uniform(-3.0, 3.0);
    geometry_msgs::PoseStamped m;
    m.pose.orientation = quat(r0, p0, y0);
    const double scale = rng.uniform(0.5, 2.0);  // tf2 normalises; so do we
    m.pose.orientation.x *= scale;
    m.pose.orientation.y *= scale;
    m.pose.orientation.z *= scale;
    m.pose.orientation.w *= scale;
    double out = 0.0;
    std::string why;
    ASSERT_TRUE(ne::readFields(ne::view(m), yaw, &out, why)) << why;
    EXPECT_NEAR(out, y0, 1e-9);
  }
}

TEST(SensorAdapters, BadValuesAreRefusedNamingTheField)
{
  geometry_msgs::PoseStamped m;  // the zero quaternion is no rotation
  std::string why;
  double y[2];
  const std::vector<ne::InputField> f = {ne::inputFieldFromString(ne::InputType::POSE, "pose.position.x", "k"),
                                         ne::inputFieldFromString(ne::InputType::POSE, "pose.orientation.yaw", "k")};
  EXPECT_FALSE(ne::readFields(ne::view(m), f, y, why));
  EXPECT_NE(why.find("pose.orientation.yaw: the orientation is not a rotation"), std::string::npos) << why;
  m.pose.orientation.w = 1.0;
  m.pose.position.x = std::nan("");
  EXPECT_FALSE(ne::readFields(ne::view(m), f, y, why));
  EXPECT_NE(why.find("pose.position.x is not finite"), std::string::npos) << why;
  sensor_msgs::Range r;
  r.range = std::numeric_limits<float>::infinity();  // no return
  EXPECT_FALSE(ne::readFields(ne::view(r), ne::inputFields(ne::InputType::RANGE), y, why));
  EXPECT_NE(why.find("range is not finite (inf)"), std::string::npos) << why;
}

// NavSatFix -> ENU against GeographicLib's own LocalCartesian (forward, and reverse back to the
// fix), the first valid fix as the datum, and the refusals.
TEST(SensorAdapters, NavSatFixToEnu)
{
  ne::NavSatFixEnu pinned({48.137, 11.575, 520.0});
  ASSERT_NE(pinned.datum(), nullptr);
  GeographicLib::LocalCartesian ref(48.137, 11.575, 520.0);
  const double points[3][3] = {{48.1375, 11.5762, 523.5}, {48.13, 11.57, 500.0}, {48.2, 11.4, 600.0}};
  for (const auto& pt : points)
  {
    sensor_msgs::NavSatFix fix;
    fix.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
    fix.latitude = pt[0];
    fix.longitude = pt[1];
    fix.altitude = pt[2];
    Eigen::Vector3d enu;
    std::string why;
    bool new_datum = true;
    ASSERT_TRUE(pinned.convert(fix, enu, why, new_datum)) << why;
    EXPECT_FALSE(new_datum);
    double e, n, u, lat, lon, alt;
    ref.Forward(pt[0], pt[1], pt[2], e, n, u);
    EXPECT_NEAR(enu.x(), e, 1e-9);
    EXPECT_NEAR(enu.y(), n, 1e-9);
    EXPECT_NEAR(enu.z(), u, 1e-9);
    ref.Reverse(enu.x(), enu.y(), enu.z(), lat, lon, alt);
    EXPECT_NEAR(lat, pt[0], 1e-11);
    EXPECT_NEAR(lon, pt[1], 1e-11);
    EXPECT_NEAR(alt, pt[2], 1e-6);
  }
  ne::NavSatFixEnu first({});
  EXPECT_EQ(first.datum(), nullptr);
  sensor_msgs::NavSatFix fix;
  fix.status.status = sensor_msgs::NavSatStatus::STATUS_NO_FIX;
  fix.latitude = 10.0;
  Eigen::Vector3d enu;
  std::string why;
  bool new_datum = false;
  EXPECT_FALSE(first.convert(fix, enu, why, new_datum));
  EXPECT_NE(why.find("status NO_FIX (-1)"), std::string::npos) << why;
  EXPECT_EQ(first.datum(), nullptr);  // a rejected fix does not become the datum
  fix.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
  fix.longitude = std::nan("");
  EXPECT_FALSE(first.convert(fix, enu, why, new_datum));
  EXPECT_NE(why.find("latitude/longitude not finite or out of range"), std::string::npos) << why;
  fix.longitude = 20.0;
  fix.altitude = std::nan("");  // a 2-D fix: east and north only
  ASSERT_TRUE(first.convert(fix, enu, why, new_datum)) << why;
  EXPECT_TRUE(new_datum);
  EXPECT_EQ(enu.x(), 0.0);
  EXPECT_EQ(enu.y(), 0.0);
  EXPECT_TRUE(std::isnan(enu.z()));
  ne::MessageView v;
  v.enu = &enu;
  double y[3];
  EXPECT_TRUE(ne::readFields(
      v, {ne::inputFields(ne::InputType::NAVSATFIX)[0], ne::inputFields(ne::InputType::NAVSATFIX)[1]}, y, why));
  EXPECT_FALSE(ne::readFields(v, ne::inputFields(ne::InputType::NAVSATFIX), y, why));
  EXPECT_NE(why.find("up is not finite"), std::string::npos) << why;
}

// odometry/filtered: the mapped state entries and their block of P (row-major, pose order x y z
// roll pitch yaw, twist vx vy vz wx wy wz), a large variance and no correlation where unmapped.
TEST(OdometryOutput, MappedEntriesAndCovarianceBlocks)
{
  ne::Rng rng(5);
  const int n = 6;
  Eigen::VectorXd x(n);
  Eigen::MatrixXd L(n, n);
  for (int i = 0; i < n; ++i)
  {
    x(i) = rng.uniform(-2.0, 2.0);
    for (int j = 0; j < n; ++j)
      L(i, j) = rng.uniform(-1.0, 1.0);
  }
  const Eigen::MatrixXd P = L * L.transpose();
  ne::StateMap map;
  map.x = 3;
  map.y = 0;
  map.yaw = 5;
  map.vx = 1;
  map.yaw_rate = 2;  // state 4 is not published
  const nav_msgs::Odometry o = ne::toOdometry(x, P, map, ros::Time(12.5), "map", "base_link");
  EXPECT_EQ(o.header.frame_id, "map");
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_EQ(o.header.stamp, ros::Time(12.5));
  EXPECT_EQ(o.pose.pose.position.x, x(3));
  EXPECT_EQ(o.pose.pose.position.y, x(0));
  EXPECT_EQ(o.pose.pose.position.z, 0.0);
  const double yaw = 2.0 * std::atan2(o.pose.pose.orientation.z, o.pose.pose.orientation.w);
  EXPECT_NEAR(std::remainder(yaw - x(5), 2.0 * M_PI), 0.0, 1e-12);
  EXPECT_EQ(o.twist.twist.linear.x, x(1));
  EXPECT_EQ(o.twist.twist.angular.z, x(2));
  const int pose[6] = {3, 0, -1, -1, -1, 5}, twist[6] = {1, -1, -1, -1, -1, 2};
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)
    {
      const double pc = o.pose.covariance[static_cast<std::size_t>(6 * a + b)];
      const double tc = o.twist.covariance[static_cast<std::size_t>(6 * a + b)];
      EXPECT_EQ(pc, pose[a] >= 0 && pose[b] >= 0 ? P(pose[a], pose[b]) : (a == b ? ne::kUnmappedVariance : 0.0))
          << a << " " << b;
      EXPECT_EQ(tc, twist[a] >= 0 && twist[b] >= 0 ? P(twist[a], twist[b]) : (a == b ? ne::kUnmappedVariance : 0.0))
          << a << " " << b;
    }
}

// omni_3d's default mapping (every state it names): the full orientation from roll, pitch and yaw
// (REP-103 fixed axes), the angular velocity from vroll, vpitch, vyaw, and their blocks of P.
TEST(SensorAdapters, OdometryFullOrientation)
{
  const ne::StateMap map = ne::motionStateMap(ne::Motion::OMNI_3D);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(15);
  x << 1, 2, 3, 0.3, -0.2, 2.5, 0.4, 0.1, -0.05, 0.01, 0.02, 0.03, 0, 0, 0;
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(15, 15);
  for (int i = 0; i < 15; ++i)
    P(i, i) = 1.0 + i;
  P(3, 4) = P(4, 3) = 0.1;
  P(9, 11) = P(11, 9) = -0.2;
  const nav_msgs::Odometry o = ne::toOdometry(x, P, map, ros::Time(1.0), "odom", "base_link");
  tf2::Quaternion q(o.pose.pose.orientation.x, o.pose.pose.orientation.y, o.pose.pose.orientation.z,
                    o.pose.pose.orientation.w);
  double roll = 0.0, pitch = 0.0, yaw = 0.0;
  tf2::Matrix3x3(q).getRPY(roll, pitch, yaw);
  EXPECT_NEAR(roll, 0.3, 1e-12);
  EXPECT_NEAR(pitch, -0.2, 1e-12);
  EXPECT_NEAR(yaw, 2.5, 1e-12);
  EXPECT_EQ(o.pose.pose.position.z, 3.0);
  EXPECT_EQ(o.twist.twist.linear.z, -0.05);
  EXPECT_EQ(o.twist.twist.angular.x, 0.01);
  EXPECT_EQ(o.twist.twist.angular.y, 0.02);
  EXPECT_EQ(o.twist.twist.angular.z, 0.03);
  EXPECT_EQ(o.pose.covariance[3 * 6 + 3], 4.0);    // roll
  EXPECT_EQ(o.pose.covariance[3 * 6 + 4], 0.1);    // roll-pitch
  EXPECT_EQ(o.pose.covariance[5 * 6 + 5], 6.0);    // yaw
  EXPECT_EQ(o.twist.covariance[3 * 6 + 5], -0.2);  // vroll-vyaw
  EXPECT_EQ(o.twist.covariance[4 * 6 + 4], 11.0);  // vpitch
  for (std::size_t i = 0; i < 36; i += 7)
  {
    EXPECT_LT(o.pose.covariance[i], ne::kUnmappedVariance) << i;  // every axis estimated
    EXPECT_LT(o.twist.covariance[i], ne::kUnmappedVariance) << i;
  }
}

TEST(SensorAdapters, CommandTypes)
{
  geometry_msgs::Twist t;
  t.linear.x = 0.7;
  t.angular.z = -0.2;
  const std::vector<ne::InputField> f = {ne::inputFieldFromString(ne::InputType::TWIST_UNSTAMPED, "linear.x", "k"),
                                         ne::inputFieldFromString(ne::InputType::TWIST_UNSTAMPED, "angular.z", "k")};
  double u[2];
  std::string why;
  ASSERT_TRUE(ne::readFields(ne::view(t), f, u, why)) << why;
  EXPECT_EQ(u[0], 0.7);
  EXPECT_EQ(u[1], -0.2);
  std_msgs::Float64MultiArray a;
  a.data = {1.5, 2.5};
  const std::vector<ne::InputField> g = {ne::inputFieldFromString(ne::InputType::FLOAT64_ARRAY, "data[1]", "k"),
                                         ne::inputFieldFromString(ne::InputType::FLOAT64_ARRAY, "data[0]", "k")};
  ASSERT_TRUE(ne::readFields(ne::view(a), g, u, why)) << why;
  EXPECT_EQ(u[0], 2.5);
  EXPECT_EQ(u[1], 1.5);
  a.data = {1.5};
  EXPECT_FALSE(ne::readFields(ne::view(a), g, u, why));
  EXPECT_NE(why.find("data[1] is out of range: the message has 1 values"), std::string::npos) << why;
}

namespace
{

/// A fixed table of transforms target <- source for the frame tests.
ne::Frames tableFrames(const std::map<std::pair<std::string, std::string>, tf2::Transform>& table)
{
  ne::Frames f;
  f.world = "map";
  f.base = "base_link";
  f.lookup = [table](const std::string& target, const std::string& source, const ros::Time&, tf2::Transform& out,
                     std::string& why)
  {
    auto it = table.find({target, source});
    if (it == table.end())
    {
      why = "no transform " + target + " <- " + source;
      return false;
    }
    out = it->second;
    return true;
  };
  return f;
}

}  // namespace

// Measurements into the model's frames: positions and orientations into world (p' = R p + t,
// q' = q_T q), velocities into base_link (rotation only), an IMU's rates rotated and its
// orientation turned into base_link's; no transform when the frame is the target or empty; a
// missing transform refused naming both frames.
// relative: the first pose is the origin, later ones T0^-1 T (a robot that starts at (2, 1) facing
// +y and drives 1 m forward reads (1, 0) facing 0); the covariance rotated into the origin's axes.
TEST(InputPreprocessing, RelativePoses)
{
  auto yawOf = [](const geometry_msgs::Quaternion& q)
  {
    double r, p, y;
    tf2::Matrix3x3(ne::toTf(q)).getRPY(r, p, y);
    return y;
  };
  ne::SensorInput in;
  in.type = ne::InputType::ODOMETRY;
  in.relative = true;
  ne::InputMemory mem;
  std::string why;
  auto odom = [](double x, double y, double yaw)
  {
    nav_msgs::Odometry m;
    m.pose.pose.position.x = x;
    m.pose.pose.position.y = y;
    tf2::Quaternion q;
    q.setRPY(0.0, 0.0, yaw);
    ne::fromTf(q, m.pose.pose.orientation);
    m.pose.covariance[0] = 0.04;  // x
    m.pose.covariance[7] = 0.01;  // y
    return m;
  };
  nav_msgs::Odometry a = odom(2.0, 1.0, M_PI / 2);
  ASSERT_TRUE(ne::preprocess(in, mem, a, why)) << why;
  EXPECT_NEAR(a.pose.pose.position.x, 0.0, 1e-12);
  EXPECT_NEAR(a.pose.pose.position.y, 0.0, 1e-12);
  EXPECT_NEAR(yawOf(a.pose.pose.orientation), 0.0, 1e-12);
  EXPECT_NEAR(a.pose.covariance[0], 0.01, 1e-12);  // x and y swap under the quarter turn
  EXPECT_NEAR(a.pose.covariance[7], 0.04, 1e-12);
  nav_msgs::Odometry b = odom(2.0, 2.0, M_PI / 2 + 0.25);
  ASSERT_TRUE(ne::preprocess(in, mem, b, why)) << why;
  EXPECT_NEAR(b.pose.pose.position.x, 1.0, 1e-12);
  EXPECT_NEAR(b.pose.pose.position.y, 0.0, 1e-12);
  EXPECT_NEAR(yawOf(b.pose.pose.orientation), 0.25, 1e-12);
  // Without relative: untouched.
  ne::SensorInput plain = in;
  plain.relative = false;
  ne::InputMemory other;
  nav_msgs::Odometry c = odom(2.0, 2.0, 0.1);
  ASSERT_TRUE(ne::preprocess(plain, other, c, why));
  EXPECT_EQ(c.pose.pose.position.x, 2.0);
  // A first pose without an orientation cannot be the origin: refused, and the next one is.
  ne::InputMemory fresh;
  nav_msgs::Odometry zero = odom(5.0, 5.0, 0.0);
  zero.pose.pose.orientation = geometry_msgs::Quaternion();
  zero.pose.pose.orientation.w = 0.0;
  EXPECT_FALSE(ne::preprocess(in, fresh, zero, why));
  EXPECT_NE(why.find("relative: the first pose"), std::string::npos) << why;
  nav_msgs::Odometry d = odom(5.0, 5.0, 0.0);
  ASSERT_TRUE(ne::preprocess(in, fresh, d, why));
  EXPECT_NEAR(d.pose.pose.position.x, 0.0, 1e-12);
}

// remove_gravitational_acceleration: an IMU at rest reads +g along the world's up; rotated by its
// orientation, gravity leaves nothing, in any attitude; with a forward acceleration only that stays.
TEST(InputPreprocessing, GravityRemovedByTheOrientation)
{
  ne::SensorInput in;
  in.type = ne::InputType::IMU;
  in.remove_gravity = true;
  ne::InputMemory mem;
  std::string why;
  ne::Rng rng(7);
  for (int t = 0; t < 50; ++t)
  {
    tf2::Quaternion q;
    q.setRPY(rng.uniform(-M_PI, M_PI), rng.uniform(-1.5, 1.5), rng.uniform(-M_PI, M_PI));
    const tf2::Vector3 forward(0.7, 0.0, 0.0);  // body-frame acceleration
    const tf2::Vector3 reading = forward + tf2::Matrix3x3(q).transpose() * tf2::Vector3(0.0, 0.0, ne::kGravity);
    sensor_msgs::Imu m;
    ne::fromTf(q, m.orientation);
    ne::fromTf(reading, m.linear_acceleration);
    ASSERT_TRUE(ne::preprocess(in, mem, m, why)) << why;
    EXPECT_NEAR(m.linear_acceleration.x, 0.7, 1e-12);
    EXPECT_NEAR(m.linear_acceleration.y, 0.0, 1e-12);
    EXPECT_NEAR(m.linear_acceleration.z, 0.0, 1e-12);
  }
  sensor_msgs::Imu none;  // no orientation estimate: nothing to rotate gravity by
  none.orientation.w = 1.0;
  none.orientation_covariance[0] = -1.0;
  EXPECT_FALSE(ne::preprocess(in, mem, none, why));
  EXPECT_NE(why.find("remove_gravitational_acceleration: the message has no orientation"), std::string::npos);
  sensor_msgs::Imu zero;
  EXPECT_FALSE(ne::preprocess(in, mem, zero, why));
}

// differential: consecutive poses as a velocity in base_link: a robot facing +y that moves 0.2 m
// along y and turns 0.05 rad in 0.1 s drives at 2 m/s forward, turning at 0.5 rad/s; the first
// pose is only the reference; a stamp that does not advance is refused.
TEST(InputPreprocessing, DifferentialPosesAreVelocities)
{
  ne::InputMemory mem;
  std::string why;
  auto pose = [](double x, double y, double yaw)
  {
    geometry_msgs::Pose p;
    p.position.x = x;
    p.position.y = y;
    tf2::Quaternion q;
    q.setRPY(0.0, 0.0, yaw);
    ne::fromTf(q, p.orientation);
    return p;
  };
  ne::MessageView v;
  const geometry_msgs::Pose a = pose(1.0, 1.0, M_PI / 2), b = pose(1.0, 1.2, M_PI / 2 + 0.05);
  EXPECT_EQ(ne::differentiate(mem, &a, 10.0, v, why), ne::Differential::FIRST);
  EXPECT_EQ(v.linear, nullptr);
  ASSERT_EQ(ne::differentiate(mem, &b, 10.1, v, why), ne::Differential::OK) << why;
  // Read through the fields a differential sensor gets (position.x -> vx, yaw -> vyaw).
  const std::vector<ne::InputField> fields = {{"pose.pose.position.x", ne::Quantity::LINEAR_VELOCITY, 0},
                                              {"pose.pose.position.y", ne::Quantity::LINEAR_VELOCITY, 1},
                                              {"pose.pose.orientation.yaw", ne::Quantity::ANGULAR_VELOCITY, 2}};
  double y[3];
  ASSERT_TRUE(ne::readFields(v, fields, y, why)) << why;
  EXPECT_NEAR(y[0], 2.0, 1e-9);
  EXPECT_NEAR(y[1], 0.0, 1e-9);
  EXPECT_NEAR(y[2], 0.5, 1e-9);
  const geometry_msgs::Pose c = pose(1.0, 1.4, M_PI / 2);
  EXPECT_EQ(ne::differentiate(mem, &c, 10.1, v, why), ne::Differential::BAD);
  EXPECT_NE(why.find("is not after the previous pose's"), std::string::npos) << why;
  geometry_msgs::Pose zero = c;
  zero.orientation.w = 0.0;
  zero.orientation.z = 0.0;
  EXPECT_EQ(ne::differentiate(mem, &zero, 10.2, v, why), ne::Differential::BAD);
  EXPECT_EQ(ne::differentiate(mem, nullptr, 10.2, v, why), ne::Differential::BAD);
  // Turning through +-pi: the change, not the jump.
  ne::InputMemory turn;
  const geometry_msgs::Pose p1 = pose(0.0, 0.0, M_PI - 0.01), p2 = pose(0.0, 0.0, -M_PI + 0.01);
  ne::differentiate(turn, &p1, 1.0, v, why);
  ASSERT_EQ(ne::differentiate(turn, &p2, 1.02, v, why), ne::Differential::OK);
  EXPECT_NEAR(v.angular->z, 1.0, 1e-9);
}

TEST(FrameTransforms, IntoWorldAndBaseLink)
{
  tf2::Quaternion yaw90;
  yaw90.setRPY(0.0, 0.0, M_PI / 2);
  const tf2::Transform map_odom(yaw90, tf2::Vector3(1.0, 2.0, 0.5));
  tf2::Quaternion imu_rot;
  imu_rot.setRPY(M_PI, 0.0, 0.0);  // an IMU mounted upside down
  const tf2::Transform base_imu(imu_rot, tf2::Vector3(0.1, 0.0, 0.2));
  const ne::Frames f = tableFrames(
      {{{"map", "odom"}, map_odom}, {{"base_link", "imu_link"}, base_imu}, {{"base_link", "odom"}, map_odom}});
  std::string why;
  geometry_msgs::PoseStamped p;
  p.header.frame_id = "odom";
  p.pose.position.x = 3.0;
  p.pose.position.y = -1.0;
  tf2::Quaternion q;
  q.setRPY(0.0, 0.0, 0.3);
  ne::fromTf(q, p.pose.orientation);
  ASSERT_TRUE(ne::intoFrames(f, p, why)) << why;
  EXPECT_NEAR(p.pose.position.x, 1.0 + 1.0, 1e-12);  // R (3, -1) = (1, 3), plus (1, 2)
  EXPECT_NEAR(p.pose.position.y, 2.0 + 3.0, 1e-12);
  EXPECT_NEAR(p.pose.position.z, 0.5, 1e-12);
  double yaw = 0.0;
  const std::vector<ne::InputField> yawf = {ne::inputFieldFromString(ne::InputType::POSE, "pose.orientation.yaw", "k")};
  ASSERT_TRUE(ne::readFields(ne::view(p), yawf, &yaw, why)) << why;
  EXPECT_NEAR(yaw, 0.3 + M_PI / 2, 1e-12);
  // Already in the world frame, or no frame: untouched.
  geometry_msgs::PointStamped pt;
  pt.point.x = 4.0;
  pt.header.frame_id = "map";
  ASSERT_TRUE(ne::intoFrames(f, pt, why));
  EXPECT_EQ(pt.point.x, 4.0);
  pt.header.frame_id = "";
  ASSERT_TRUE(ne::intoFrames(f, pt, why));
  EXPECT_EQ(pt.point.x, 4.0);
  // A twist in the IMU's frame: rotated by pi about x.
  geometry_msgs::TwistStamped t;
  t.header.frame_id = "imu_link";
  t.twist.linear.y = 1.0;
  t.twist.angular.z = 0.5;
  ASSERT_TRUE(ne::intoFrames(f, t, why)) << why;
  EXPECT_NEAR(t.twist.linear.y, -1.0, 1e-12);
  EXPECT_NEAR(t.twist.angular.z, -0.5, 1e-12);
  // An IMU upside down: yaw rate and the z acceleration change sign; a level IMU orientation
  // (identity) becomes base_link rolled by pi.
  sensor_msgs::Imu imu;
  imu.header.frame_id = "imu_link";
  imu.angular_velocity.z = 0.2;
  imu.linear_acceleration.z = -9.81;
  imu.orientation.w = 1.0;
  ASSERT_TRUE(ne::intoFrames(f, imu, why)) << why;
  EXPECT_NEAR(imu.angular_velocity.z, -0.2, 1e-12);
  EXPECT_NEAR(imu.linear_acceleration.z, 9.81, 1e-12);
  double roll = 0.0;
  const std::vector<ne::InputField> rollf = {ne::inputFieldFromString(ne::InputType::IMU, "orientation.roll", "k")};
  ASSERT_TRUE(ne::readFields(ne::view(imu), rollf, &roll, why)) << why;
  EXPECT_NEAR(std::fabs(roll), M_PI, 1e-12);
  // Odometry: the pose from its header frame into map, the twist from child_frame_id into base_link.
  nav_msgs::Odometry o;
  o.header.frame_id = "odom";
  o.child_frame_id = "base_link";
  o.pose.pose.orientation.w = 1.0;
  o.twist.twist.linear.x = 0.7;
  ASSERT_TRUE(ne::intoFrames(f, o, why)) << why;
  EXPECT_NEAR(o.pose.pose.position.x, 1.0, 1e-12);
  EXPECT_EQ(o.twist.twist.linear.x, 0.7);  // already in base_link
  // A missing transform.
  geometry_msgs::PoseStamped lost;
  lost.header.frame_id = "camera";
  why.clear();
  EXPECT_FALSE(ne::intoFrames(f, lost, why));
  EXPECT_EQ(why, "no transform map <- camera");
}

// The tf plan when the estimate drives base_link: never a second parent.
TEST(TfOutput, NeverASecondParentForBaseLink)
{
  using K = ne::TfPlan::Kind;
  const std::string me = "/manager";
  // The estimate's own frame (default child <algorithm>_estimate): always direct.
  EXPECT_EQ(ne::planTf("map", "odom", "base_link", "kfio_estimate", "odom", "/wheels", me).kind, K::DIRECT);
  // base_link without a parent, or parented by us: direct world -> base_link.
  EXPECT_EQ(ne::planTf("odom", "odom", "base_link", "base_link", "", "", me).kind, K::DIRECT);
  EXPECT_EQ(ne::planTf("odom", "odom", "base_link", "base_link", "odom", me, me).kind, K::DIRECT);
  // world map and someone's odom -> base_link: map -> odom.
  EXPECT_EQ(ne::planTf("map", "odom", "base_link", "base_link", "odom", "/wheels", me).kind, K::MAP_TO_ODOM);
  // world odom and someone else's odom -> base_link, or another parent: nothing, and why.
  const ne::TfPlan none = ne::planTf("odom", "odom", "base_link", "base_link", "odom", "/wheels", me);
  EXPECT_EQ(none.kind, K::NONE);
  EXPECT_EQ(none.reason, "odom -> base_link is published by /wheels: not giving base_link a second parent (odom)");
  EXPECT_EQ(ne::planTf("map", "odom", "base_link", "base_link", "world", "/other", me).kind, K::NONE);
  // map -> odom composes to the estimate: (map <- odom)(odom <- base) = map <- base.
  tf2::Quaternion a, b;
  a.setRPY(0, 0, 0.4);
  b.setRPY(0, 0, -1.1);
  const tf2::Transform map_base(a, tf2::Vector3(3, 1, 0)), odom_base(b, tf2::Vector3(-2, 0.5, 0));
  const tf2::Transform back = ne::mapToOdom(map_base, odom_base) * odom_base;
  EXPECT_NEAR((back.getOrigin() - map_base.getOrigin()).length(), 0.0, 1e-12);
  EXPECT_NEAR(back.getRotation().angleShortestPath(map_base.getRotation()), 0.0, 1e-7);
}

// The Estimator's own transforms come back on /tf without a publisher's name (in-process): it knows
// them by what it sent, so base_link's parent from another publisher is told apart from its own,
// whatever their names; another's parent counts for 10 s (a static one for good).
TEST(TfOutput, OwnTransformsAreRecognised)
{
  ne::OwnTransforms own;
  ne::ForeignParent foreign;
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "odom";
  t.child_frame_id = "base_link";
  t.transform.rotation.w = 1.0;
  for (int k = 1; k <= 300; ++k)
  {
    t.header.stamp.fromSec(100.0 + 0.05 * k);
    t.transform.translation.x = 0.01 * k;
    own.sent(t);
    foreign.saw(t, "base_link", own, "unknown_publisher", 1.0 + 0.05 * k, false);
  }
  EXPECT_EQ(foreign.at(20.0), "");  // only our own so far
  EXPECT_TRUE(own.ours(t));
  // Another publisher's odom -> base_link at one of our stamps but another value: not ours.
  geometry_msgs::TransformStamped wheels = t;
  wheels.transform.translation.x += 0.3;
  EXPECT_FALSE(own.ours(wheels));
  foreign.saw(wheels, "base_link", own, "/wheel_odometry", 20.0, false);
  EXPECT_EQ(foreign.at(25.0), "odom");
  EXPECT_EQ(foreign.publisher, "/wheel_odometry");
  EXPECT_EQ(foreign.at(30.5), "");  // 10 s without another one
  // Transforms of other frames do not count; an in-process publisher is named as such.
  geometry_msgs::TransformStamped other = wheels;
  other.child_frame_id = "laser";
  foreign.saw(other, "base_link", own, "/x", 40.0, false);
  EXPECT_EQ(foreign.at(40.0), "");
  wheels.header.frame_id = "base_footprint";
  foreign.saw(wheels, "base_link", own, "unknown_publisher", 41.0, true);
  EXPECT_EQ(foreign.at(1e9), "base_footprint");
  EXPECT_EQ(foreign.publisher, "another publisher in this process");
  // The oldest of more than 200 sent transforms is forgotten.
  t.header.stamp.fromSec(100.05);
  t.transform.translation.x = 0.01;
  EXPECT_FALSE(own.ours(t));
}

// covariance: message. R of the selected fields from the message's blocks (fields of different
// blocks uncorrelated), ROS's "unknown" conventions as a fallback to the model's R, and bad
// covariances refused naming the fields; rotated with the frame (diag(R, R) for a 6 x 6 pose).
TEST(SensorAdapters, MessageCovariances)
{
  nav_msgs::Odometry o;
  for (int i = 0; i < 6; ++i)
  {
    o.pose.covariance[static_cast<std::size_t>(7 * i)] = 1.0 + i;  // diagonal 1..6
    o.twist.covariance[static_cast<std::size_t>(7 * i)] = 10.0 + i;
  }
  o.pose.covariance[1] = o.pose.covariance[6] = 0.5;  // cov(x, y)
  o.pose.pose.orientation.w = 1.0;
  const std::vector<ne::InputField> f = {
      ne::inputFieldFromString(ne::InputType::ODOMETRY, "pose.pose.position.y", "k"),
      ne::inputFieldFromString(ne::InputType::ODOMETRY, "pose.pose.position.x", "k"),
      ne::inputFieldFromString(ne::InputType::ODOMETRY, "twist.twist.angular.z", "k")};
  double R[9];
  std::string why;
  ASSERT_EQ(ne::readCovariance(ne::InputType::ODOMETRY, ne::view(o), f, R, why), ne::CovarianceRead::OK) << why;
  const double expect[9] = {2.0, 0.5, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 15.0};
  for (int i = 0; i < 9; ++i)
    EXPECT_EQ(R[i], expect[i]) << i;
  // Rotated into a world frame yawed by 90 degrees: x and y swap their variances.
  tf2::Quaternion yaw90;
  yaw90.setRPY(0.0, 0.0, M_PI / 2);
  ne::Frames frames = tableFrames({{{"map", "odom"}, tf2::Transform(yaw90, tf2::Vector3(0, 0, 0))}});
  geometry_msgs::PoseWithCovarianceStamped p;
  p.header.frame_id = "odom";
  p.pose = o.pose;
  ASSERT_TRUE(ne::intoFrames(frames, p, why)) << why;
  const std::vector<ne::InputField> xy = {
      ne::inputFieldFromString(ne::InputType::POSE_WITH_COVARIANCE, "pose.pose.position.x", "k"),
      ne::inputFieldFromString(ne::InputType::POSE_WITH_COVARIANCE, "pose.pose.position.y", "k")};
  double R2[4];
  ASSERT_EQ(ne::readCovariance(ne::InputType::POSE_WITH_COVARIANCE, ne::view(p), xy, R2, why), ne::CovarianceRead::OK);
  EXPECT_NEAR(R2[0], 2.0, 1e-12);   // var x' = var y
  EXPECT_NEAR(R2[3], 1.0, 1e-12);   // var y' = var x
  EXPECT_NEAR(R2[1], -0.5, 1e-12);  // cov(x', y') = -cov(x, y)
  // IMU: a leading -1 means "no estimate": the block is disabled (disabledBlock), for every
  // covariance mode, and only for the fields of that block.
  sensor_msgs::Imu imu;
  imu.orientation.w = 1.0;
  imu.angular_velocity_covariance[0] = -1.0;
  const std::vector<ne::InputField> gz = {ne::inputFieldFromString(ne::InputType::IMU, "angular_velocity.z", "k")};
  EXPECT_EQ(ne::readCovariance(ne::InputType::IMU, ne::view(imu), gz, R, why), ne::CovarianceRead::DISABLED);
  EXPECT_NE(why.find("angular_velocity.z: the message has no estimate of it"), std::string::npos) << why;
  EXPECT_TRUE(ne::disabledBlock(ne::InputType::IMU, ne::view(imu), gz, why));
  const std::vector<ne::InputField> yaw = {ne::inputFieldFromString(ne::InputType::IMU, "orientation.yaw", "k"),
                                           ne::inputFieldFromString(ne::InputType::IMU, "linear_acceleration.x", "k")};
  EXPECT_FALSE(ne::disabledBlock(ne::InputType::IMU, ne::view(imu), yaw, why));
  imu.orientation_covariance[0] = -1.0;           // an IMU without an orientation estimate
  imu.orientation = geometry_msgs::Quaternion();  // often all zeros then: never read
  EXPECT_TRUE(ne::disabledBlock(ne::InputType::IMU, ne::view(imu), yaw, why));
  EXPECT_NE(why.find("orientation.yaw: the message has no estimate of it"), std::string::npos) << why;
  imu.orientation_covariance[0] = 0.0;
  imu.linear_acceleration_covariance[0] = -1.0;
  EXPECT_TRUE(ne::disabledBlock(ne::InputType::IMU, ne::view(imu), yaw, why));
  EXPECT_NE(why.find("linear_acceleration.x"), std::string::npos) << why;
  // Other types have no such convention: an Odometry covariance starting with -1 is just bad.
  EXPECT_FALSE(ne::disabledBlock(ne::InputType::ODOMETRY, ne::view(nav_msgs::Odometry()),
                                 {ne::inputFieldFromString(ne::InputType::ODOMETRY, "pose.pose.position.x", "k")},
                                 why));
  imu.orientation.w = 1.0;
  imu.angular_velocity_covariance = {};  // all zeros: unknown too
  EXPECT_EQ(ne::readCovariance(ne::InputType::IMU, ne::view(imu), gz, R, why), ne::CovarianceRead::FALLBACK);
  EXPECT_EQ(why, "covariance all zeros");
  imu.angular_velocity_covariance[8] = -0.1;  // negative variance
  EXPECT_EQ(ne::readCovariance(ne::InputType::IMU, ne::view(imu), gz, R, why), ne::CovarianceRead::BAD);
  EXPECT_NE(why.find("covariance of [angular_velocity.z] is not positive definite"), std::string::npos) << why;
  // Asymmetric and non-finite.
  o.pose.covariance[1] = 0.7;
  EXPECT_EQ(ne::readCovariance(ne::InputType::ODOMETRY, ne::view(o), f, R, why), ne::CovarianceRead::BAD);
  EXPECT_NE(why.find("is not symmetric"), std::string::npos) << why;
  o.pose.covariance[1] = 0.5;
  o.twist.covariance[35] = std::nan("");
  EXPECT_EQ(ne::readCovariance(ne::InputType::ODOMETRY, ne::view(o), f, R, why), ne::CovarianceRead::BAD);
  EXPECT_NE(why.find("is not finite"), std::string::npos) << why;
  // NavSatFix: the type UNKNOWN falls back.
  ne::MessageView v;
  const Eigen::Vector3d enu(1, 2, 3);
  const double cov[9] = {4, 0, 0, 0, 9, 0, 0, 0, 16};
  v.enu = &enu;
  v.enu_cov = cov;
  v.enu_cov_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_UNKNOWN;
  const std::vector<ne::InputField> en = {ne::inputFields(ne::InputType::NAVSATFIX)[0],
                                          ne::inputFields(ne::InputType::NAVSATFIX)[1]};
  EXPECT_EQ(ne::readCovariance(ne::InputType::NAVSATFIX, v, en, R, why), ne::CovarianceRead::FALLBACK);
  v.enu_cov_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_DIAGONAL_KNOWN;
  ASSERT_EQ(ne::readCovariance(ne::InputType::NAVSATFIX, v, en, R, why), ne::CovarianceRead::OK);
  EXPECT_EQ(R[0], 4.0);
  EXPECT_EQ(R[3], 9.0);
}

// The PlantSimulator's writers (sensor_writers.hpp) against the Estimator's readers: for every
// output type, y written into random selections of its fields and R into its covariance read back
// as y exactly and R exactly (Range: y in single precision); other diagonal entries of a used
// block say "not measured" (1e6) and an unused Imu block has its leading -1.
namespace
{

template <class M>
void expectRoundTrip(ne::InputType type, const std::vector<std::string>& names, ne::Rng& rng)
{
  std::vector<ne::InputField> fields;
  for (const std::string& n : names)
    fields.push_back(ne::inputFieldFromString(type, n, "test"));
  const std::size_t n = fields.size();
  std::vector<double> y(n), R(n * n, 0.0);
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i)
  {
    y[i] = 2.0 * rng.uniform() - 1.0;  // a roll/pitch/yaw in (-1, 1) rad round-trips through its quaternion
    for (std::size_t j = 0; j <= i; ++j)
      L(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) =
          i == j ? 0.5 + rng.uniform() : 0.3 * rng.uniform();
  }
  // Fields of one covariance block are correlated, of different blocks not (the reader's rule).
  const Eigen::MatrixXd S = L * L.transpose();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j)
      if (ne::covarianceOf(type, fields[i]).block == ne::covarianceOf(type, fields[j]).block)
        R[i * n + j] = S(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
  M m;
  const ne::MessageSlots s = ne::slots(m);
  ne::writeFields(s, fields, y.data());
  ne::writeCovariance(type, s, fields, R.data());
  std::vector<double> back(n), Rback(n * n);
  std::string why;
  ASSERT_TRUE(ne::readFields(ne::view(m), fields, back.data(), why)) << why;
  const bool rpy = std::any_of(fields.begin(), fields.end(),
                               [](const ne::InputField& f) { return f.quantity == ne::Quantity::ORIENTATION_RPY; });
  for (std::size_t i = 0; i < n; ++i)
  {
    if (type == ne::InputType::RANGE)
      EXPECT_EQ(back[i], static_cast<double>(static_cast<float>(y[i])));
    else if (rpy && fields[i].quantity == ne::Quantity::ORIENTATION_RPY)
      EXPECT_NEAR(back[i], y[i], 1e-12) << fields[i].name;  // through a quaternion: rounding only
    else
      EXPECT_EQ(back[i], y[i]) << ne::toString(type) << " " << fields[i].name;
  }
  bool has_cov = true;
  for (const ne::InputField& f : fields)
    has_cov = has_cov && ne::covarianceOf(type, f).block != ne::CovarianceBlock::NONE;
  if (!has_cov)
    return;
  ASSERT_EQ(ne::readCovariance(type, ne::view(m), fields, Rback.data(), why), ne::CovarianceRead::OK) << why;
  for (std::size_t i = 0; i < n * n; ++i)
    EXPECT_EQ(Rback[i], R[i]) << ne::toString(type) << " entry " << i;
}

}  // namespace

TEST(SensorWriters, EveryOutputTypeRoundTripsThroughItsReader)
{
  ne::Rng rng(5);
  for (int trial = 0; trial < 20; ++trial)
  {
    expectRoundTrip<nav_msgs::Odometry>(ne::InputType::ODOMETRY,
                                        {"pose.pose.position.y", "pose.pose.position.x", "twist.twist.linear.x",
                                         "pose.pose.orientation.yaw", "twist.twist.angular.z"},
                                        rng);
    expectRoundTrip<geometry_msgs::PoseWithCovarianceStamped>(
        ne::InputType::POSE_WITH_COVARIANCE,
        {"pose.pose.position.x", "pose.pose.position.z", "pose.pose.orientation.roll"}, rng);
    expectRoundTrip<geometry_msgs::PoseStamped>(ne::InputType::POSE, {"pose.position.x", "pose.orientation.yaw"}, rng);
    expectRoundTrip<geometry_msgs::PointStamped>(ne::InputType::POINT, {"point.z", "point.x"}, rng);
    expectRoundTrip<geometry_msgs::TwistWithCovarianceStamped>(ne::InputType::TWIST_WITH_COVARIANCE,
                                                               {"twist.twist.linear.y", "twist.twist.angular.z"}, rng);
    expectRoundTrip<geometry_msgs::TwistStamped>(ne::InputType::TWIST, {"twist.linear.x"}, rng);
    expectRoundTrip<sensor_msgs::Imu>(
        ne::InputType::IMU, {"orientation.yaw", "angular_velocity.z", "linear_acceleration.x", "linear_acceleration.y"},
        rng);
    expectRoundTrip<sensor_msgs::Range>(ne::InputType::RANGE, {"range"}, rng);
  }
  // The entries y does not set: "not measured" in a used block, -1 in an unused Imu block.
  sensor_msgs::Imu imu;
  const std::vector<ne::InputField> gz = {ne::inputFieldFromString(ne::InputType::IMU, "angular_velocity.z", "k")};
  const double y = 0.25, R = 0.01;
  ne::writeFields(ne::slots(imu), gz, &y);
  ne::writeCovariance(ne::InputType::IMU, ne::slots(imu), gz, &R);
  EXPECT_EQ(imu.orientation.w, 1.0);  // no orientation field: the identity, a valid quaternion
  EXPECT_EQ(imu.angular_velocity_covariance[8], 0.01);
  EXPECT_EQ(imu.angular_velocity_covariance[0], ne::kUnmeasuredVariance);
  EXPECT_EQ(imu.angular_velocity_covariance[1], 0.0);
  EXPECT_EQ(imu.orientation_covariance[0], -1.0);
  EXPECT_EQ(imu.linear_acceleration_covariance[0], -1.0);
}

TEST(SensorWriters, FixAtLocalEnuReadsBackThroughTheDatum)
{
  const ne::LocalEnu datum(48.137, 11.575, 520.0);
  const std::vector<ne::InputField> en = {ne::inputFieldFromString(ne::InputType::NAVSATFIX, "north", "k"),
                                          ne::inputFieldFromString(ne::InputType::NAVSATFIX, "east", "k")};
  const double y[2] = {-1234.5, 876.25}, R[4] = {4.0, 0.5, 0.5, 9.0};
  Eigen::Vector3d enu = Eigen::Vector3d::Zero();
  ne::writeFields(ne::MessageSlots(), en, y, &enu);
  EXPECT_EQ(enu, Eigen::Vector3d(876.25, -1234.5, 0.0));
  const sensor_msgs::NavSatFix f = ne::fixAt(datum, enu, en, R);
  EXPECT_EQ(f.status.status, sensor_msgs::NavSatStatus::STATUS_FIX);
  EXPECT_EQ(f.position_covariance_type, sensor_msgs::NavSatFix::COVARIANCE_TYPE_KNOWN);
  // GeographicLib's own forward of the fix, independently of the adapters.
  const GeographicLib::LocalCartesian lc(48.137, 11.575, 520.0);
  double e = 0, n = 0, u = 0;
  lc.Forward(f.latitude, f.longitude, f.altitude, e, n, u);
  EXPECT_NEAR(e, 876.25, 1e-8);  // km-scale round trip of GeographicLib: nanometres
  EXPECT_NEAR(n, -1234.5, 1e-8);
  EXPECT_NEAR(u, 0.0, 1e-8);
  // Through the Estimator's reader: NavSatFixEnu about the same datum, then the fields and R.
  ne::NavSatFixEnu reader(std::vector<double>{48.137, 11.575, 520.0});
  Eigen::Vector3d local;
  std::string why;
  bool new_datum = false;
  ASSERT_TRUE(reader.convert(f, local, why, new_datum)) << why;
  ne::MessageView v;
  v.enu = &local;
  v.enu_cov = f.position_covariance.data();
  v.enu_cov_type = f.position_covariance_type;
  double back[2], Rback[4];
  ASSERT_TRUE(ne::readFields(v, en, back, why)) << why;
  EXPECT_NEAR(back[0], -1234.5, 1e-8);
  EXPECT_NEAR(back[1], 876.25, 1e-8);
  ASSERT_EQ(ne::readCovariance(ne::InputType::NAVSATFIX, v, en, Rback, why), ne::CovarianceRead::OK) << why;
  for (int i = 0; i < 4; ++i)
    EXPECT_EQ(Rback[i], R[i]) << i;
  EXPECT_EQ(f.position_covariance[8], ne::kUnmeasuredVariance);  // up: not measured
}

// transport: udp asks roscpp for UDPROS first and TCPROS second; tcp for TCPROS alone; tcp_nodelay
// reaches the TCPROS connection either way.
TEST(InputTransport, Hints)
{
  ne::InputTransport t;
  ros::TransportHints h = ne::transportHints(t);
  EXPECT_EQ(h.getTransports(), (std::vector<std::string>{"TCP"}));
  EXPECT_TRUE(h.getTCPNoDelay());
  t.transport = ne::Transport::UDP;
  t.tcp_nodelay = false;
  h = ne::transportHints(t);
  EXPECT_EQ(h.getTransports(), (std::vector<std::string>{"UDP", "TCP"}));
  EXPECT_FALSE(h.getTCPNoDelay());
}

// What an input's diagnostic says of its connections (this process's getBusInfo rows): UDPROS, a
// fallback to TCPROS naming the publisher, in-process, none yet; other topics do not count.
TEST(InputTransport, StatusFromTheBusInfo)
{
  ne::InputTransport udp;
  udp.transport = ne::Transport::UDP;
  const std::vector<ne::InboundLink> links = {{"/odom", "http://robot:4001/", "UDPROS"},
                                              {"/fix", "http://py:4002/", "TCPROS"},
                                              {"/fix", "http://robot:4001/", "UDPROS"},
                                              {"/imu", "http://local:4003/", "INTRAPROCESS"},
                                              {"/odom_other", "http://py:4002/", "TCPROS"}};
  ne::TransportStatus s = ne::transportStatus(udp, "/odom", links);
  EXPECT_EQ(s.text, "udp: UDPROS from 1 publisher");
  EXPECT_TRUE(s.fallbacks.empty());
  s = ne::transportStatus(udp, "/fix", links);
  EXPECT_EQ(s.fallbacks, std::vector<std::string>{"http://py:4002/"});
  EXPECT_EQ(s.text.find("udp: UDPROS from 1 publisher; TCPROS fallback from http://py:4002/ (the publisher cannot "
                        "serve UDPROS, e.g. rospy, or another subscription of /fix in this process asked for TCPROS "
                        "first)"),
            0u)
      << s.text;
  s = ne::transportStatus(udp, "/imu", links);
  EXPECT_EQ(s.text, "udp: in-process from 1 publisher (no network)");
  EXPECT_TRUE(s.fallbacks.empty());
  EXPECT_EQ(ne::transportStatus(udp, "/gps", links).text, "udp: no publisher connected");
  // tcp: said as configured (nothing to fall back from).
  ne::InputTransport tcp;
  EXPECT_EQ(ne::transportStatus(tcp, "/fix", links).text, "tcp");
  EXPECT_TRUE(ne::transportStatus(tcp, "/fix", links).fallbacks.empty());
  tcp.tcp_nodelay = false;
  EXPECT_EQ(ne::transportStatus(tcp, "/fix", links).text, "tcp (tcp_nodelay: false)");
}

namespace
{

sensor_msgs::Imu imuWithYaw(double yaw, const std::string& frame)
{
  sensor_msgs::Imu m;
  m.header.frame_id = frame;
  m.orientation.z = std::sin(yaw / 2);
  m.orientation.w = std::cos(yaw / 2);
  return m;
}

}  // namespace

// The nodelet's side of gnss_alignment: navsat_transform (gnss_alignment.hpp), without a master: a
// robot whose odom has heading 0 at start faces 30 deg in ENU; its IMU reads the ENU heading minus a
// declination of 0.2 rad; the antenna is 0.5 m ahead (tf base_link <- gps).
TEST(GnssAligner, WaitsForAHeadingAndAnEstimateThenTakesFixesIntoWorld)
{
  const double heading = 30.0 * M_PI / 180.0, declination = 0.2;
  ne::GnssAlignment opt;
  opt.navsat_transform = true;
  opt.magnetic_declination = declination;
  opt.heading_sensor = 1;
  ne::GnssAligner g(opt, "odom", "base_link");
  tf2::Transform mount;
  mount.setIdentity();
  mount.setOrigin(tf2::Vector3(0.5, 0.0, 0.0));
  bool have_pose = false;
  ne::BasePose pose;  // odom at start: the origin, yaw 0
  g.connect(tableFrames({{{"base_link", "gps"}, mount}}),
            [&](ne::BasePose& p)
            {
              p = pose;
              return have_pose;
            });
  const ne::LocalEnu datum(48.137, 11.575, 0.0);
  sensor_msgs::NavSatFix fix;
  fix.header.frame_id = "gps";
  const Eigen::Vector3d antenna0(0.5 * std::cos(heading), 0.5 * std::sin(heading), 0.0);
  boost::array<double, 9> cov = {0.16, 0, 0, 0, 0.04, 0, 0, 0, 1.0};
  Eigen::Vector3d local = antenna0;
  std::string why;
  // No heading yet, then no estimate yet: not fused, counted.
  EXPECT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::NOT_YET);
  EXPECT_NE(why.find("no estimate"), std::string::npos) << why;
  have_pose = true;
  why.clear();
  EXPECT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::NOT_YET);
  EXPECT_NE(why.find("gnss_heading"), std::string::npos) << why;
  EXPECT_EQ(g.notYet(), 2u);
  EXPECT_FALSE(g.aligned());
  // The heading comes: the next fix aligns and is base_link at the odom origin.
  g.heading(imuWithYaw(heading - declination, "base_link"));
  why.clear();
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_TRUE(g.aligned());
  EXPECT_NEAR(g.yawDelta(), -heading, 1e-12);
  EXPECT_LT(local.norm(), 1e-9) << local.transpose();
  // The covariance rotated into odom (by -30 deg): xy = (0.16 - 0.04) cos(-30) sin(-30).
  const double c = std::cos(-heading), s = std::sin(-heading);
  EXPECT_NEAR(cov[0], 0.16 * c * c + 0.04 * s * s, 1e-12);
  EXPECT_NEAR(cov[4], 0.16 * s * s + 0.04 * c * c, 1e-12);
  EXPECT_NEAR(cov[1], 0.12 * c * s, 1e-12);
  EXPECT_NEAR(cov[3], cov[1], 1e-15);
  EXPECT_NEAR(cov[8], 1.0, 1e-12);
  // Later: base_link at (10, 2) in odom with yaw 0.5; its antenna 0.5 m ahead, in ENU.
  pose.position = Eigen::Vector3d(9.0, 1.0, 0.0);  // the estimate's position is not used, its yaw is
  pose.yaw = 0.5;
  const Eigen::Vector3d base_enu = ne::rotationRpy(0, 0, heading) * Eigen::Vector3d(10.0, 2.0, 0.0);
  local = base_enu + ne::rotationRpy(0, 0, heading + 0.5) * Eigen::Vector3d(0.5, 0.0, 0.0);
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_LT((local - Eigen::Vector3d(10.0, 2.0, 0.0)).norm(), 1e-9) << local.transpose();
  // A later heading does not move the alignment (it is made once).
  g.heading(imuWithYaw(1.0, "base_link"));
  local = base_enu + ne::rotationRpy(0, 0, heading + 0.5) * Eigen::Vector3d(0.5, 0.0, 0.0);
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_LT((local - Eigen::Vector3d(10.0, 2.0, 0.0)).norm(), 1e-9);
  // A fix that is not finite is refused.
  local = Eigen::Vector3d(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
  EXPECT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::BAD);
  EXPECT_NE(why.find("not finite"), std::string::npos) << why;
}

TEST(GnssAligner, NoLeverArmTransformMeansZeroAndTheImuMountingIsRemoved)
{
  // The antenna's frame has no tf: the lever arm is zero (the fix is base_link's position). The
  // IMU is mounted turned by 0.3 rad (tf base_link <- imu_link): its yaw minus 0.3 is base_link's.
  const double heading = 30.0 * M_PI / 180.0;
  ne::GnssAlignment opt;
  opt.navsat_transform = true;
  opt.yaw_offset = 0.1;
  opt.heading_sensor = 0;
  ne::GnssAligner g(opt, "odom", "base_link");
  tf2::Transform imu_mount;
  imu_mount.setIdentity();
  tf2::Quaternion q;
  q.setRPY(0.0, 0.0, 0.3);
  imu_mount.setRotation(q);
  g.connect(tableFrames({{{"base_link", "imu_link"}, imu_mount}}),
            [](ne::BasePose& p)
            {
              p = ne::BasePose();
              return true;
            });
  g.heading(imuWithYaw(heading - 0.1 + 0.3, "imu_link"));
  const ne::LocalEnu datum(48.137, 11.575, 0.0);
  sensor_msgs::NavSatFix fix;
  fix.header.frame_id = "antenna_without_tf";
  boost::array<double, 9> cov = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  Eigen::Vector3d local(3.0, 4.0, 0.0);
  std::string why;
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_NEAR(g.yawDelta(), -heading, 1e-12);
  EXPECT_LT(local.norm(), 1e-9);  // the first fix is base_link at the origin: no lever arm
  // A point 10 m east of the first fix: in odom, 10 m along -30 deg.
  local = Eigen::Vector3d(13.0, 4.0, 0.0);
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_NEAR(local.x(), 10.0 * std::cos(-heading), 1e-9);
  EXPECT_NEAR(local.y(), 10.0 * std::sin(-heading), 1e-9);
}

TEST(GnssAligner, UseOdometryYawAlignsWithTheFusedYaw)
{
  // use_odometry_yaw: the world frame is taken as earth-aligned; the declination still applies.
  ne::GnssAlignment opt;
  opt.navsat_transform = true;
  opt.use_odometry_yaw = true;
  opt.magnetic_declination = 0.25;
  ne::GnssAligner g(opt, "map", "base_link");
  g.connect(tableFrames({}),
            [](ne::BasePose& p)
            {
              p = ne::BasePose();
              p.yaw = 1.0;
              return true;
            });
  const ne::LocalEnu datum(48.137, 11.575, 0.0);
  sensor_msgs::NavSatFix fix;
  boost::array<double, 9> cov = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  Eigen::Vector3d local(0.0, 0.0, 0.0);
  std::string why;
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_NEAR(g.yawDelta(), -0.25, 1e-12);
}

// After the filter starts over (a time jump), the alignment is made again at the next fix: the
// world frame was anchored again, at wherever the robot then is.
TEST(GnssAligner, RestartAlignsAgainAtTheNextFix)
{
  ne::GnssAlignment opt;
  opt.navsat_transform = true;
  opt.heading_sensor = 0;
  ne::GnssAligner g(opt, "odom", "base_link");
  ne::BasePose pose;  // the origin of odom, yaw 0
  g.connect(tableFrames({}),
            [&](ne::BasePose& p)
            {
              p = pose;
              return true;
            });
  g.heading(imuWithYaw(0.5, "base_link"));
  const ne::LocalEnu datum(48.137, 11.575, 0.0);
  sensor_msgs::NavSatFix fix;
  boost::array<double, 9> cov = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  Eigen::Vector3d local(3.0, 4.0, 0.0);
  std::string why;
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_NEAR(g.yawDelta(), -0.5, 1e-12);
  EXPECT_LT(local.norm(), 1e-9);
  // Without a restart a new heading does not move it; after one, the next fix aligns again: the
  // fix at ENU (20, 0) is the new odom origin, with the new heading 1.0.
  g.heading(imuWithYaw(1.0, "base_link"));
  local = Eigen::Vector3d(20.0, 0.0, 0.0);
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_GT(local.norm(), 10.0);
  g.restart();
  EXPECT_FALSE(g.aligned());
  local = Eigen::Vector3d(20.0, 0.0, 0.0);
  ASSERT_EQ(g.apply(fix, datum, local, cov, why), ne::GnssStep::OK) << why;
  EXPECT_TRUE(g.aligned());
  EXPECT_NEAR(g.yawDelta(), -1.0, 1e-12);
  EXPECT_LT(local.norm(), 1e-9) << local.transpose();
}

// The nodelets' list of message classes (input_message_types.hpp) and the core's descriptor table
// (sensor_inputs.hpp) agree on every type: its ROS name and whether it has a header.
TEST(InputMessageTypes, ListMatchesTheTable)
{
  for (ne::InputType t : ne::inputTypes())
  {
    const ne::InputTypeInfo& row = ne::inputTypeInfo(t);
    EXPECT_EQ(row.type, t);
    const std::string name = ne::withInputMessage(
        t, [](auto tag) { return std::string(ros::message_traits::DataType<ne::MessageOf<decltype(tag)>>::value()); });
    EXPECT_EQ(name, row.name);
    const bool stamped = ne::withInputMessage(
        t, [](auto tag) { return ros::message_traits::HasHeader<ne::MessageOf<decltype(tag)>>::value; });
    EXPECT_EQ(stamped, row.stamped) << row.name;
    EXPECT_EQ(row.sensor, t != ne::InputType::CONTROL_INPUT) << row.name;
  }
}

// Measurement and ControlInput are adapters like the others: their sample points into the message
// (no copy), with its step and stamp; a Measurement naming another sensor, or a step beyond what
// a long holds, is refused naming the field.
TEST(SensorAdapters, WholeVectorMessages)
{
  ne::Measurement m;
  m.header.stamp = ros::Time(12.5);
  m.step = 7;
  m.sensor = "gps";
  m.y = {1.0, -2.0, 3.5};
  ne::SensorSample s;
  s.sensor = 4;  // the caller's, kept
  std::string why;
  ASSERT_TRUE(ne::wholeSample(m, "gps", s, why)) << why;
  EXPECT_EQ(s.y, m.y.data());
  EXPECT_EQ(s.size, 3u);
  EXPECT_EQ(s.step, 7);
  EXPECT_EQ(s.stamp, 12.5);
  EXPECT_EQ(s.R, nullptr);
  EXPECT_EQ(s.sensor, 4u);

  m.sensor.clear();  // no name: not checked
  m.step = 0;        // no step: placed by the stamp
  ASSERT_TRUE(ne::wholeSample(m, "gps", s, why)) << why;
  EXPECT_EQ(s.step, 0);

  m.sensor = "odom";
  EXPECT_FALSE(ne::wholeSample(m, "gps", s, why));
  EXPECT_EQ(why, "sensor: expected 'gps', found 'odom'");
  m.sensor = "gps";
  m.step = std::numeric_limits<std::uint64_t>::max();
  EXPECT_FALSE(ne::wholeSample(m, "gps", s, why));
  EXPECT_EQ(why, "step " + std::to_string(m.step) + " out of range");

  ne::ControlInput c;
  c.header.stamp = ros::Time(3.0);
  c.step = 2;
  c.u = {0.25};
  ASSERT_TRUE(ne::wholeSample(c, "", s, why)) << why;
  EXPECT_EQ(s.y, c.u.data());
  EXPECT_EQ(s.size, 1u);
  EXPECT_EQ(s.step, 2);
  EXPECT_EQ(s.stamp, 3.0);
  c.step = static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2) + 1;
  EXPECT_FALSE(ne::wholeSample(c, "", s, why));
  EXPECT_NE(why.find("out of range"), std::string::npos) << why;
}
