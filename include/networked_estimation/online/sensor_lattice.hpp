// When a sensor samples, on the model's steps: its phase and rate learnt from its own stamps.
//
// A sensor at rate f in a model at rate F samples every r = F / f model steps (r >= 1). Its samples
// sit on a lattice of step positions p_j = phase + j rho (rho: the learnt spacing, starting at r).
// Real sensors' stamps jitter and samples go missing, so each sample is matched to the nearest
// lattice point j; it fits when it is within `kJitterTolerance` spacings of it (+-20 % jitter fits
// with room for the estimate's own error), and dropouts are simply lattice points without a
// sample. A fitting sample nudges the phase and the spacing (a second-order phase-locked loop), so
// the lattice follows a slightly different true rate and a drifting clock. Samples that do not fit
// are counted; three in a row re-learn the lattice from the latest one (the sensor restarted, or
// its rate is not the configured one), and so does a learnt spacing outside +-25 % of r.
//
// The step of a sample is its lattice point's step, not the nearest step to its own stamp: a
// sensor whose stamps sit near the middle between two steps, with jitter, always lands on the same
// one of them (no duplicate in one step and hole in the next). With a whole r (within 2 %) the
// lattice steps are exactly r apart; a drift moves them by one step only when the lattice has moved
// more than half a step plus 0.15 spacing away from them (hysteresis), so a sensor's due steps stay
// regular. The sensor
// is *due* at the lattice steps (OnlineEstimator), before its first sample at none unless r = 1.
#pragma once

#include <cstdint>
#include <deque>
#include <string>

namespace networked_estimation
{

class SensorLattice
{
public:
  /// Tolerated distance of a sample from its lattice point, in spacings.
  static constexpr double kJitterTolerance = 0.35;
  /// A ratio within this fraction of a whole number counts as that whole number.
  static constexpr double kWholeTolerance = 0.02;
  /// `ratio` as the whole number it counts as, or unchanged (for the stability analysis' sensor
  /// schedule, which needs whole ratios: a 9.996 Hz sensor in a 30 Hz model samples every 3 steps).
  static double whole(double ratio);
  /// Warn when the learnt rate differs from the configured one by more than this fraction.
  static constexpr double kRateMismatch = 0.05;

  /// `ratio`: the model's rate over the sensor's configured rate (>= 1).
  explicit SensorLattice(double ratio = 1.0);

  /// Where a sample falls: its step, whether it fits the lattice, and what observe() would learn.
  struct Fit
  {
    long step = 0;
    bool fits = true;
    long index = 0;      ///< lattice points after the reference (<= 0: not newer than it)
    double error = 0.0;  ///< position minus its lattice point, in steps
  };

  /// The fit of a sample at step position `position` ((stamp - t0) / period, not rounded). `given`
  /// >= 1: the step the message names (Measurement), which is then its step whatever the fit.
  Fit fit(double position, long given = -1) const;
  /// Learns from a sample (the fit() of the same arguments); returns true when it re-learnt the
  /// lattice (three samples in a row off it, or a spacing outside +-25 % of the configured one).
  bool learn(double position, const Fit& f);

  bool locked() const { return locked_; }
  /// Whether the sensor samples at step k: every step for r = 1, else the lattice steps once learnt.
  bool due(long k) const;
  /// The learnt spacing in steps (r before the first samples).
  double spacing() const { return rho_; }
  double configured() const { return ratio_; }
  /// Samples that did not fit their lattice point, and re-learnt lattices, since construction.
  std::uint64_t offLattice() const { return off_total_; }
  std::uint64_t relearnt() const { return relearnt_; }
  /// A real mismatch with the configuration: the learnt rate is more than 5 % off the configured
  /// one, or at least 5 of the last 20 samples missed the lattice. `why` says which, with numbers
  /// (rates in Hz from `period`, the model's period in s): the configured rate, and the rate the
  /// last 20 stamps show (their intervals over the whole spacings they span, so that dropouts do
  /// not read as a slower rate).
  bool mismatch(double period, std::string* why = nullptr) const;
  /// That rate of the last samples in Hz (NaN before two).
  double measuredRate(double period) const;
  /// Forgets the lattice (a timeline restart).
  void reset();

private:
  void relock(double position, long step);

  double ratio_;    ///< configured spacing r
  long whole_ = 0;  ///< r as a whole number (0: not whole)
  bool locked_ = false;
  double phase_ = 0.0;  ///< position of the reference lattice point
  double rho_;          ///< learnt spacing
  long ref_step_ = 0;   ///< the step of the reference point
  int off_in_row_ = 0;
  std::deque<bool> recent_;       ///< the last 20 samples: fitted or not
  std::deque<double> positions_;  ///< and their positions
  std::uint64_t off_total_ = 0, relearnt_ = 0;
};

}  // namespace networked_estimation
