// The message class of each input type (online/sensor_inputs.hpp's descriptor table): the one list
// the nodelets dispatch on. A new message type is a row in the core's table and a case here; its
// fields are then read and written by the field adapters (sensor_adapters.hpp, sensor_writers.hpp).
// The package's own Measurement and ControlInput are taken whole, with their step (wholeSample).
#pragma once

#include <geometry_msgs/PointStamped.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <geometry_msgs/TwistWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Float64.h>
#include <std_msgs/Float64MultiArray.h>

#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "networked_estimation/ControlInput.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/online/sensor_inputs.hpp"
#include "networked_estimation/online/sensor_sample.hpp"

namespace networked_estimation
{

template <class M>
struct MessageTag
{
  using type = M;
};

/// Calls f(MessageTag<M>{}) with the message class M of `type` and returns what it returns (the
/// same type for every M).
template <class F>
decltype(auto) withInputMessage(InputType type, F&& f)
{
  switch (type)
  {
    case InputType::ODOMETRY:
      return f(MessageTag<nav_msgs::Odometry>{});
    case InputType::POSE_WITH_COVARIANCE:
      return f(MessageTag<geometry_msgs::PoseWithCovarianceStamped>{});
    case InputType::POSE:
      return f(MessageTag<geometry_msgs::PoseStamped>{});
    case InputType::POINT:
      return f(MessageTag<geometry_msgs::PointStamped>{});
    case InputType::TWIST_WITH_COVARIANCE:
      return f(MessageTag<geometry_msgs::TwistWithCovarianceStamped>{});
    case InputType::TWIST:
      return f(MessageTag<geometry_msgs::TwistStamped>{});
    case InputType::IMU:
      return f(MessageTag<sensor_msgs::Imu>{});
    case InputType::NAVSATFIX:
      return f(MessageTag<sensor_msgs::NavSatFix>{});
    case InputType::RANGE:
      return f(MessageTag<sensor_msgs::Range>{});
    case InputType::FLOAT64:
      return f(MessageTag<std_msgs::Float64>{});
    case InputType::TWIST_UNSTAMPED:
      return f(MessageTag<geometry_msgs::Twist>{});
    case InputType::FLOAT64_ARRAY:
      return f(MessageTag<std_msgs::Float64MultiArray>{});
    case InputType::CONTROL_INPUT:
      return f(MessageTag<ControlInput>{});
    case InputType::MEASUREMENT:
      break;
  }
  return f(MessageTag<Measurement>{});
}

/// The message class of a tag.
template <class Tag>
using MessageOf = typename std::decay_t<Tag>::type;

/// Whether M is one of the package's own messages, which carry y (or u) whole with its step
/// (read by wholeSample).
template <class M>
constexpr bool kWholeVector = std::is_same<M, Measurement>::value || std::is_same<M, ControlInput>::value;

/// The sample of a step-numbered vector (kWholeVector): `s` points at `values` (nothing is copied;
/// it lives as long as the message) and gets `stamp` and `step` (0: none, the step then comes from
/// the stamp); its sensor index is left to the caller. The values' count is checked where the
/// sensor's (or command's) size is known, by the OnlineEstimator. False with `why` for a step a
/// long does not hold with room to spare (Measurement.step and ControlInput.step are uint64).
inline bool stepSample(std::uint64_t step, const std::vector<double>& values, const ros::Time& stamp, SensorSample& s,
                       std::string& why)
{
  if (step > static_cast<std::uint64_t>(std::numeric_limits<long>::max() / 2))
  {
    why = "step " + std::to_string(step) + " out of range";
    return false;
  }
  s.step = static_cast<long>(step);
  s.y = values.data();
  s.size = values.size();
  s.R = nullptr;
  s.stamp = stamp.toSec();
  return true;
}

/// The sample of one of the package's own messages (stepSample), and for a Measurement naming
/// another sensor than `sensor` (the model's name of the sensor it feeds; an empty
/// Measurement.sensor is not checked) false with `why`.
inline bool wholeSample(const Measurement& m, const std::string& sensor, SensorSample& s, std::string& why)
{
  if (!m.sensor.empty() && m.sensor != sensor)
  {
    why = "sensor: expected '" + sensor + "', found '" + m.sensor + "'";
    return false;
  }
  return stepSample(m.step, m.y, m.header.stamp, s, why);
}
inline bool wholeSample(const ControlInput& c, const std::string&, SensorSample& s, std::string& why)
{
  return stepSample(c.step, c.u, c.header.stamp, s, why);
}

}  // namespace networked_estimation
