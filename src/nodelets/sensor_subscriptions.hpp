// Subscriptions of the Estimator's per-sensor inputs of standard types (sensor_inputs.hpp): each
// message's selected fields go to `ok` with the message's stamp, or a reason to `bad`.
#pragma once

#include <ros/ros.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "frame_transforms.hpp"
#include "sensor_adapters.hpp"

namespace networked_estimation
{

struct SensorSink
{
  std::function<void(const ros::Time& stamp, const double* y, std::size_t size)> ok;
  std::function<void(const std::string& why)> bad;
  /// NavSatFix only: a fix became the datum.
  std::function<void(const LocalEnu& datum)> datum;
  /// The model's frames and the tf2 lookup (frame_transforms.hpp); no lookup: frames are not used.
  Frames frames;
};

template <class M>
ros::Time stampOf(const M& m)
{
  return m.header.stamp;
}
/// std_msgs/Float64, Float64MultiArray and geometry_msgs/Twist have no header: they are stamped by
/// their arrival.
inline ros::Time stampOf(const std_msgs::Float64&) { return ros::Time::now(); }
inline ros::Time stampOf(const std_msgs::Float64MultiArray&) { return ros::Time::now(); }
inline ros::Time stampOf(const geometry_msgs::Twist&) { return ros::Time::now(); }

template <class M>
ros::Subscriber subscribeFields(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue, const SensorSink& sink)
{
  const std::vector<InputField> fields = in.fields;
  return nh.subscribe<M>(
      in.topic, queue,
      [fields, sink](const typename M::ConstPtr& m) {
        std::vector<double> y(fields.size());
        std::string why;
        M local = *m;  // into the model's frames
        if (!intoFrames(sink.frames, local, why))
          sink.bad(why);
        else if (readFields(view(local), fields, y.data(), why))
          sink.ok(stampOf(local), y.data(), y.size());
        else
          sink.bad(why);
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
}

inline ros::Subscriber subscribeNavSatFix(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue,
                                          const SensorSink& sink, const std::vector<double>& datum)
{
  const std::vector<InputField> fields = in.fields;
  auto enu = std::make_shared<NavSatFixEnu>(datum);
  return nh.subscribe<sensor_msgs::NavSatFix>(
      in.topic, queue,
      [fields, sink, enu](const sensor_msgs::NavSatFix::ConstPtr& m) {
        Eigen::Vector3d local;
        std::string why;
        bool new_datum = false;
        if (!enu->convert(*m, local, why, new_datum))
        {
          sink.bad(why);
          return;
        }
        if (new_datum && sink.datum)
          sink.datum(*enu->datum());
        MessageView v;
        v.enu = &local;
        std::vector<double> y(fields.size());
        if (readFields(v, fields, y.data(), why))
          sink.ok(m->header.stamp, y.data(), y.size());
        else
          sink.bad(why);
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
}

/// A subscription of any type but networked_estimation/Measurement and ControlInput (which carry
/// their step and are read by the nodelet itself).
inline ros::Subscriber subscribeSensor(ros::NodeHandle& nh, const SensorInput& in, uint32_t queue,
                                       const SensorSink& sink, const std::vector<double>& datum)
{
  switch (in.type)
  {
    case InputType::ODOMETRY:
      return subscribeFields<nav_msgs::Odometry>(nh, in, queue, sink);
    case InputType::POSE_WITH_COVARIANCE:
      return subscribeFields<geometry_msgs::PoseWithCovarianceStamped>(nh, in, queue, sink);
    case InputType::POSE:
      return subscribeFields<geometry_msgs::PoseStamped>(nh, in, queue, sink);
    case InputType::POINT:
      return subscribeFields<geometry_msgs::PointStamped>(nh, in, queue, sink);
    case InputType::TWIST_WITH_COVARIANCE:
      return subscribeFields<geometry_msgs::TwistWithCovarianceStamped>(nh, in, queue, sink);
    case InputType::TWIST:
      return subscribeFields<geometry_msgs::TwistStamped>(nh, in, queue, sink);
    case InputType::IMU:
      return subscribeFields<sensor_msgs::Imu>(nh, in, queue, sink);
    case InputType::NAVSATFIX:
      return subscribeNavSatFix(nh, in, queue, sink, datum);
    case InputType::RANGE:
      return subscribeFields<sensor_msgs::Range>(nh, in, queue, sink);
    case InputType::FLOAT64:
      return subscribeFields<std_msgs::Float64>(nh, in, queue, sink);
    case InputType::TWIST_UNSTAMPED:
      return subscribeFields<geometry_msgs::Twist>(nh, in, queue, sink);
    case InputType::FLOAT64_ARRAY:
      return subscribeFields<std_msgs::Float64MultiArray>(nh, in, queue, sink);
    case InputType::MEASUREMENT:
    case InputType::CONTROL_INPUT:
      break;
  }
  return ros::Subscriber();
}

}  // namespace networked_estimation
