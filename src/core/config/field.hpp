// The one checked-field reader of every configuration: model files, estimator and channel
// settings, schedules, motions, the nodelets' parameters (converted to YAML) and the Python keyword
// arguments (converted to YAML). A Field is a YAML value with where it came from (source, line, key
// path); its typed accessors throw ConfigError "<source>:<line>: <key>: <problem>" (the line is
// omitted when unknown, e.g. for parameters from the parameter server). A parser is a declared
// table of its keys (readKeys): the table is what the parser reads, so the known keys of a map are
// the table's and an unknown key cannot drift from what is read. Private to the core.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Dense>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/common/covariance.hpp"

namespace networked_estimation
{
namespace detail
{

/// A configuration value: its YAML node, its key path ("sensors[1].R"; "" for the document root)
/// and its source (a file name, "Link()", a nodelet's name). Cheap to copy.
class Field
{
public:
  /// Where the document comes from. A FILE's messages give the line and name a value of the wrong
  /// kind by its kind ("found a list": the line points at it). PARAMETERS (from the parameter
  /// server) have no lines: the messages show the value itself ("found '[a, b]'").
  enum class Origin
  {
    FILE,
    PARAMETERS
  };

  /// The document root of `source`.
  Field(YAML::Node node, const std::string& source, Origin origin = Origin::FILE);

  const YAML::Node& node() const { return node_; }
  const std::string& key() const { return key_; }
  const std::string& source() const { return origin_->source; }
  /// 1-based line, 0 when unknown (an absent key, PARAMETERS).
  int line() const;
  /// Whether the value is given (an absent key is not; `key: null` is).
  bool present() const { return node_.IsDefined(); }
  explicit operator bool() const { return present(); }
  // (An absent field is none of these: yaml-cpp throws on the type of an absent key's node.)
  bool isMap() const { return present() && node_.IsMap(); }
  bool isList() const { return present() && node_.IsSequence(); }
  bool isScalar() const { return present() && node_.IsScalar(); }
  /// The scalar's text ("" for anything else).
  std::string text() const { return isScalar() ? node_.Scalar() : std::string(); }

  /// What this value is, for "found ..." in messages ("nothing", "null", "'text'", "a list" or
  /// the value, see Origin).
  std::string found() const;

  /// ConfigError "<source>:<line>: <key>: <problem>" at this value.
  [[noreturn]] void fail(const std::string& problem) const;
  /// The same, naming `key` (a path of its own, e.g. a child that is absent) at this value's line.
  [[noreturn]] void failAt(const std::string& key, const std::string& problem) const;

  /// Child `name` of a map (absent when not given); its key path is "<key>.<name>".
  Field operator[](const std::string& name) const;
  /// Element i of a list; its key path is "<key>[i]".
  Field operator[](std::size_t i) const;
  /// Number of elements of a list or entries of a map (0 for a scalar).
  std::size_t size() const { return isList() || isMap() ? node_.size() : 0; }
  /// The elements of a list, in order.
  std::vector<Field> elements() const;
  /// Child `name`; "missing required key" (with `why` in parentheses) when absent.
  Field required(const std::string& name, const std::string& why = "") const;

  /// The value must be a map ("expected a map, found ...").
  void requireMap() const;
  /// The document root must be a map (an empty document is named as such).
  void requireTopMap() const;
  /// Every key of this map must be a plain name, given once and one of `known` ("unknown key
  /// (known keys: ...)" names them). readKeys() calls it with its table's names.
  void checkKeys(const std::vector<std::string>& known) const;

  /// Any number, including .nan / .inf (no finiteness check).
  double rawNumber() const;
  /// A finite number.
  double number() const;
  /// A number in [0, 1].
  double probability() const;
  /// A finite number >= 0; `what` names it in the message ("a non-negative <what>").
  double nonNegative(const std::string& what) const;
  /// A decimal integer in [min, 2^64 - 1].
  std::uint64_t integer(std::uint64_t min) const;
  /// true or false (also True/TRUE/False/FALSE); not yes/no/on/off/1/0.
  bool boolean() const;
  std::string string() const;
  /// One of `names` ("unknown <what> 'x' (expected one of: ...)"); returns its index.
  std::size_t oneOf(const std::string& what, const std::vector<std::string>& names) const;
  /// A non-empty matrix written as a list of rows of finite numbers. rows / cols < 0 leave that
  /// dimension free; `hint` explains the expected size, e.g. "n = 2 columns".
  Eigen::MatrixXd matrix(int rows, int cols, const std::string& hint) const;
  /// A flat list of exactly `size` finite numbers.
  Eigen::VectorXd vector(int size, const std::string& hint) const;
  /// Fails unless M (read from this value) is a covariance as checkCovariance() says; `label`
  /// names it in the message, e.g. "R".
  void checkCovariance(const Eigen::MatrixXd& M, const std::string& label, Definiteness definiteness) const;

private:
  struct Document
  {
    std::string source;
    Origin origin;
  };
  Field(std::shared_ptr<const Document> origin, YAML::Node node, std::string key);
  /// One finite matrix / vector entry; `where` is e.g. "entry (0,1)".
  double entry(const YAML::Node& node, const std::string& where) const;

  std::shared_ptr<const Document> origin_;
  YAML::Node node_;
  std::string key_;
};

/// One row of a parser's table: a key, how to read it when given, and what its absence means.
template <typename Out>
struct KeyRule
{
  std::string name;
  /// Reads the given value into the result.
  std::function<void(const Field& value, Out& out)> read;
  /// Called with the map when the key is absent (e.g. to fail when another key needs it); an
  /// empty function leaves the default.
  std::function<void(const Field& map, Out& out)> absent;
};

/// A key that must be given; `why` is added to "missing required key (...)".
template <typename Out>
KeyRule<Out> requiredKey(std::string name, std::function<void(const Field&, Out&)> read, std::string why = "")
{
  const std::string key = name;
  return KeyRule<Out>{std::move(name), std::move(read), [key, why](const Field& map, Out&) { map.required(key, why); }};
}

/// A key that may be left out (then `absent`, when given, runs).
template <typename Out>
KeyRule<Out> optionalKey(std::string name, std::function<void(const Field&, Out&)> read,
                         std::function<void(const Field&, Out&)> absent = {})
{
  return KeyRule<Out>{std::move(name), std::move(read), std::move(absent)};
}

/// The names of a table's keys, in order.
template <typename Out>
std::vector<std::string> keyNames(const std::vector<KeyRule<Out>>& table)
{
  std::vector<std::string> names;
  names.reserve(table.size());
  for (const KeyRule<Out>& rule : table)
  {
    names.push_back(rule.name);
  }
  return names;
}

/// Reads the map `map` by its table: refuses keys the table does not read (before reading any, so
/// that a typo is named as such), then runs each row in the table's order (a row may use what
/// earlier rows read).
template <typename Out>
void readKeys(const Field& map, const std::vector<KeyRule<Out>>& table, Out& out)
{
  map.requireMap();
  map.checkKeys(keyNames(table));
  for (const KeyRule<Out>& rule : table)
  {
    const Field value = map[rule.name];
    if (value.present())
    {
      rule.read(value, out);
    }
    else if (rule.absent)
    {
      rule.absent(map, out);
    }
  }
}

}  // namespace detail
}  // namespace networked_estimation
