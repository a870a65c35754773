// Sensor schedules (docs/formats.md, "Sensor schedule"): which sensors transmit at each step, when
// the network can carry fewer than all of them (Marelli et al.'s scheduled sensors).
//
//   periodic   a fixed pattern of period tau: at step k the sensors of pattern[(k - 1) mod tau]
//              transmit (time-based schedule)
//   random     at each step one of K subsets of the sensors transmits, drawn i.i.d. with given
//              probabilities or by a Markov chain over the subsets (random schedule)
//
// A sensor that is not scheduled does not transmit: it is not a loss. A scheduled sensor's packet
// still crosses its own link and may be lost there. The links are time-driven: a link's loss
// process advances every step, whether or not its sensor transmits (a radio channel fades in
// time), so adding a schedule does not change which of the scheduled packets are lost.
#pragma once

#include <Eigen/Dense>

#include <cstdint>
#include <string>
#include <vector>

namespace networked_estimation
{

struct Schedule
{
  enum class Kind
  {
    NONE,      ///< every sensor transmits at every step
    PERIODIC,  ///< pattern, period tau = pattern.size()
    RANDOM     ///< subsets drawn i.i.d. (probabilities) or by a Markov chain (transition)
  };
  Kind kind = Kind::NONE;
  /// PERIODIC: pattern[t][s] = sensor s transmits at the steps k with (k - 1) mod tau = t.
  std::vector<std::vector<bool>> pattern;
  /// RANDOM: subsets[i][s] = sensor s transmits when subset i is drawn.
  std::vector<std::vector<bool>> subsets;
  /// RANDOM: row-stochastic K x K, rows = the current subset. i.i.d.: every row = probabilities.
  Eigen::MatrixXd transition;
  /// RANDOM: the law of the first step's subset: the stationary distribution of `transition`.
  Eigen::VectorXd initial;
  bool markov = false;  ///< RANDOM: given as a transition matrix (else i.i.d. probabilities)

  bool active() const { return kind != Kind::NONE; }
  /// PERIODIC: tau; RANDOM and NONE: 1.
  int period() const;
  /// Largest number of sensors transmitting at one step (the network's R).
  int maxTransmitting() const;
  /// Long-run fraction of the steps at which sensor s transmits (1 without a schedule).
  double transmitFraction(std::size_t sensor) const;
  /// One line for reports, with sensor names: "periodic, tau = 2: [gnss] [camera]".
  std::string describe(const std::vector<std::string>& sensor_names) const;
};

}  // namespace networked_estimation
