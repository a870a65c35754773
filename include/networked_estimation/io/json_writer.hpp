// Writing JSON text (the analyze, montecarlo, sweep and shard outputs): members in the order the
// caller writes them, lines broken where the caller asks, and every key and value serialized by
// nlohmann/json (json_writer.cpp), so strings are escaped and numbers written as the library does.
#pragma once

#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace networked_estimation
{

/// Builds JSON text element by element. Separators are written for the caller: ", " between the
/// members or elements of a container and ": " after a key; br(n) replaces the space of the next
/// separator (or the place before the next closing bracket) by a newline and n spaces. A double
/// that is not finite is written as null; one that is a whole number below 2^53 as an integer
/// (2, not 2.0), any other as the shortest text that reads back to the same double.
class JsonWriter
{
public:
  /// A newline and `indent` spaces before the next member, element or closing bracket.
  JsonWriter& br(int indent);

  JsonWriter& beginObject();
  JsonWriter& endObject();
  JsonWriter& beginArray();
  JsonWriter& endArray();
  /// The key of the next member of the current object.
  JsonWriter& key(const std::string& name);

  JsonWriter& value(const std::string& s);
  JsonWriter& value(const char* s) { return value(std::string(s)); }
  JsonWriter& value(double v);
  JsonWriter& value(bool b);
  JsonWriter& null();
  template <class T,
            typename std::enable_if<std::is_integral<T>::value && !std::is_same<T, bool>::value, int>::type = 0>
  JsonWriter& value(T v)
  {
    return std::is_signed<T>::value ? integer(static_cast<std::int64_t>(v))
                                    : unsignedInteger(static_cast<std::uint64_t>(v));
  }
  JsonWriter& value(const std::vector<double>& v);
  JsonWriter& value(const std::vector<std::string>& v);

  /// key(name) then value(v).
  template <class T>
  JsonWriter& member(const std::string& name, const T& v)
  {
    key(name);
    return value(v);
  }

  /// The text written so far.
  const std::string& text() const { return out_; }

private:
  JsonWriter& integer(std::int64_t v);
  JsonWriter& unsignedInteger(std::uint64_t v);
  /// Writes the separator before a member (key) or an array element, or nothing after a key.
  void separate();
  /// Writes a scalar's text.
  JsonWriter& scalar(const std::string& text);
  JsonWriter& close(char bracket);

  std::string out_;
  std::string break_;        ///< the pending line break ("\n" and spaces), empty for none
  std::vector<bool> empty_;  ///< per open container: nothing in it yet
  bool after_key_ = false;
};

}  // namespace networked_estimation
