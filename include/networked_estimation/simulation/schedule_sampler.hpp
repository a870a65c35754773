// Draws a sensor schedule step by step (schedule.hpp): which sensors transmit at k = 1, 2, ...
#pragma once

#include <cstdint>
#include <vector>

#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/schedule.hpp"

namespace networked_estimation
{

class ScheduleSampler
{
public:
  /// `sensors` = the model's sensor count. A random schedule draws from its own generator seeded
  /// with `seed`; a periodic one (or none) uses no randomness.
  ScheduleSampler(const Schedule& schedule, std::size_t sensors, std::uint64_t seed);

  /// Starts over before the first step, as if constructed with `seed` (no allocation).
  void restart(std::uint64_t seed);

  /// Advances to the next step and returns, per sensor, whether it transmits there.
  const std::vector<bool>& next();
  /// The mask of the last next() (every sensor before the first).
  const std::vector<bool>& current() const { return mask_; }
  /// RANDOM: index of the subset drawn at the last step (-1 before the first); PERIODIC: the phase.
  int state() const { return state_; }

private:
  const Schedule* schedule_;
  Rng rng_;
  std::vector<bool> mask_;
  int state_ = -1;
  long k_ = 0;
};

}  // namespace networked_estimation
