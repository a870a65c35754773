// JsonDocument and JsonField (json_document.hpp).
#include "io/json_document.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

namespace
{

/// Line and column (from 1) of byte `offset` (from 0) of `text`.
std::string lineColumn(const std::string& text, std::size_t offset)
{
  long line = 1, column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i)
  {
    if (text[i] == '\n')
    {
      ++line;
      column = 1;
    }
    else
      ++column;
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

/// The byte at `offset` as a message shows it.
std::string byteAt(const std::string& text, std::size_t offset)
{
  if (offset >= text.size())
    return "the end of the file (truncated?)";
  const unsigned char c = static_cast<unsigned char>(text[offset]);
  if (c < 0x20 || c >= 0x7f)
    return "byte " + std::to_string(c);
  return std::string("'") + static_cast<char>(c) + "'";
}

/// The library's description of a syntax error, without its "[json.exception...] parse error at
/// ...: " prefix (the caller names the place).
std::string syntaxProblem(const std::string& what)
{
  const std::string::size_type at = what.find("syntax error");
  if (at != std::string::npos)
    return what.substr(at);
  const std::string::size_type bracket = what.find("] ");
  return bracket == std::string::npos ? what : what.substr(bracket + 2);
}

/// The position of the parser in the text, kept with the names of the open containers as the
/// parser's callback reports them: each object, array and object member gets its line.
class LineTracker
{
public:
  LineTracker(const std::string& text, std::stringbuf& buf, std::map<std::string, long>& lines, const std::string& path)
    : text_(text), buf_(buf), lines_(lines), path_(path)
  {
  }

  bool operator()(int /*depth*/, nlohmann::json::parse_event_t event, nlohmann::json& parsed)
  {
    using E = nlohmann::json::parse_event_t;
    switch (event)
    {
      case E::object_start:
      case E::array_start:
      {
        const std::string name = stack_.empty() ? std::string() : child();
        lines_[name] = line();
        stack_.push_back({event == E::object_start, name, "", 0, {}});
        break;
      }
      case E::key:
      {
        Frame& f = stack_.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second)
          throw InputError(path_ + ": line " + std::to_string(line()) + ": key '" + f.key + "' given twice" +
                           (f.name.empty() ? std::string() : " in '" + f.name + "'"));
        break;
      }
      case E::value:
        if (!stack_.empty())
        {
          if (stack_.back().object)
            lines_[child()] = line();  // array elements take their array's line (the numbers of a row)
          else
            ++stack_.back().index;
        }
        break;
      case E::object_end:
      case E::array_end:
        stack_.pop_back();
        if (!stack_.empty() && !stack_.back().object)
          ++stack_.back().index;
        break;
    }
    return true;
  }

private:
  struct Frame
  {
    bool object;
    std::string name;
    std::string key;    ///< objects: the current member's key
    std::size_t index;  ///< arrays: the current element's index
    std::set<std::string> keys;
  };

  std::string child() const
  {
    const Frame& f = stack_.back();
    if (!f.object)
      return f.name + "[" + std::to_string(f.index) + "]";
    return f.name.empty() ? f.key : f.name + "." + f.key;
  }

  /// The line of the last byte the parser has read (the stream's position is just past it).
  long line()
  {
    const std::streamoff pos = buf_.pubseekoff(0, std::ios_base::cur, std::ios_base::in);
    const std::size_t end = pos > 0 ? std::min(static_cast<std::size_t>(pos) - 1, text_.size()) : 0;
    for (; counted_ < end; ++counted_)
      if (text_[counted_] == '\n')
        ++line_;
    return line_;
  }

  const std::string& text_;
  std::stringbuf& buf_;
  std::map<std::string, long>& lines_;
  const std::string& path_;
  std::vector<Frame> stack_;
  std::size_t counted_ = 0;
  long line_ = 1;
};

}  // namespace

JsonDocument::JsonDocument(const std::string& text, const std::string& path) : path_(path)
{
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || text[first] != '{')
    throw InputError(path + ": " + lineColumn(text, first == std::string::npos ? text.size() : first) +
                     ": expected '{', found " + byteAt(text, first == std::string::npos ? text.size() : first));
  std::istringstream in(text);
  LineTracker tracker(text, *in.rdbuf(), lines_, path_);
  try
  {
    root_ = nlohmann::json::parse(in, std::ref(tracker));
  }
  catch (const nlohmann::json::parse_error& e)
  {
    // e.byte counts from 1 and is past the end for an error at the end of the text
    const std::size_t at = e.byte > 0 ? e.byte - 1 : 0;
    const std::string problem = syntaxProblem(e.what());
    throw InputError(path + ": " + lineColumn(text, at) + ": " + problem +
                     (at >= text.size() ? " (the file ends early: truncated?)" : ""));
  }
  catch (const nlohmann::json::exception& e)  // a number beyond the doubles: where the parser stopped
  {
    const std::streamoff pos = in.rdbuf()->pubseekoff(0, std::ios_base::cur, std::ios_base::in);
    const std::size_t at = pos > 0 ? std::min(static_cast<std::size_t>(pos) - 1, text.size()) : 0;
    throw InputError(path + ": " + lineColumn(text, at) + ": " + syntaxProblem(e.what()));
  }
}

