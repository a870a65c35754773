// Small helpers for writing JSON text by hand (the montecarlo and analyze tools' JSON outputs).
#pragma once

#include <cstdio>
#include <string>

namespace networked_estimation
{

/// `s` as a JSON string literal (quoted; ", \, newline, carriage return and tab escaped, the other
/// control characters as \u00XX; bytes >= 0x80 copied unchanged).
inline std::string jsonString(const std::string& s)
{
  std::string out = "\"";
  for (unsigned char c : s)
  {
    switch (c)
    {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (c < 0x20)
        {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        }
        else
          out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

}  // namespace networked_estimation
