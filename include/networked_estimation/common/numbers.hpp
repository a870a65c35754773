// The two special doubles the core writes by name: NaN (not computed, not applicable) and +inf.
#pragma once

#include <limits>

namespace networked_estimation
{

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace networked_estimation
