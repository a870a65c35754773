// JsonWriter (json_writer.hpp): the layout here, every scalar's text from nlohmann/json.
#include "networked_estimation/io/json_writer.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

namespace networked_estimation
{

namespace
{

/// The library's text of a value. Bytes that are not UTF-8 (a path in another encoding) are
/// written as U+FFFD rather than refused: the outputs are reports, and JSON has no other way.
std::string dump(const nlohmann::json& v)
{
  return v.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace

JsonWriter& JsonWriter::br(int indent)
{
  break_ = "\n" + std::string(static_cast<std::size_t>(indent > 0 ? indent : 0), ' ');
  return *this;
}

void JsonWriter::separate()
{
  if (after_key_)
  {
    after_key_ = false;
    return;
  }
  if (!empty_.empty())
  {
    if (!empty_.back())
      out_ += ',';
    out_ += break_.empty() ? (empty_.back() ? "" : " ") : break_;
    empty_.back() = false;
  }
  break_.clear();
}

JsonWriter& JsonWriter::beginObject()
{
  separate();
  out_ += '{';
  empty_.push_back(true);
  return *this;
}

JsonWriter& JsonWriter::beginArray()
{
  separate();
  out_ += '[';
  empty_.push_back(true);
  return *this;
}

JsonWriter& JsonWriter::close(char bracket)
{
  out_ += break_;
  break_.clear();
  out_ += bracket;
  if (!empty_.empty())
    empty_.pop_back();
  return *this;
}

JsonWriter& JsonWriter::endObject()
{
  return close('}');
}

JsonWriter& JsonWriter::endArray()
{
  return close(']');
}

JsonWriter& JsonWriter::key(const std::string& name)
{
  separate();
  out_ += dump(name) + ": ";
  after_key_ = true;
  return *this;
}

JsonWriter& JsonWriter::scalar(const std::string& text)
{
  separate();
  out_ += text;
  return *this;
}

JsonWriter& JsonWriter::value(const std::string& s)
{
  return scalar(dump(s));
}

JsonWriter& JsonWriter::value(double v)
{
  if (!std::isfinite(v))
    return null();
  // a whole number as an integer: 2 rather than the library's 2.0 (the same JSON number)
  if (v == std::floor(v) && std::fabs(v) < 9007199254740992.0 && !(v == 0.0 && std::signbit(v)))
    return integer(static_cast<std::int64_t>(v));
  return scalar(dump(v));
}

JsonWriter& JsonWriter::value(bool b)
{
  return scalar(dump(b));
}

JsonWriter& JsonWriter::null()
{
  return scalar(dump(nullptr));
}

JsonWriter& JsonWriter::integer(std::int64_t v)
{
  return scalar(dump(v));
}

JsonWriter& JsonWriter::unsignedInteger(std::uint64_t v)
{
  return scalar(dump(v));
}

JsonWriter& JsonWriter::value(const std::vector<double>& v)
{
  beginArray();
  for (double x : v)
    value(x);
  return endArray();
}

JsonWriter& JsonWriter::value(const std::vector<std::string>& v)
{
  beginArray();
  for (const std::string& s : v)
    value(s);
  return endArray();
}

}  // namespace networked_estimation
