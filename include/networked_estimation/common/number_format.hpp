// Numbers in messages and files: the shortest text that reads back as the same double.
#pragma once

#include <string>

namespace networked_estimation
{

/// Shortest decimal text that reads back as exactly `v` (at most `max_digits` significant digits);
/// "nan", "inf", "-inf" for the special values.
std::string formatNumber(double v, int max_digits = 17);
/// formatNumber without an exponent for magnitudes in [1, 1e15): "20", not "2e+01".
std::string plainNumber(double v);

}  // namespace networked_estimation
