// Private ROS parameters as a YAML map, so that nodelets validate them with the same core parsers
// (and the same messages naming the key) as the files of the offline tools.
#pragma once

#include <ros/node_handle.h>
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <vector>

namespace networked_estimation
{

/// Converts an XmlRpc value (parameter tree) to YAML.
YAML::Node toYaml(const XmlRpc::XmlRpcValue& value);

/// All private parameters of `pnh` as a YAML map, minus the keys in `ignore` (parameters that
/// belong to ROS helpers, e.g. diagnostic_period). Empty map when there are none.
YAML::Node privateParameters(const ros::NodeHandle& pnh, const std::set<std::string>& ignore = {});

}  // namespace networked_estimation

namespace networked_estimation
{

/// Typed access to a nodelet's private parameters (as a YAML map) with the same kind of messages
/// as the core parsers: "<source>: <key>: expected ..., found ...". Every key read is consumed;
/// rejectUnknown() then names any key left over (a typo in a launch file is an error, not a
/// silently ignored setting).
class ParamReader
{
public:
  ParamReader(YAML::Node params, std::string source);

  bool has(const std::string& key) const;
  double number(const std::string& key, double def, double lo, double hi);
  long integer(const std::string& key, long def, long lo, long hi);
  bool flag(const std::string& key, bool def);
  std::string text(const std::string& key, const std::string& def);
  /// A required string (ConfigError when missing or empty).
  std::string required(const std::string& key);
  /// One of `choices`.
  std::string choice(const std::string& key, const std::string& def, const std::vector<std::string>& choices);
  /// A list of distinct integers in [0, bound).
  std::vector<int> indices(const std::string& key, const std::vector<int>& def, int bound);
  /// Removes and returns the raw node of a key (null node when absent).
  YAML::Node take(const std::string& key);
  /// Throws ConfigError naming every key that was never read.
  void rejectUnknown() const;
  const std::string& source() const { return source_; }

private:
  YAML::Node params_;
  std::string source_;
  std::set<std::string> used_;
};

}  // namespace networked_estimation
