// gnss_alignment: navsat_transform in the Estimator (docs/ros_interface.md "GNSS alignment"): the
// ROS side of NavSatAlignment (geodesy/navsat_alignment.hpp). It keeps the latest earth-referenced
// heading (the gnss_heading Imu input's orientation yaw, or the fused yaw with use_odometry_yaw),
// looks the antenna's lever arm up in tf (base_link_frame <- the fix's frame_id), ties ENU to
// world_frame at the first usable fix, and then turns each fix's ENU antenna position into
// base_link's world position with its covariance rotated. Outputs: odometry/gps, gps/filtered, the
// static tf world_frame -> utm. The maths is the core's; this only moves messages.
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <tf2/LinearMath/Matrix3x3.h>
#include <tf2/LinearMath/Quaternion.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <Eigen/Core>

#include <boost/array.hpp>

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "frame_transforms.hpp"
#include "transport_watch.hpp"
#include "networked_estimation/geodesy/local_enu.hpp"
#include "networked_estimation/geodesy/navsat_alignment.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"

namespace networked_estimation
{

/// base_link's pose in a state: x, y, z, yaw of `map` (z: 0 when not mapped), roll and pitch at
/// the indices `roll`, `pitch` (-1: 0).
inline BasePose basePoseOf(const Eigen::Ref<const Eigen::VectorXd>& x, const StateMap& map, int roll, int pitch)
{
  auto value = [&](int i) { return i >= 0 && i < x.size() ? x(i) : 0.0; };
  BasePose p;
  p.position = Eigen::Vector3d(value(map.x), value(map.y), value(map.z));
  p.roll = value(roll);
  p.pitch = value(pitch);
  p.yaw = value(map.yaw);
  return p;
}

enum class GnssStep
{
  OK,       ///< the fix is base_link's world position now
  NOT_YET,  ///< no ENU -> world transform yet (no heading or no estimate): not fused, counted
  BAD       ///< refused (`why`)
};

class GnssAligner
{
public:
  /// The latest estimate of base_link's world pose (roll and pitch 0 where the state has none);
  /// false when there is none yet.
  using PoseSource = std::function<bool(BasePose& pose)>;

  GnssAligner(const GnssAlignment& options, std::string world_frame, std::string base_link_frame)
    : opt_(options), world_(std::move(world_frame)), base_(std::move(base_link_frame)), align_(options.zero_altitude)
  {
  }

  /// Topics on `nh`; the heading input's subscription on `in_nh` (the queue of the fixes);
  /// `frames`: the tf2 lookup (for the lever arm and the IMU's mounting).
  void start(ros::NodeHandle& nh, ros::NodeHandle& in_nh, const std::vector<SensorInput>& inputs, const Frames& frames,
             PoseSource pose)
  {
    connect(frames, std::move(pose));
    if (opt_.publish_gps_odometry)
      gps_odom_pub_ = nh.advertise<nav_msgs::Odometry>("odometry/gps", 10);
    if (opt_.publish_filtered_gps)
      filtered_pub_ = nh.advertise<sensor_msgs::NavSatFix>("gps/filtered", 10);
    if (opt_.broadcast_utm_transform)
      static_tf_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    if (opt_.heading_sensor >= 0)
    {
      const SensorInput& in = inputs[static_cast<std::size_t>(opt_.heading_sensor)];
      // The sensor's own transport: roscpp shares one connection per topic, and its first
      // subscriber's hints would decide it.
      heading_sub_ = in_nh.subscribe<sensor_msgs::Imu>(
          in.topic, 10, [this](const sensor_msgs::Imu::ConstPtr& m) { heading(*m); }, ros::VoidConstPtr(),
          transportHints(in.transport));
    }
  }
  void stop() { heading_sub_.shutdown(); }
  /// The tf2 lookup and the estimate's pose, without topics (start() does this; tests call it).
  void connect(const Frames& frames, PoseSource pose)
  {
    frames_ = frames;
    pose_ = std::move(pose);
  }

