// Private to the core: a text split into fields, a whole field read as a number (the option and
// file readers: --axis ranges, simulate's command and trace fields, CSV cells), and a number
// written into a message.
#pragma once

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace networked_estimation
{
namespace tokens
{

/// `text` split on `sep`, empty fields kept ("a::b" is a, "", b; "" is one empty field).
inline std::vector<std::string> split(const std::string& text, char sep)
{
  std::vector<std::string> parts;
  std::string::size_type start = 0;
  for (;;)
  {
    const std::string::size_type at = text.find(sep, start);
    parts.push_back(text.substr(start, at == std::string::npos ? std::string::npos : at - start));
    if (at == std::string::npos)
      return parts;
    start = at + 1;
  }
}

/// The whole text as a finite double: no leading space, nothing after the number, in range.
/// `out` is set only on success.
inline bool parseFinite(const std::string& text, double& out)
{
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front())))
    return false;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v))
    return false;
  out = v;
  return true;
}

/// The whole text as a long integer (base 10), as parseFinite.
inline bool parseLong(const std::string& text, long& out)
{
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front())))
    return false;
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE)
    return false;
  out = v;
  return true;
}

/// `v` with `significant` digits as printf's %g writes it ("20", "0.05", "1e-09").
inline std::string format(double v, int significant)
{
  std::ostringstream o;
  o.precision(significant);
  o << v;
  return o.str();
}

}  // namespace tokens
}  // namespace networked_estimation
