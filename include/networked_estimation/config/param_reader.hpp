// Typed access to a parameter map (a nodelet's private parameters, converted to YAML) with
// messages naming the key: "<source>: <key>: expected ..., found ...". ROS-free.
#pragma once

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <vector>

namespace networked_estimation
{

/// Typed access to parameters (a YAML map) with the same kind of messages
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
