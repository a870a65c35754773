// The ROS-free engine of the LossyChannel nodelet (docs/formats.md, "Channel settings"): drops, delays,
// duplicates and reorders messages like Linux netem, reproducibly from a seed. The caller keeps
// the message objects (keyed by its own sequence numbers) and drives the engine with times in
// seconds; the engine makes every decision and keeps the in-flight schedule.
//
// Per offer(seq, now), in this order:
//  1. Loss.  The LossModel of the settings (makeLossModel) decides DROPPED_MODEL; its state()
//     afterwards is reported in the event (0 good, 1 bad; always 0 for bernoulli and trace).
//     A trace (model: trace) is replayed from its first slot: the i-th offer gets slot i's outcome
//     (looping), and below its recorded delay and, for a slot received twice, a copy.
//  2. Delay noise.  Exactly two uniforms u1, u2 are drawn from the delay stream on EVERY offer
//     (dropped or not, whatever jitter and distribution are), and
//        uniform: Z = 2 u1 - 1                                  (U[-1, 1], netem without a table)
//        normal:  Z = sqrt(-2 ln(1 - u1)) cos(2 pi u2)          (Box-Muller, N(0, 1))
//        pareto:  Z = ((1 - u1)^(-1/3) - 1.5) / sqrt(0.75)      (Pareto(x_m = 1, alpha = 3),
//                 standardised to mean 0, sd 1: heavy right tail, Z >= -0.577)
//     d = max(0, delay + jitter * Z).  So the noise of the i-th offer depends only on (seed, i):
//     changing jitter / distribution / loss never shifts another stream.
//  3. Duplicate.  Exactly one uniform is drawn from the duplicate stream on every offer;
//     u < duplicate asks for a second copy (only honoured for a delivered message with room).
//  4. Queue.  A message that survives the loss model but finds in_flight >= queue_limit is
//     DROPPED_QUEUE (counted, not scheduled; delay 0 in its event).  The duplicate needs a second
//     free slot; without one it is silently not made (and not counted as duplicated).
//  5. Schedule.  reorder = false: due = max(now + d, largest due in flight) - deliveries keep
//     offer order, late messages hold back the later ones (netem without reorder).  When nothing
//     is in flight the floor is dropped, so a backwards time jump does not stall the channel.
//     reorder = true: due = now + d.  The copy has the same due as its original.
//     Delivery order is (due, offer order, original before copy): ties keep offer order and a
//     copy is delivered right after its original.  The offer order is the engine's own call
//     counter, not the caller's seq (which need not be monotonic).
//
// Randomness: three independent Rng streams, loss = deriveSeed(seed, 0), delay = deriveSeed(seed,
// 1), duplicate = deriveSeed(seed, 2).  Same settings + seed + the same sequence of offer() /
// reconfigure() calls (and times) => the same events and deliveries.
//
// Counters are lifetime totals; at every moment
//   received + duplicated == delivered + dropped_model + dropped_queue + in_flight
// (delivered counts copies too).  Statistics (lossRate, meanBurstLength, delayQuantile) cover the
// offers since construction or the last clearStatistics().
//
// Memory: the delay window is a ring of 10000 samples; the schedule holds at most queue_limit
// entries (at the time of each offer).  offer() and popDue() cost O(log n) per delivery.
// Not thread-safe: the caller serialises access (the nodelet holds one mutex).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <queue>
#include <string>
#include <vector>

#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/channel_settings.hpp"

namespace networked_estimation
{

enum class ChannelOutcome
{
  DELIVERED,      ///< scheduled for delivery (possibly with a copy)
  DROPPED_MODEL,  ///< lost by the loss model
  DROPPED_QUEUE   ///< would have been delivered, but in_flight was already >= queue_limit
};

/// "delivered", "dropped_model", "dropped_queue".
std::string toString(ChannelOutcome outcome);

/// One per offered message: the ground truth for evaluation.
struct ChannelRecord
{
  std::uint64_t seq = 0;  ///< the caller's sequence number of the input message
  double arrival = 0.0;   ///< time the message was offered (s)
  ChannelOutcome outcome = ChannelOutcome::DELIVERED;
  bool duplicated = false;  ///< a second copy was scheduled
  int state = 0;            ///< loss-model state after this message (0 good, 1 bad)
  /// Holding time of the (first) copy, due - arrival, in s (0 when dropped).  Includes the hold
  /// imposed by in-order delivery when reorder = false; equals the drawn d exactly when not held.
  double delay = 0.0;
  /// The delay drawn from the configured distribution for this message (delay + jitter Z, clipped
  /// at 0), before any in-order hold. Depends only on the seed and the message's index, so two
  /// channels with one seed agree on it even when their clocks differ. 0 when dropped.
  double sampled_delay = 0.0;
};

struct ChannelCounters
{
  std::uint64_t received = 0;   ///< offers
  std::uint64_t delivered = 0;  ///< deliveries popped (copies included)
  std::uint64_t dropped_model = 0;
  std::uint64_t dropped_queue = 0;
  std::uint64_t duplicated = 0;  ///< copies scheduled
  std::size_t in_flight = 0;     ///< deliveries scheduled, not yet popped (copies included)
};

struct Delivery
{
  std::uint64_t seq = 0;   ///< the caller's sequence number
  bool duplicate = false;  ///< true for the second copy
  double due = 0.0;        ///< scheduled delivery time (s)
};

class LossyChannel
{
public:
  /// Number of delays kept for delayQuantile().
  static constexpr std::size_t kDelayWindow = 10000;

