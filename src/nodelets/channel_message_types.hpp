// The message types of the LossyChannel nodelet (lossy_channel_nodelet.cpp): the header.stamp of a
// message of any type (for ~events), and the types ~type may name, each forwarded as its own class.
#pragma once

#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "networked_estimation/ControlInput.h"
#include "networked_estimation/Estimate.h"
#include "networked_estimation/Measurement.h"
#include "networked_estimation/PlantState.h"
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

namespace networked_estimation
{
namespace channel_types
{

/// header.stamp of a serialized message whose type starts with a std_msgs/Header
/// (uint32 seq, then time stamp); zero otherwise.
inline ros::Time inputStamp(const topic_tools::ShapeShifter& msg, bool has_header)
{
  if (!has_header || msg.size() < 12)
    return ros::Time();
  std::vector<uint8_t> buf(msg.size());
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  msg.write(out);
  uint32_t sec, nsec;
  std::memcpy(&sec, buf.data() + 4, 4);
  std::memcpy(&nsec, buf.data() + 8, 4);
  return ros::Time(sec, nsec);
}

/// Whether the first field of a message definition (after comments and blank lines) is a Header.
inline bool startsWithHeader(const std::string& definition)
{
  std::istringstream in(definition);
  std::string line;
  while (std::getline(in, line))
  {
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#')
      continue;
    return line.compare(first, 14, "Header header ") == 0 || line.compare(first, 13, "Header header") == 0 ||
           line.compare(first, 22, "std_msgs/Header header") == 0;
  }
  return false;
}

template <class M>
struct TypeTag
{
  using type = M;
};

/// Calls f(TypeTag<M>{}) for the message class M named by ~type; false for a type not in the list.
template <class F>
bool withKnownType(const std::string& type, F&& f)
{
  if (type == "networked_estimation/Measurement")
    f(TypeTag<Measurement>{});
  else if (type == "networked_estimation/ControlInput")
    f(TypeTag<ControlInput>{});
  else if (type == "networked_estimation/PlantState")
    f(TypeTag<PlantState>{});
  else if (type == "networked_estimation/Estimate")
    f(TypeTag<Estimate>{});
  else if (type == "sensor_msgs/Range")
    f(TypeTag<sensor_msgs::Range>{});
  else if (type == "sensor_msgs/Imu")
    f(TypeTag<sensor_msgs::Imu>{});
  else if (type == "geometry_msgs/PointStamped")
    f(TypeTag<geometry_msgs::PointStamped>{});
  else if (type == "geometry_msgs/PoseStamped")
    f(TypeTag<geometry_msgs::PoseStamped>{});
  else if (type == "geometry_msgs/PoseWithCovarianceStamped")
    f(TypeTag<geometry_msgs::PoseWithCovarianceStamped>{});
  else if (type == "geometry_msgs/TwistStamped")
    f(TypeTag<geometry_msgs::TwistStamped>{});
  else if (type == "geometry_msgs/TwistWithCovarianceStamped")
    f(TypeTag<geometry_msgs::TwistWithCovarianceStamped>{});
  else if (type == "geometry_msgs/Twist")
    f(TypeTag<geometry_msgs::Twist>{});
  else if (type == "nav_msgs/Odometry")
    f(TypeTag<nav_msgs::Odometry>{});
  else if (type == "sensor_msgs/NavSatFix")
    f(TypeTag<sensor_msgs::NavSatFix>{});
  else if (type == "std_msgs/Float64")
    f(TypeTag<std_msgs::Float64>{});
  else if (type == "std_msgs/Float64MultiArray")
    f(TypeTag<std_msgs::Float64MultiArray>{});
  else
    return false;
  return true;
}

/// header.stamp of a typed message; zero for a type without a Header.
template <class M>
ros::Time stampOf(const M& m)
{
  if constexpr (ros::message_traits::HasHeader<M>::value)
    return m.header.stamp;
  else
    return ros::Time();
}

constexpr const char* kKnownTypes =
    "networked_estimation/{Measurement, ControlInput, PlantState, Estimate}, nav_msgs/Odometry, "
    "sensor_msgs/{Range, Imu, NavSatFix}, geometry_msgs/{PointStamped, PoseStamped, PoseWithCovarianceStamped, "
    "TwistStamped, TwistWithCovarianceStamped, Twist}, std_msgs/{Float64, Float64MultiArray}";

}  // namespace channel_types
}  // namespace networked_estimation
