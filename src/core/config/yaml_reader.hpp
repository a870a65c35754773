// The YAML helpers of the configuration readers: the one grammar of booleans and integers, key
// paths, messages shaped "<source>:<line>: <key>: <problem>" (the line is omitted when unknown),
// matrix checks without a node, and loading a file. The typed reader itself is config/field.hpp.
// Private to the core.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/covariance.hpp"
#include "networked_estimation/common/number_format.hpp"

namespace networked_estimation
{
namespace detail
{

// Number formatting is common/number_format.hpp's.
using networked_estimation::formatNumber;
using networked_estimation::plainNumber;
/// The one grammar of a boolean in every configuration (files, ROS parameters, settings):
/// true, True, TRUE, false, False, FALSE. False when `text` is none of them.
bool booleanText(const std::string& text, bool& out);
/// The one grammar of an integer: an optional sign and decimal digits. False when `text` is not
/// one or it is beyond long long.
bool integerText(const std::string& text, long long& out);
/// "RxC".
std::string dims(Eigen::Index rows, Eigen::Index cols);
/// "a, b, c".
std::string joinList(const std::vector<std::string>& items);
/// Key path of a child: "a" + "b" -> "a.b"; "" + "b" -> "b".
std::string childKey(const std::string& prefix, const std::string& key);
/// "prefix[i]".
std::string indexKey(const std::string& prefix, std::size_t i);
/// What a node holds, for "found ..." in messages.
std::string describe(const YAML::Node& node);
/// "<source>:<line>: <key>: <problem>", or without ":<line>" when line <= 0, without "<key>: "
/// when key is empty.
std::string message(const std::string& source, int line, const std::string& key, const std::string& problem);
/// 1-based line of a node, 0 when unknown.
int lineOf(const YAML::Node& node);

// Checks on matrices, shared by parseModel (with line numbers) and validateModel (without).
// Each returns the problem text, or "" when the matrix is fine.
std::string finitenessProblem(const Eigen::MatrixXd& M, const std::string& label);
/// "<label>(i,j) = inf" for M's first infinite entry (an overflow: the cause of a NaN made from
/// it, e.g. 0 inf), else for its first NaN; "" when M is finite.
std::string nonFiniteEntry(const Eigen::MatrixXd& M, const std::string& label);
// Symmetry and definiteness: common/covariance.hpp (checkCovariance).

/// "n = 3".
std::string countText(const char* what, int value);

/// Reads a file into a YAML document, turning I/O and syntax errors into ConfigError.
YAML::Node loadYamlFile(const std::string& path);

/// Runs a parser, turning any stray yaml-cpp exception into a ConfigError naming the source.
template <typename F>
auto guarded(const std::string& source, F&& parse) -> decltype(parse())
{
  try
  {
    return parse();
  }
  catch (const YAML::Exception& e)
  {
    throw ConfigError(message(source, 0, "", std::string("YAML error: ") + e.what()));
  }
}

}  // namespace detail
}  // namespace networked_estimation
