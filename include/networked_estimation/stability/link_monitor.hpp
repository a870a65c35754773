// Live link diagnostics: windowed arrival and recovery rates with confidence intervals, and their
// classification against the stability thresholds of stability.hpp. O(1) per sample. The counts
// and the estimates are link/link_estimates.hpp's, the same as the offline fit's (fit_link).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "networked_estimation/link/link_estimates.hpp"

namespace networked_estimation
{

struct StabilityReport;

/// Sliding window over the last `window` arrival indicators.
class LinkMonitor
{
public:
  /// window >= 2 (throws std::invalid_argument otherwise).
  explicit LinkMonitor(std::size_t window);

  /// Records whether the next observed sample arrived. O(1). `follows_previous`: the previous
  /// recorded sample was the step just before this one, so (previous, this) is a transition of
  /// the link; false when steps were skipped (a sensor schedule: the sensor was not due), so the
  /// transition counts below only ever see consecutive steps.
  void add(bool arrived, bool follows_previous = true);
  /// Forgets everything.
  void clear();

  /// Samples in the window (<= window).
  std::size_t samples() const { return counts_.samples; }
  std::size_t arrivals() const { return counts_.arrivals; }
  /// Transitions (k-1, k) of consecutive steps with both samples in the window and sample k-1 lost.
  std::size_t lossTransitions() const { return counts_.after_loss; }
  std::size_t recoveries() const { return counts_.recovered; }
  /// Transitions (k-1, k) with both samples in the window and sample k-1 arrived, and those of
  /// them where sample k was lost.
  std::size_t arrivalTransitions() const { return counts_.after_arrival; }
  std::size_t failures() const { return counts_.failed; }
  /// The counts of the window (link_estimates.hpp).
  const ArrivalCounts& counts() const { return counts_; }
  /// Samples seen since construction / clear().
  std::uint64_t total() const { return total_; }
  /// The indicators in the window, oldest first.
  std::vector<bool> window() const;

  /// The three estimates of the window (estimateLink).
  LinkEstimate estimates() const { return estimateLink(counts_); }
  /// P(arrived), Wilson interval over the window.
  RateEstimate arrivalRate() const;
  /// P(arrived at k | lost at k-1), Wilson interval over the transitions in the window.
  RateEstimate recoveryRate() const;
  /// P(lost at k | arrived at k-1) (a Gilbert-Elliott on/off link's p), Wilson interval.
  RateEstimate failureRate() const;

private:
  std::vector<std::uint8_t> ring_;  ///< bit 0: arrived; bit 1: follows the previous entry's step
  std::size_t head_ = 0;            ///< index of the oldest sample
  ArrivalCounts counts_;
  std::uint64_t total_ = 0;
};

/// Thresholds on one link quantity (arrival rate for i.i.d. links, recovery rate for Markov links).
struct LinkThresholds
{
  std::string quantity = "arrival rate";
  double necessary = 0.0;   ///< below it the expected error covariance is unbounded
  double sufficient = 0.0;  ///< above it it is bounded; (necessary, sufficient) is the undecided band
  std::size_t min_samples = 100;
};

/// Thresholds of the whole model from a report: arrival-rate thresholds for i.i.d. channels (and
/// without channel), recovery-rate thresholds for on/off Gilbert-Elliott channels. NaN thresholds
/// (unknown) are replaced conservatively: necessary by the lower bound, sufficient by 1.
LinkThresholds linkThresholds(const StabilityReport& report, std::size_t min_samples = 100);

struct LinkCondition
{
  enum class Level
  {
    OK,
    WARN,
    ERROR
  };
  Level level = Level::WARN;
  std::string message;
};

/// "OK", "WARN", "ERROR".
std::string toString(LinkCondition::Level level);

/// OK when the whole interval is above the sufficient threshold; ERROR when it is below the
/// necessary threshold; WARN otherwise (inside the undecided band or straddling a threshold) and
/// when there are fewer than min_samples trials.
LinkCondition classifyLink(const RateEstimate& estimate, const LinkThresholds& thresholds);

}  // namespace networked_estimation