  /// The earth-referenced yaw of base_link from a message of the gnss_heading input: the IMU's yaw
  /// minus its mounting yaw in base_link (tf base_link_frame <- the message's frame, when it is
  /// another frame; none: the IMU's yaw as it is, warned about once). A non-finite or zero
  /// orientation is ignored (the sensor's own input reports it).
  void heading(const sensor_msgs::Imu& m)
  {
    const auto& q = m.orientation;
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w) ||
        q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w < 1e-6)
      return;
    double roll, pitch, yaw;
    tf2::Matrix3x3(tf2::Quaternion(q.x, q.y, q.z, q.w).normalized()).getRPY(roll, pitch, yaw);
    double mount = 0.0;
    if (!m.header.frame_id.empty() && m.header.frame_id != base_ && frames_.lookup)
    {
      tf2::Transform t;
      std::string why;
      if (frames_.lookup(base_, m.header.frame_id, ros::Time(0), t, why))
      {
        double r, p;
        tf2::Matrix3x3(t.getRotation()).getRPY(r, p, mount);
      }
      else if (!warned_mount_)
      {
        warned_mount_ = true;
        ROS_WARN("Estimator: gnss_heading: no tf %s <- %s: the IMU's yaw is taken as base_link's (%s)", base_.c_str(),
                 m.header.frame_id.c_str(), why.c_str());
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    heading_ = std::atan2(std::sin(yaw - mount), std::cos(yaw - mount));
    has_heading_ = true;
  }

  /// The fix `m` (its antenna's ENU `local` about `datum`, and its ENU covariance `cov`) in place
  /// to base_link's world position and its covariance in world_frame; the first call that has a
  /// heading and an estimate ties ENU to world_frame.
  GnssStep apply(const sensor_msgs::NavSatFix& m, const LocalEnu& datum, Eigen::Vector3d& local,
                 boost::array<double, 9>& cov, std::string& why)
  {
    BasePose pose;
    const bool have_pose = pose_ && pose_(pose);  // outside our lock: takes the filter's
    std::lock_guard<std::mutex> lock(mutex_);
    const Eigen::Vector3d lever = leverArm(m.header.frame_id);
    if (!align_.aligned())
    {
      double reading = 0.0;
      if (!have_pose)
        why = "not fused: no estimate of base_link's world pose yet to tie the fix's ENU frame to world_frame";
      else if (opt_.use_odometry_yaw)
        reading = pose.yaw;
      else if (!has_heading_)
        why =
            "not fused: no heading yet from the gnss_heading Imu input (ENU is tied to world_frame at the first "
            "fix after one)";
      if (!why.empty())
      {
        ++not_yet_;
        return GnssStep::NOT_YET;
      }
      if (!opt_.use_odometry_yaw)
        reading = heading_;
      const double theta = enuHeading(reading, opt_.magnetic_declination, opt_.yaw_offset);
      if (!align_.align(local, theta, pose, lever, why))
        return GnssStep::BAD;
      if (!lever_known_)
        ROS_WARN("Estimator: GNSS antenna frame '%s': no tf %s <- %s, the lever arm is taken as zero (%s)",
                 m.header.frame_id.c_str(), base_.c_str(), m.header.frame_id.c_str(), lever_why_.c_str());
      datum_ = std::make_unique<LocalEnu>(datum.latitude(), datum.longitude(), datum.altitude());
      fix_frame_ = m.header.frame_id;
      ROS_INFO(
          "Estimator: GNSS aligned (navsat_transform) at the fix of %.3f: base_link's ENU heading %.4f rad "
          "(%s %.4f + magnetic_declination_radians %.4f + yaw_offset %.4f), world pose (%.3f, %.3f, %.3f, yaw "
          "%.4f), world_T_enu yaw %.4f rad, translation (%.3f, %.3f, %.3f); %lu fixes before it not fused",
          m.header.stamp.toSec(), theta, opt_.use_odometry_yaw ? "fused yaw" : "IMU yaw", reading,
          opt_.magnetic_declination, opt_.yaw_offset, pose.position.x(), pose.position.y(), pose.position.z(), pose.yaw,
          align_.yawDelta(), align_.translation().x(), align_.translation().y(), align_.translation().z(),
          static_cast<unsigned long>(not_yet_));
      if (static_tf_)
        broadcastUtm(m.header.stamp);
    }
    Eigen::Vector3d world;
    if (!align_.toWorld(local, pose, lever, world, why))
      return GnssStep::BAD;
    local = world;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> C(cov.data());
    const Eigen::Matrix3d rotated = align_.covarianceToWorld(C);
    C = rotated;
    if (opt_.zero_altitude)
    {
      C(0, 2) = C(1, 2) = C(2, 0) = C(2, 1) = 0.0;
    }
    if (gps_odom_pub_)
      publishGpsOdometry(m, world, C);
    return GnssStep::OK;
  }

  /// gps/filtered: the antenna's latitude, longitude and altitude of an estimate of base_link's
  /// world pose and its position covariance (world_frame), once aligned.
  void publishFiltered(const BasePose& pose, const Eigen::Matrix3d& P_world, const ros::Time& stamp)
  {
    if (!filtered_pub_)
      return;
    std::lock_guard<std::mutex> lock(mutex_);
    Eigen::Vector3d enu;
    std::string why;
    if (!datum_ || !align_.toEnu(pose, lever_arm_, enu, why))
      return;
    const Eigen::Vector3d lla = datum_->reverse(enu);
    sensor_msgs::NavSatFix f;
    f.header.stamp = stamp;
    f.header.frame_id = fix_frame_;
    f.status.status = sensor_msgs::NavSatStatus::STATUS_FIX;
    f.status.service = sensor_msgs::NavSatStatus::SERVICE_GPS;
    f.latitude = lla.x();
    f.longitude = lla.y();
    f.altitude = lla.z();
    // world -> ENU: R^T P R, R = Rz(world_T_enu yaw).
    const Eigen::Matrix3d R = rotationRpy(0.0, 0.0, align_.yawDelta());
    const Eigen::Matrix3d enu_P = R.transpose() * P_world * R;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        f.position_covariance[static_cast<std::size_t>(3 * i + j)] = enu_P(i, j);
    f.position_covariance_type = sensor_msgs::NavSatFix::COVARIANCE_TYPE_KNOWN;
    filtered_pub_.publish(f);
  }
  bool wantsFiltered() const { return static_cast<bool>(filtered_pub_); }

  /// The filter started over (a time jump restarts the stream from the model's x0): the world frame
  /// it estimates in is anchored again, so the ENU -> world transform is made again at the next fix
  /// that has a heading, and the lever arm looked up again. The heading and the counts are kept.
  void restart()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    align_ = NavSatAlignment(opt_.zero_altitude);
    lever_known_ = false;
  }

