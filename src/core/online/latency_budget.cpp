// The adaptive latency budget and the per-sensor losses to lateness (latency_budget.hpp).
#include "networked_estimation/online/latency_budget.hpp"

#include <algorithm>
#include <functional>
#include <cmath>
#include <limits>

namespace networked_estimation
{

LatencyBudget::LatencyBudget(std::size_t sensors, const LatencyOptions& options) : options_(options)
{
  sensors_.resize(sensors);
  clear();
}

void LatencyBudget::setOptions(const LatencyOptions& options)
{
  options_ = options;
  update();
}

void LatencyBudget::start(double now)
{
  start_ = now;
  starting_ = true;
  update();
}

void LatencyBudget::at(double now)
{
  if (starting_ && !(now < start_ + kStartup))
  {
    starting_ = false;
    update();
  }
}

void LatencyBudget::clear()
{
  starting_ = false;
  for (PerSensor& s : sensors_)
  {
    s.delays.clear();
    s.next = 0;
    s.quantile = std::numeric_limits<double>::quiet_NaN();
    s.buckets.fill(Bucket());
  }
  update();
}

LatencyBudget::Bucket& LatencyBudget::bucket(PerSensor& s, double now)
{
  const long second = static_cast<long>(std::floor(now));
  Bucket& b = s.buckets[static_cast<std::size_t>(((second % kLateSeconds) + kLateSeconds) % kLateSeconds)];
  if (b.second != second)
    b = Bucket{second, 0, 0};
  return b;
}

void LatencyBudget::arrived(std::size_t sensor, double delay, double now)
{
  PerSensor& s = sensors_[sensor];
  ++bucket(s, now).received;
  if (!std::isfinite(delay))
    return;
  if (s.delays.size() < kWindow)
    s.delays.push_back(delay);
  else
    s.delays[s.next] = delay;
  s.next = (s.next + 1) % kWindow;
  // The kQuantile-th (nearest rank), but never the largest of two or more: the (n - rank)-th
  // largest, found among the few largest (2 or 3 of the window's 256) without copying the window.
  const std::size_t n = s.delays.size();
  const std::size_t rank =
      n < 2 ? 0 : std::min(n - 2, static_cast<std::size_t>(std::ceil(kQuantile * static_cast<double>(n))) - 1);
  scratch_.resize(n - rank);
  std::partial_sort_copy(s.delays.begin(), s.delays.end(), scratch_.begin(), scratch_.end(), std::greater<double>());
  s.quantile = scratch_.back();
  update();
}

double LatencyBudget::medianDelay(std::size_t sensor) const
{
  std::vector<double> d = sensors_[sensor].delays;
  if (d.empty())
    return std::numeric_limits<double>::quiet_NaN();
  // Nearest rank: the ceil(n / 2)-th smallest.
  const auto mid = d.begin() + static_cast<std::ptrdiff_t>((d.size() + 1) / 2 - 1);
  std::nth_element(d.begin(), mid, d.end());
  return *mid;
}

void LatencyBudget::lost(std::size_t sensor, double now)
{
  ++bucket(sensors_[sensor], now).lost;
}

void LatencyBudget::refused(std::size_t sensor, double now)
{
  Bucket& b = bucket(sensors_[sensor], now);
  ++b.received;
  ++b.lost;
}

void LatencyBudget::update()
{
  if (!options_.adaptive)
  {
    budget_ = options_.fixed;
    return;
  }
  double need = options_.min;
  for (const PerSensor& s : sensors_)
    if (std::isfinite(s.quantile))
      need = std::max(need, s.quantile + 0.5 * options_.period + 0.5 * std::max(0.0, s.quantile));
    else if (starting_)
      need = options_.max;  // not heard from yet
  budget_ = std::min(std::max(need, options_.min), options_.max);
}

LatencyBudget::Window LatencyBudget::window(std::size_t sensor, double now) const
{
  Window w;
  const long second = static_cast<long>(std::floor(now));
  for (const Bucket& b : sensors_[sensor].buckets)
    if (b.second > second - kLateSeconds && b.second <= second)
    {
      w.received += b.received;
      w.lost += b.lost;
    }
  return w;
}

}  // namespace networked_estimation
