// The shared YAML reader of the configuration files (model, estimator settings, channel settings):
// typed access to YAML nodes and matrix checks, each failure a ConfigError shaped
// "<source>:<line>: <key>: <problem>" (the line is omitted when unknown), where <key> is the full
// key path (e.g. "sensors[1].R", "control_link.failure"). Private to the core.
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

/// Typed access to YAML nodes, throwing ConfigError with source, line and key path.
class Reader
{
public:
  explicit Reader(const std::string& source) : source_(source) {}

  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& problem) const;

  /// The document root must be a map.
  void requireTopMap(const YAML::Node& node) const;

  /// A nested value that must be a map.
  void requireMap(const YAML::Node& node, const std::string& key) const;

  /// Rejects non-scalar, duplicate and unknown keys of `map` (whose own key path is `prefix`).
  void checkKeys(const YAML::Node& map, const std::string& prefix, const std::vector<std::string>& known) const;

  /// Child `key` of `map`; throws "missing required key" (with `why` appended) when absent.
  YAML::Node require(const YAML::Node& map, const std::string& prefix, const std::string& key,
                     const std::string& why = "") const;

  /// Any number, including .nan / .inf (no finiteness check).
  double rawNumber(const YAML::Node& node, const std::string& key) const;

  /// A finite number.
  double number(const YAML::Node& node, const std::string& key) const;

  double probability(const YAML::Node& node, const std::string& key) const;

  double nonNegative(const YAML::Node& node, const std::string& key, const std::string& what) const;

  /// A decimal integer in [min, 2^64 - 1].
  std::uint64_t integer(const YAML::Node& node, const std::string& key, std::uint64_t min) const;

  /// true or false (also True/TRUE/False/FALSE, YAML 1.2); not yes/no/on/off/1/0.
  bool boolean(const YAML::Node& node, const std::string& key) const;

  std::string string(const YAML::Node& node, const std::string& key) const;

  /// One of `names`; returns its index.
  std::size_t choice(const YAML::Node& node, const std::string& key, const std::string& what,
                     const std::vector<std::string>& names) const;

  /// A non-empty matrix written as a list of rows of finite numbers. rows / cols < 0 leave that
  /// dimension free; `hint` explains the expected size, e.g. "n = 2 columns".
  Eigen::MatrixXd matrix(const YAML::Node& node, const std::string& key, int rows, int cols,
                         const std::string& hint) const;

  /// A flat list of exactly `size` finite numbers.
  Eigen::VectorXd vector(const YAML::Node& node, const std::string& key, int size, const std::string& hint) const;

private:
  /// One finite matrix / vector entry; `where` is e.g. "entry (0,1)".
  double entry(const YAML::Node& node, const std::string& key, const std::string& where) const;

  std::string source_;
};

/// Checks symmetry and definiteness of a parsed matrix, failing at `node`.
void checkCovariance(const Reader& in, const YAML::Node& node, const std::string& key, const std::string& label,
                     const Eigen::MatrixXd& M, bool strict);

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
