// Packet loss models (docs/formats.md, "Channel settings"), with netem's semantics:
//   bernoulli:        each message lost independently with probability `loss`
//   gilbert_elliott:  two-state Markov chain, p = P(good -> bad), r = P(bad -> good),
//                     P(lost | bad) = loss_bad (netem 1-h), P(lost | good) = loss_good (netem 1-k).
//   trace:            the losses of a recorded link, slot after slot, looping at its end
//                     (link/channel_trace.hpp); the seed chooses the first slot.
// The chain starts in its stationary law. Same seed + same number of calls = same outcomes.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/channel_settings.hpp"

namespace networked_estimation
{

class LossModel
{
public:
  virtual ~LossModel() = default;

  /// Advances the model by one message and returns true when that message is lost.
  virtual bool nextLost() = 0;

  /// Current channel state after the last nextLost(): 0 = good, 1 = bad (always 0 for bernoulli).
  virtual int state() const = 0;

  /// Long-run fraction of lost messages.
  virtual double stationaryLossRate() const = 0;

  /// Long-run mean length of a run of consecutive losses (infinity if a loss run never ends,
  /// NaN if nothing is ever lost).
  virtual double stationaryMeanBurstLength() const = 0;

  /// Restarts the sequence from `seed` (drawing a fresh initial state from the stationary law).
  virtual void reseed(std::uint64_t seed) = 0;
};

class BernoulliLoss : public LossModel
{
public:
  BernoulliLoss(double loss, std::uint64_t seed);
  bool nextLost() override;
  int state() const override { return 0; }
  double stationaryLossRate() const override;
  double stationaryMeanBurstLength() const override;
  void reseed(std::uint64_t seed) override;

private:
  double loss_;
  Rng rng_;
};

class GilbertElliottLoss : public LossModel
{
public:
  GilbertElliottLoss(double p, double r, double loss_bad, double loss_good, std::uint64_t seed);
  bool nextLost() override;
  int state() const override { return bad_ ? 1 : 0; }
  double stationaryLossRate() const override;
  double stationaryMeanBurstLength() const override;
  void reseed(std::uint64_t seed) override;

  /// Stationary probability of the bad state: p / (p + r) (0 when p + r = 0).
  double stationaryBadProbability() const;

private:
  double p_, r_, loss_bad_, loss_good_;
  Rng rng_;
  bool bad_ = false;
  bool started_ = false;
};

/// The losses of a recorded link: call i gives slot (start + i) mod slots.
class TraceLoss : public LossModel
{
public:
  /// `start`: the first slot (taken mod the slots). The trace must have at least one slot.
  TraceLoss(std::shared_ptr<const ChannelTrace> trace, std::size_t start);
  bool nextLost() override;
  int state() const override { return 0; }
  double stationaryLossRate() const override;
  double stationaryMeanBurstLength() const override;
  /// Restarts at slot seed mod slots.
  void reseed(std::uint64_t seed) override;
  /// The slot of the last nextLost() (its delay and copies are the trace's).
  std::size_t slot() const { return slot_; }
  const ChannelTrace& trace() const { return *trace_; }

private:
  std::shared_ptr<const ChannelTrace> trace_;
  std::size_t next_ = 0, slot_ = 0;
};

/// Builds the loss model of a channel configuration, seeded with `seed` (normally settings.seed,
/// or a stream seed derived from it with deriveSeed). A trace starts at slot seed mod slots.
std::unique_ptr<LossModel> makeLossModel(const ChannelSettings& settings, std::uint64_t seed);

}  // namespace networked_estimation
