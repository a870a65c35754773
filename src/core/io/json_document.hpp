// A JSON file read with nlohmann/json, with what its readers need for their messages: the line of
// every object, array and member (JsonDocument::where), a repeated key refused, and accessors that
// name the field as the file spells it and the expected type (JsonField). Private to the core: the
// readers of the package's JSON files (montecarlo's shard files) include it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace networked_estimation
{

class JsonDocument
{
public:
  /// Parses `text`, read from `path`. Throws InputError "PATH: line L, column C: ..." for a syntax
  /// error (naming a truncated file as such), a key given twice in one object, or a top-level
  /// value that is not an object.
  JsonDocument(const std::string& text, const std::string& path);

  const nlohmann::json& root() const { return root_; }
  const std::string& path() const { return path_; }
  /// "PATH: line L: " for the field `field` (as JsonField names it: "calls[0].blocks[2].mean"), the
  /// line of its nearest enclosing field that the file has a line for.
  std::string where(const std::string& field) const;

private:
  std::string path_;
  nlohmann::json root_;
  std::map<std::string, long> lines_;  ///< field -> line: objects, arrays and object members
};

/// A value of a JsonDocument with its field name, for checked reading.
class JsonField
{
public:
  JsonField(const JsonDocument& doc, const nlohmann::json& value, std::string field)
    : doc_(doc), value_(value), field_(std::move(field))
  {
  }

  const nlohmann::json& json() const { return value_; }
  const std::string& name() const { return field_; }
  /// The member `key` of this object (which must have it: see keys()).
  JsonField operator[](const std::string& key) const;
  /// The elements of this array.
  std::vector<JsonField> elements() const;

  /// Checks that this is an object whose keys are all in `allowed` and include all of `required`.
  void keys(const std::vector<std::string>& required, const std::vector<std::string>& optional = {}) const;

  std::string string() const;
  long integer(long min, long max) const;
  std::uint64_t uint64() const;
  bool boolean() const;
  /// A JSON number, or one of the strings "nan", "-nan", "inf", "-inf" (how the package writes the
  /// doubles JSON has no number for).
  double number() const;
  std::vector<double> numbers() const;
  std::vector<std::string> strings() const;

  /// Throws InputError "PATH: line L: 'FIELD': WHAT".
  [[noreturn]] void fail(const std::string& what) const;

private:
  /// Fails with "expected WHAT, found ..." unless `ok`.
  void expect(bool ok, const std::string& what) const;

  const JsonDocument& doc_;
  const nlohmann::json& value_;
  std::string field_;
};

}  // namespace networked_estimation