  /// Seeds every stream from s.seed.  Throws ConfigError for invalid settings (negative or
  /// non-finite delay / jitter, probabilities outside [0, 1], queue_limit 0).
  explicit LossyChannel(const ChannelSettings& s);

  /// New settings for the following offers; the schedule (already-scheduled deliveries keep their
  /// due times, even when queue_limit shrinks below in_flight), counters and statistics are kept.
  ///  - seed changed: every stream restarts from the new seed exactly as in a freshly constructed
  ///    channel (a new loss model, in its stationary law).
  ///  - seed unchanged, loss parameters of the (new) model unchanged: the loss model continues
  ///    undisturbed (so e.g. changing jitter leaves the loss sequence identical).
  ///  - seed unchanged, loss model or its parameters changed: a new loss model starts in its
  ///    stationary law on a fresh stream deriveSeed(deriveSeed(seed, 0), g), g = 1, 2, ... counting
  ///    such changes since the seed was last set (deterministic, not a replay of the old draws).
  ///  - delay / duplicate streams are never disturbed by a reconfigure without a seed change.
  /// Throws ConfigError (and changes nothing) for invalid settings.
  void reconfigure(const ChannelSettings& s);

  /// Decides loss / delay / duplicate for one message offered at `now` and schedules its
  /// deliveries.  Throws InputError (and changes nothing) when now is not finite.
  ChannelRecord offer(std::uint64_t seq, double now);

  /// Pops every delivery with due <= now, in delivery order, into out (cleared first).
  /// Returns the count.
  std::size_t popDue(double now, std::vector<Delivery>& out);

  /// Pops everything in flight, in delivery order, whatever its due (e.g. on shutdown or when the
  /// clock jumps backwards); counted as delivered.  Returns the count.
  std::size_t popAll(std::vector<Delivery>& out);

  /// Due time of the next delivery; +infinity when nothing is in flight.
  double nextDue() const;

  const ChannelCounters& counters() const { return counters_; }
  const ChannelSettings& settings() const { return settings_; }

  // Statistics over the offers since construction / the last clearStatistics():

  /// (dropped_model + dropped_queue) / offers; NaN if nothing was offered.
  double lossRate() const;

  /// Mean length of the maximal runs of consecutive dropped offers (either kind), counting a run
  /// still in progress; NaN if nothing was dropped.
  double meanBurstLength() const;

  /// q-quantile (q in [0, 1]) of the last (up to) kDelayWindow event delays of delivered offers
  /// (one per offer, copies not counted), by linear interpolation between order statistics
  /// (x_(floor(h)) + frac(h) (x_(floor(h)+1) - x_(floor(h))), h = (n - 1) q, 0-based; numpy's
  /// default).  NaN if none; throws std::invalid_argument for q outside [0, 1] or NaN.  O(n).
  double delayQuantile(double q) const;

  /// Number of delays currently in the window (<= kDelayWindow).
  std::size_t delaySamples() const { return delay_count_; }

  /// Resets the statistics windows (loss rate, bursts, delays).  A drop run in progress is
  /// forgotten: drops after the reset start a new run.  counters() (lifetime totals), the schedule
  /// and the random streams are untouched.
  void clearStatistics();

private:
  struct Entry
  {
    double due;
    std::uint64_t order;  ///< offer counter
    bool duplicate;
    std::uint64_t seq;
  };
  /// "a is delivered after b": the priority_queue comparator (min-heap on (due, order, dup)).
  struct Later
  {
    bool operator()(const Entry& a, const Entry& b) const
    {
      if (a.due != b.due)
        return a.due > b.due;
      if (a.order != b.order)
        return a.order > b.order;
      return a.duplicate && !b.duplicate;
    }
  };

  static void validate(const ChannelSettings& s);
  std::unique_ptr<LossModel> makeLoss(std::uint64_t seed);
  static bool sameLossModel(const ChannelSettings& a, const ChannelSettings& b);
  void seedStreams();
  double drawDelay();
  void recordDrop();
  void pop(std::vector<Delivery>& out);

  ChannelSettings settings_;
  std::unique_ptr<LossModel> loss_;
  const TraceLoss* trace_ = nullptr;  ///< loss_ when the model is a trace
  std::uint64_t loss_generation_ = 0;
  Rng delay_rng_, dup_rng_;

  std::priority_queue<Entry, std::vector<Entry>, Later> schedule_;
  double max_due_ = 0.0;  ///< largest due in flight (valid when the schedule is not empty)
  std::uint64_t offers_ = 0;
  ChannelCounters counters_;

  // statistics windows
  std::uint64_t stat_offers_ = 0, stat_dropped_ = 0, stat_runs_ = 0;
  bool in_run_ = false;
  std::vector<double> delays_;  ///< ring buffer, capacity kDelayWindow
  std::size_t delay_next_ = 0, delay_count_ = 0;
};

}  // namespace networked_estimation
