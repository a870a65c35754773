// A link's rates from its arrival sequence, shared by the live monitors and the offline fit
// (link_estimates.hpp).
#include "networked_estimation/link/link_estimates.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace networked_estimation
{

RateEstimate wilsonInterval(std::size_t successes, std::size_t trials, double z)
{
  // Wilson score interval: the set of p whose score test |phat - p| / sqrt(p (1 - p) / n) <= z
  // accepts; unlike the Wald interval it stays inside [0, 1] and keeps its coverage near 0 and 1.
  RateEstimate e;
  e.successes = successes;
  e.trials = trials;
  if (trials == 0)
  {
    e.value = std::numeric_limits<double>::quiet_NaN();
    return e;
  }
  const double n = static_cast<double>(trials);
  const double p = static_cast<double>(successes) / n;
  const double z2 = z * z;
  const double denom = 1.0 + z2 / n;
  const double center = (p + z2 / (2.0 * n)) / denom;
  const double half = z / denom * std::sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n));
  e.value = p;
  // At 0 (or all) successes the end is exactly 0 (1); the formula leaves a rounding error there.
  e.lower = successes == 0 ? 0.0 : std::max(0.0, center - half);
  e.upper = successes == trials ? 1.0 : std::min(1.0, center + half);
  return e;
}

void ArrivalCounts::addSample(bool arrived)
{
  ++samples;
  arrivals += arrived ? 1 : 0;
}

void ArrivalCounts::removeSample(bool arrived)
{
  --samples;
  arrivals -= arrived ? 1 : 0;
}

void ArrivalCounts::addTransition(bool previous_arrived, bool arrived)
{
  if (!previous_arrived)
  {
    ++after_loss;
    recovered += arrived ? 1 : 0;
  }
  else
  {
    ++after_arrival;
    failed += arrived ? 0 : 1;
  }
}

void ArrivalCounts::removeTransition(bool previous_arrived, bool arrived)
{
  if (!previous_arrived)
  {
    --after_loss;
    recovered -= arrived ? 1 : 0;
  }
  else
  {
    --after_arrival;
    failed -= arrived ? 0 : 1;
  }
}

ArrivalCounts countArrivals(const std::vector<std::uint8_t>& arrived)
{
  ArrivalCounts c;
  for (std::size_t k = 0; k < arrived.size(); ++k)
  {
    c.addSample(arrived[k] != 0);
    if (k > 0)
      c.addTransition(arrived[k - 1] != 0, arrived[k] != 0);
  }
  return c;
}

RateEstimate arrivalEstimate(const ArrivalCounts& c)
{
  return wilsonInterval(c.arrivals, c.samples);
}

RateEstimate recoveryEstimate(const ArrivalCounts& c)
{
  return wilsonInterval(c.recovered, c.after_loss);
}

RateEstimate failureEstimate(const ArrivalCounts& c)
{
  return wilsonInterval(c.failed, c.after_arrival);
}

LinkEstimate estimateLink(const ArrivalCounts& c)
{
  LinkEstimate e;
  e.arrival = arrivalEstimate(c);
  e.recovery = recoveryEstimate(c);
  e.failure = failureEstimate(c);
  return e;
}

namespace
{

/// On/off Gilbert-Elliott link with failure p and recovery r, kept inside (0, 1] so that the chain
/// is defined (an interval end of exactly 0 for r would be a link that never recovers).
LinkModel onOffLink(double p, double r)
{
  const double tiny = 1e-9;
  return LinkModel::gilbertElliott(std::min(1.0, std::max(tiny, p)), std::min(1.0, std::max(tiny, r)));
}

}  // namespace

LinkModel linkAt(const LinkEstimate& e, bool markov, IntervalEnd end)
{
  if (markov)
  {
    // A link that lost nothing has no recovery trials: its recovery rate is taken as 1 (isolated
    // losses at most: no loss was seen).
    const bool lost = e.recovery.trials > 0;
    switch (end)
    {
      case IntervalEnd::PESSIMISTIC:
        return onOffLink(e.failure.upper, lost ? e.recovery.lower : 1.0);
      case IntervalEnd::OPTIMISTIC:
        return onOffLink(e.failure.lower, lost ? e.recovery.upper : 1.0);
      case IntervalEnd::POINT:
        return onOffLink(e.failure.trials ? e.failure.value : 0.5, lost ? e.recovery.value : 1.0);
    }
  }
  switch (end)
  {
    case IntervalEnd::PESSIMISTIC:
      return LinkModel::iid(e.arrival.lower);
    case IntervalEnd::OPTIMISTIC:
      return LinkModel::iid(e.arrival.upper);
    case IntervalEnd::POINT:
      break;
  }
  return LinkModel::iid(e.arrival.trials ? e.arrival.value : 0.0);
}

std::size_t linkTrials(const LinkEstimate& e, bool markov)
{
  if (!markov)
    return e.arrival.trials;
  return e.recovery.trials ? std::min(e.recovery.trials, e.failure.trials) : e.failure.trials;
}

}  // namespace networked_estimation
