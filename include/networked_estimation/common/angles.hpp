// Angles: the one wrap of the package (docs/algorithms.md 2.7). An angle is represented in
// (-pi, pi]; the difference of two angles (an innovation, an estimation error) is the shortest
// turn between them, also in (-pi, pi].
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

namespace networked_estimation
{

/// pi as a double (the nearest double; 2 kPi is exactly the double nearest to 2 pi).
constexpr double kPi = 3.14159265358979323846;

/// a wrapped into (-pi, pi]: a - 2 pi j for the integer j that lands there. An angle already in
/// the interval is returned unchanged (no arithmetic, so an unwrapped quantity stays bit-exact);
/// a non-finite value is returned as it is.
inline double wrapAngle(double a)
{
  if (a > -kPi && a <= kPi)
    return a;
  if (!std::isfinite(a))
    return a;
  // std::remainder is exact: r = a - 2 kPi j with j the nearest integer to a / (2 kPi), |r| <= kPi
  const double r = std::remainder(a, 2.0 * kPi);
  return r <= -kPi ? r + 2.0 * kPi : r;
}

/// Wraps the entries `indices` (each + offset) of v: a vector, or every column of a matrix.
template <class Derived>
inline void wrapEntries(Derived& v, const std::vector<int>& indices, int offset = 0)
{
  for (const int i : indices)
    for (decltype(v.cols()) c = 0; c < v.cols(); ++c)
      v(i + offset, c) = wrapAngle(v(i + offset, c));
}

/// ||x - xhat||^2 with the entries `angles` (ascending) taken as angles, their difference wrapped:
/// the squared estimation error of every tool that scores an estimate.
template <class A, class B>
inline double squaredError(const A& x, const B& xhat, const std::vector<int>& angles)
{
  if (angles.empty())
    return (x - xhat).squaredNorm();
  double sum = 0.0;
  std::size_t next = 0;
  for (decltype(x.size()) i = 0; i < x.size(); ++i)
  {
    double d = x[i] - xhat[i];
    if (next < angles.size() && angles[next] == i)
    {
      d = wrapAngle(d);
      ++next;
    }
    sum += d * d;
  }
  return sum;
}

}  // namespace networked_estimation
