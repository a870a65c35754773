// A nodelet that cannot start (a bad parameter, a bad model file) refuses its load: it logs the
// reason as FATAL, naming the key, and throws from onInit. The nodelet manager then drops the
// nodelet and answers the load request with a failure, so `nodelet load` exits with an error and
// roslaunch shows the process as died, instead of a loaded nodelet that does nothing.
#pragma once

#include <ros/console.h>

#include <stdexcept>
#include <string>

namespace networked_estimation
{

[[noreturn]] inline void refuseLoad(const std::string& nodelet_name, const std::string& reason)
{
  ROS_FATAL_NAMED(nodelet_name, "%s", reason.c_str());
  throw std::runtime_error(reason);
}

}  // namespace networked_estimation
