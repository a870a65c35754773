// The one implementation of a link's rates from its arrival sequence, shared by the live monitors
// (stability/link_monitor.hpp, stability/joint_link_monitor.hpp: a sliding window) and the offline
// fit of a recorded link (link/link_fit.hpp, fit_link, analyze --bag: the whole record):
//   - the counts of an arrival sequence: samples, arrivals and the transitions (k-1, k) of
//     consecutive steps, split by what happened at k-1;
//   - the estimates from the counts, each with its 95 % Wilson score interval: the arrival rate
//     P(arrived), the failure rate p = P(lost at k | arrived at k-1) = n01 / (n00 + n01) and the
//     recovery rate r = P(arrived at k | lost at k-1) = n10 / (n10 + n11) (0 = arrived, 1 = lost):
//     the maximum-likelihood estimates of a Bernoulli link and of a two-state Gilbert link;
//   - the links at the estimates and at the pessimistic and optimistic ends of the intervals, on
//     which the verdicts are taken.
// ROS-free.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "networked_estimation/stability/link_model.hpp"

namespace networked_estimation
{

/// A proportion estimated from `trials` Bernoulli trials with a 95 % confidence interval.
struct RateEstimate
{
  double value = 0.0;  ///< successes / trials (NaN without trials)
  double lower = 0.0;  ///< 95 % Wilson score interval
  double upper = 1.0;
  std::size_t successes = 0, trials = 0;
};

/// 95 % Wilson score interval for `successes` out of `trials` (z = 1.959964); [0, 1] and value NaN
/// without trials.
RateEstimate wilsonInterval(std::size_t successes, std::size_t trials, double z = 1.959963984540054);

/// The counts of an arrival sequence (or of a window of it).
struct ArrivalCounts
{
  std::size_t samples = 0, arrivals = 0;
  std::size_t after_loss = 0;     ///< transitions with sample k-1 lost (n10 + n11)
  std::size_t recovered = 0;      ///< ... and sample k arrived (n10)
  std::size_t after_arrival = 0;  ///< transitions with sample k-1 arrived (n00 + n01)
  std::size_t failed = 0;         ///< ... and sample k lost (n01)

  void addSample(bool arrived);
  void removeSample(bool arrived);
  /// The transition (k-1, k) of two consecutive steps.
  void addTransition(bool previous_arrived, bool arrived);
  void removeTransition(bool previous_arrived, bool arrived);
};

/// The counts of a whole sequence, every pair of neighbours a transition.
ArrivalCounts countArrivals(const std::vector<std::uint8_t>& arrived);

/// One link's estimates from its counts.
struct LinkEstimate
{
  RateEstimate arrival;   ///< P(arrived): the Bernoulli link's arrival rate
  RateEstimate recovery;  ///< r = P(arrived | lost before)
  RateEstimate failure;   ///< p = P(lost | arrived before)
};

RateEstimate arrivalEstimate(const ArrivalCounts& counts);
RateEstimate recoveryEstimate(const ArrivalCounts& counts);
RateEstimate failureEstimate(const ArrivalCounts& counts);
LinkEstimate estimateLink(const ArrivalCounts& counts);

/// Where in its intervals a link is taken.
enum class IntervalEnd
{
  PESSIMISTIC,  ///< every rate at the bad end of its interval (low arrival, high p, low r)
  POINT,        ///< at the estimates
  OPTIMISTIC    ///< every rate at the good end
};

/// The link of the estimates, at an end of the intervals: i.i.d. (the arrival rate), or markov, an
/// on/off Gilbert-Elliott link of failure p and recovery r (kept inside (0, 1]). Without trials:
/// an i.i.d. point of 0; a Markov link that lost nothing has r taken as 1 and, without arrival
/// transitions, p as 0.5 at its point.
LinkModel linkAt(const LinkEstimate& estimate, bool markov, IntervalEnd end);

/// The Markov link's trials: the fewer of its recovery and failure trials (the failure trials alone
/// when nothing was lost); the i.i.d. link's: its samples.
std::size_t linkTrials(const LinkEstimate& estimate, bool markov);

}  // namespace networked_estimation