  /// For the diagnostics.
  bool aligned()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return align_.aligned();
  }
  std::uint64_t notYet()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return not_yet_;
  }
  double yawDelta()
  {
    std::lock_guard<std::mutex> lock(mutex_);
    return align_.yawDelta();
  }

private:
  /// The antenna in base_link: tf base_link_frame <- `frame`, looked up at each fix until ENU is
  /// tied to world_frame and fixed from then on (a fixed mounting; a static tf that comes late
  /// still counts); none by then: zero, with one warning naming the frame (mutex_ held).
  Eigen::Vector3d leverArm(const std::string& frame)
  {
    if (lever_known_ || align_.aligned())
      return lever_arm_;
    lever_arm_.setZero();
    if (frame.empty() || frame == base_)
    {
      lever_known_ = true;
      return lever_arm_;
    }
    tf2::Transform t;
    lever_why_.clear();
    if (frames_.lookup && frames_.lookup(base_, frame, ros::Time(0), t, lever_why_))
    {
      lever_known_ = true;
      lever_arm_ = Eigen::Vector3d(t.getOrigin().x(), t.getOrigin().y(), t.getOrigin().z());
      ROS_INFO("Estimator: GNSS antenna lever arm (tf %s <- %s): (%.3f, %.3f, %.3f) m", base_.c_str(), frame.c_str(),
               lever_arm_.x(), lever_arm_.y(), lever_arm_.z());
    }
    return lever_arm_;
  }

  void publishGpsOdometry(const sensor_msgs::NavSatFix& m, const Eigen::Vector3d& world, const Eigen::Matrix3d& C)
  {
    nav_msgs::Odometry o;
    o.header.stamp = m.header.stamp;
    o.header.frame_id = world_;
    o.child_frame_id = base_;
    o.pose.pose.position.x = world.x();
    o.pose.pose.position.y = world.y();
    o.pose.pose.position.z = world.z();
    o.pose.pose.orientation.w = 1.0;
    for (int i = 0; i < 6; ++i)
      o.pose.covariance[static_cast<std::size_t>(7 * i)] = 1e6;  // orientation: not measured
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        o.pose.covariance[static_cast<std::size_t>(6 * i + j)] = C(i, j);
    for (int i = 0; i < 6; ++i)
      o.twist.covariance[static_cast<std::size_t>(7 * i)] = 1e6;
    gps_odom_pub_.publish(o);
  }

  /// broadcast_utm_transform: the static tf world_frame -> utm (mutex_ held).
  void broadcastUtm(const ros::Time& stamp)
  {
    UtmPoint u;
    std::string why;
    if (!utmOf(datum_->latitude(), datum_->longitude(), datum_->altitude(), u, why))
    {
      ROS_WARN("Estimator: broadcast_utm_transform: the datum has no UTM coordinates: %s", why.c_str());
      return;
    }
    double yaw;
    Eigen::Vector3d t;
    align_.worldFromUtm(u, yaw, t);
    geometry_msgs::TransformStamped m;
    m.header.stamp = stamp;
    m.header.frame_id = world_;
    m.child_frame_id = "utm";
    m.transform.translation.x = t.x();
    m.transform.translation.y = t.y();
    m.transform.translation.z = t.z();
    tf2::Quaternion q;
    q.setRPY(0.0, 0.0, yaw);
    fromTf(q, m.transform.rotation);
    static_tf_->sendTransform(m);
    ROS_INFO(
        "Estimator: broadcast_utm_transform: %s -> utm (zone %d%s, datum easting %.3f, northing %.3f, meridian "
        "convergence %.5f rad)",
        world_.c_str(), u.zone, u.northp ? "N" : "S", u.easting, u.northing, u.convergence);
  }

  GnssAlignment opt_;
  std::string world_, base_;
  Frames frames_;
  PoseSource pose_;
  std::mutex mutex_;
  NavSatAlignment align_;
  std::unique_ptr<LocalEnu> datum_;
  std::string fix_frame_, lever_why_;
  bool lever_known_ = false, warned_mount_ = false, has_heading_ = false;
  Eigen::Vector3d lever_arm_ = Eigen::Vector3d::Zero();
  double heading_ = 0.0;
  std::uint64_t not_yet_ = 0;
  ros::Subscriber heading_sub_;
  ros::Publisher gps_odom_pub_, filtered_pub_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_tf_;
};

}  // namespace networked_estimation
