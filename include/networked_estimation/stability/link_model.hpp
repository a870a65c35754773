// One sensor's link as a loss process (docs/stability.md 1.2): i.i.d. (Bernoulli) or a
// Gilbert-Elliott chain, with its arrival rate, recovery rate and loss persistence. ROS-free.
#pragma once

#include <Eigen/Dense>

#include "networked_estimation/config/channel_settings.hpp"

namespace networked_estimation
{

// Links

/// The arrival process of one sensor's link: i.i.d. (Bernoulli) or a Gilbert-Elliott chain
/// (two hidden states, P(lost | state) = loss_good / loss_bad).
struct LinkModel
{
  enum class Kind
  {
    IID,
    GILBERT_ELLIOTT
  };
  Kind kind = Kind::IID;
  double arrival = 1.0;  ///< IID: P(arrived)
  double p = 0.0;        ///< GE: P(good -> bad)
  double r = 1.0;        ///< GE: P(bad -> good)
  double loss_good = 0.0, loss_bad = 1.0;

  static LinkModel iid(double arrival_rate);
  static LinkModel gilbertElliott(double p, double r, double loss_bad = 1.0, double loss_good = 0.0);
  /// bernoulli: arrival = 1 - loss; gilbert_elliott: the chain; trace: the model fitted to it.
  static LinkModel fromSettings(const ChannelSettings& settings);

  /// GE with loss_bad = 1 and loss_good = 0: the arrival indicator itself is a two-state Markov chain.
  bool onOff() const { return kind == Kind::GILBERT_ELLIOTT && loss_bad == 1.0 && loss_good == 0.0; }
  /// Stationary arrival rate (GE on/off: r / (p + r)).
  double arrivalRate() const;
  /// Stationary P(arrived at k | lost at k-1) (IID: the arrival rate; GE on/off: r). NaN when a
  /// loss never happens.
  double recoveryRate() const;
  /// lim_T P(T consecutive losses)^{1/T}: 1 - arrival (IID), 1 - r (GE on/off), in general the
  /// spectral radius of P diag(loss_state).
  double lossPersistence() const;
  /// Transition matrix (row-stochastic, rows = current state) and per-state loss probability of
  /// the hidden chain; one state for IID.
  Eigen::MatrixXd transition() const;
  Eigen::VectorXd stateLoss() const;
};

}  // namespace networked_estimation
