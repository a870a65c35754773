// Private ROS parameters as a YAML map, so that nodelets validate them with the same core parsers
// (and the same messages naming the key) as the files of the offline tools.
#pragma once

#include <ros/node_handle.h>
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

#include "networked_estimation/config/param_reader.hpp"

namespace networked_estimation
{

/// Converts an XmlRpc value (parameter tree) to YAML.
YAML::Node toYaml(const XmlRpc::XmlRpcValue& value);

/// All private parameters of `pnh` as a YAML map, minus the keys in `ignore` (parameters that
/// belong to ROS helpers, e.g. diagnostic_period). Empty map when there are none.
YAML::Node privateParameters(const ros::NodeHandle& pnh, const std::set<std::string>& ignore = {});

}  // namespace networked_estimation
