// A sensor's sample lattice learnt from its stamps (sensor_lattice.hpp).
#include "networked_estimation/online/sensor_lattice.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace networked_estimation
{
namespace
{

// Loop gains of the phase-locked loop, per fitted sample: the phase moves by kAlpha of the error,
// the spacing by kBeta of it per lattice step (kBeta = kAlpha^2 / 4: critically damped). With a
// uniform +-20 % jitter (standard deviation 0.115 spacing) the phase estimate's own noise is about
// 0.115 sqrt(kAlpha / (2 - kAlpha)) = 0.026 spacing.
constexpr double kAlpha = 0.1;
constexpr double kBeta = 0.0025;
// A whole-ratio lattice moves its steps by one when it has drifted this many spacings past half a
// step: about six times the phase estimate's noise, so that a sensor whose stamps sit half a step
// off the grid does not flip between two steps.
constexpr double kHysteresis = 0.15;
constexpr std::size_t kRecent = 20;
constexpr int kRecentOffMismatch = 5;
constexpr int kOffInRow = 3;
constexpr double kSpacingBound = 0.25;

}  // namespace

double SensorLattice::whole(double ratio)
{
  const double q = std::round(ratio);
  return q >= 1.0 && std::fabs(ratio - q) <= kWholeTolerance * ratio ? q : ratio;
}

SensorLattice::SensorLattice(double ratio) : ratio_(ratio), rho_(ratio)
{
  const double q = whole(ratio);
  if (q == std::round(q))
    whole_ = std::lround(q);
}

SensorLattice::Fit SensorLattice::fit(double position, long given) const
{
  Fit f;
  if (!locked_)
  {
    f.step = given >= 1 ? given : std::lround(position);
    f.index = 1;
    return f;
  }
  f.index = std::lround((position - phase_) / rho_);
  const double p = phase_ + static_cast<double>(f.index) * rho_;
  f.error = position - p;
  double tolerance = kJitterTolerance * rho_;
  if (given >= 1)  // a named step was rounded by its sender: up to half a step more
    tolerance = std::min(0.5 * rho_, tolerance + 0.5);
  f.fits = std::fabs(f.error) <= tolerance;
  if (given >= 1)
    f.step = given;
  else if (!f.fits)
    f.step = std::lround(position);
  else if (whole_ > 0)
  {
    long k = ref_step_ + f.index * whole_;
    const double offset = p - static_cast<double>(k);
    if (std::fabs(offset) > 0.5 + kHysteresis * rho_)
      k += std::lround(offset);
    f.step = k;
  }
  else
    f.step = std::lround(p);
  return f;
}

void SensorLattice::relock(double position, long step)
{
  locked_ = true;
  phase_ = position;
  rho_ = ratio_;
  ref_step_ = step;
  off_in_row_ = 0;
}

bool SensorLattice::learn(double position, const Fit& f)
{
  recent_.push_back(f.fits);
  positions_.push_back(position);
  if (recent_.size() > kRecent)
  {
    recent_.pop_front();
    positions_.pop_front();
  }
  if (!locked_)
  {
    relock(position, f.step);
    return false;
  }
  if (!f.fits)
  {
    ++off_total_;
    if (++off_in_row_ < kOffInRow)
      return false;
    relock(position, f.step);
    ++relearnt_;
    return true;
  }
  off_in_row_ = 0;
  if (f.index <= 0)
    return false;  // not newer than the reference point (out of order, or a second copy)
  const double p = phase_ + static_cast<double>(f.index) * rho_;
  rho_ += kBeta * f.error / static_cast<double>(f.index);
  phase_ = p + kAlpha * f.error;
  ref_step_ = f.step;
  if (std::fabs(rho_ / ratio_ - 1.0) > kSpacingBound)
  {
    relock(position, f.step);
    ++relearnt_;
    return true;
  }
  return false;
}

bool SensorLattice::due(long k) const
{
  if (ratio_ <= 1.0)
    return true;
  if (!locked_)
    return false;
  if (whole_ > 0)
  {
    const long d = (k - ref_step_) % whole_;
    return d == 0;
  }
  const long j = std::lround((static_cast<double>(k) - phase_) / rho_);
  for (long i = j - 1; i <= j + 1; ++i)
    if (std::lround(phase_ + static_cast<double>(i) * rho_) == k)
      return true;
  return false;
}

double SensorLattice::measuredRate(double period) const
{
  double span = 0.0;
  long spacings = 0;
  for (std::size_t i = 1; i < positions_.size(); ++i)
  {
    const double d = positions_[i] - positions_[i - 1];
    if (!(d > 0.0))
      continue;  // out of order
    span += d;
    spacings += std::max(1L, std::lround(d / ratio_));
  }
  return spacings > 0 ? static_cast<double>(spacings) / (span * period) : std::numeric_limits<double>::quiet_NaN();
}

bool SensorLattice::mismatch(double period, std::string* why) const
{
  const long off = std::count(recent_.begin(), recent_.end(), false);
  std::ostringstream s;
  s.precision(4);
  const double configured = 1.0 / (ratio_ * period), learnt = 1.0 / (rho_ * period);
  if (recent_.size() >= kRecent && off >= kRecentOffMismatch)
    s << off << " of its last " << kRecent << " samples are off its " << configured
      << " Hz sample times: its stamps say " << measuredRate(period) << " Hz";
  else if (locked_ && std::fabs(rho_ / ratio_ - 1.0) > kRateMismatch)
    s << "its stamps say " << learnt << " Hz, `rate` says " << configured << " Hz";
  else
    return false;
  if (why)
    *why = s.str();
  return true;
}

void SensorLattice::reset()
{
  locked_ = false;
  rho_ = ratio_;
  off_in_row_ = 0;
  recent_.clear();
  positions_.clear();
}

}  // namespace networked_estimation
