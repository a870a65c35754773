// Numbers in messages and files (number_format.hpp).
#include "networked_estimation/common/number_format.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace networked_estimation
{

std::string formatNumber(double v, int max_digits)
{
  if (std::isnan(v))
    return "nan";
  if (std::isinf(v))
    return v > 0 ? "inf" : "-inf";
  char buf[64];
  for (int digits = 1; digits <= max_digits; ++digits)
  {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
    if (digits == max_digits || std::strtod(buf, nullptr) == v)
      break;
  }
  return buf;
}

std::string plainNumber(double v)
{
  const std::string text = formatNumber(v);
  const double magnitude = std::abs(v);
  if (!std::isfinite(v) || magnitude < 1.0 || magnitude >= 1e15 || text.find('e') == std::string::npos)
    return text;
  // %g chose an exponent because the exponent reached the digits needed: as many digits as the
  // integer part has are at least as many, so the text still reads back as v.
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", static_cast<int>(std::floor(std::log10(magnitude))) + 1, v);
  return buf;
}

}  // namespace networked_estimation