std::string JsonDocument::where(const std::string& field) const
{
  std::string f = field;
  while (true)
  {
    const auto it = lines_.find(f);
    if (it != lines_.end())
      return path_ + ": line " + std::to_string(it->second) + ": ";
    const std::string::size_type cut = f.find_last_of(".[");
    if (cut == std::string::npos)
      return path_ + ": ";
    f = f.substr(0, cut);
  }
}

// ---------------------------------------------------------------------------------------------

void JsonField::fail(const std::string& what) const
{
  throw InputError(doc_.where(field_) + (field_.empty() ? std::string() : "'" + field_ + "': ") + what);
}

void JsonField::expect(bool ok, const std::string& what) const
{
  if (ok)
    return;
  std::string found = value_.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (found.size() > 40)
    found = found.substr(0, 37) + "...";
  fail("expected " + what + ", found " + found);
}

JsonField JsonField::operator[](const std::string& key) const
{
  expect(value_.is_object(), "an object");
  const auto it = value_.find(key);
  if (it == value_.end())
    fail("missing key '" + key + "'");
  return JsonField(doc_, *it, field_.empty() ? key : field_ + "." + key);
}

std::vector<JsonField> JsonField::elements() const
{
  expect(value_.is_array(), "an array");
  std::vector<JsonField> v;
  v.reserve(value_.size());
  for (std::size_t i = 0; i < value_.size(); ++i)
    v.emplace_back(doc_, value_[i], field_ + "[" + std::to_string(i) + "]");
  return v;
}

void JsonField::keys(const std::vector<std::string>& required, const std::vector<std::string>& optional) const
{
  expect(value_.is_object(), "an object");
  for (const auto& kv : value_.items())
    if (std::find(required.begin(), required.end(), kv.key()) == required.end() &&
        std::find(optional.begin(), optional.end(), kv.key()) == optional.end())
      JsonField(doc_, kv.value(), field_.empty() ? kv.key() : field_ + "." + kv.key()).fail("unknown key");
  for (const std::string& k : required)
    if (value_.find(k) == value_.end())
      fail("missing key '" + k + "'");
}

std::string JsonField::string() const
{
  expect(value_.is_string(), "a string");
  return value_.get<std::string>();
}

long JsonField::integer(long min, long max) const
{
  const std::string range = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  expect(value_.is_number_integer(), range);
  if (value_.is_number_unsigned())
  {
    const std::uint64_t u = value_.get<std::uint64_t>();
    expect((min < 0 || u >= static_cast<std::uint64_t>(min)) && u <= static_cast<std::uint64_t>(max), range);
    return static_cast<long>(u);
  }
  const std::int64_t v = value_.get<std::int64_t>();
  expect(v >= min && v <= max, range);
  return static_cast<long>(v);
}

std::uint64_t JsonField::uint64() const
{
  expect(value_.is_number_unsigned(), "a non-negative integer");
  return value_.get<std::uint64_t>();
}

bool JsonField::boolean() const
{
  expect(value_.is_boolean(), "true or false");
  return value_.get<bool>();
}

double JsonField::number() const
{
  const std::string what = "a number or \"nan\", \"-nan\", \"inf\", \"-inf\"";
  if (value_.is_string())
  {
    const std::string s = value_.get<std::string>();
    expect(s == "nan" || s == "-nan" || s == "inf" || s == "-inf", what);
    return std::strtod(s.c_str(), nullptr);  // keeps the sign of a NaN
  }
  expect(value_.is_number(), what);
  const double v = value_.get<double>();
  expect(std::isfinite(v), "a number in range");
  return v;
}

std::vector<double> JsonField::numbers() const
{
  expect(value_.is_array(), "an array");
  std::vector<double> v;
  v.reserve(value_.size());
  for (std::size_t i = 0; i < value_.size(); ++i)
  {
    const nlohmann::json& e = value_[i];
    // a finite number directly; anything else through number(), which names the element
    v.push_back(e.is_number() && std::isfinite(e.get<double>())
                    ? e.get<double>()
                    : JsonField(doc_, e, field_ + "[" + std::to_string(i) + "]").number());
  }
  return v;
}

std::vector<std::string> JsonField::strings() const
{
  std::vector<std::string> v;
  for (const JsonField& e : elements())
    v.push_back(e.string());
  return v;
}

}  // namespace networked_estimation
