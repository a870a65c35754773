// The messages a LossyChannel holds between their offer and their deliveries, for a node that
// forwards real messages through the engine (the LossyChannel nodelet; ROS-free, any payload type:
// a shared pointer to the message, forwarded as it is).
//
// offer() numbers the messages in arrival order, offers each to the engine and keeps its payload
// once per delivery the engine scheduled (twice for a duplicate); popDue() hands out the payloads
// of the deliveries that are due, in the engine's delivery order, and forgets a payload after its
// last delivery. Not thread-safe, as the LossyChannel it wraps.
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "networked_estimation/channel/channel.hpp"

namespace networked_estimation
{

template <class Payload>
class ChannelDeliveries
{
public:
  /// Deliveries through `channel`, which must outlive this object.
  explicit ChannelDeliveries(LossyChannel& channel) : channel_(channel) {}

  /// Offers the next message to the channel at time `now` (s), holding `payload` for its deliveries.
  ChannelRecord offer(double now, const Payload& payload)
  {
    const std::uint64_t seq = next_seq_++;
    const ChannelRecord rec = channel_.offer(seq, now);
    if (rec.outcome == ChannelOutcome::DELIVERED)
      held_[seq] = {payload, rec.duplicated ? 2 : 1};
    return rec;
  }

  /// Appends to `out` the payloads of the deliveries due at `now`, in delivery order.
  void popDue(double now, std::vector<Payload>& out)
  {
    channel_.popDue(now, due_);
    for (const Delivery& d : due_)
    {
      const auto it = held_.find(d.seq);
      if (it == held_.end())
        continue;
      out.push_back(it->second.payload);
      if (--it->second.remaining == 0)
        held_.erase(it);
    }
  }

  /// Messages held for a delivery still to come.
  std::size_t held() const { return held_.size(); }

private:
  struct Held
  {
    Payload payload;
    int remaining;  ///< deliveries still to come
  };

  LossyChannel& channel_;
  std::uint64_t next_seq_ = 0;
  std::unordered_map<std::uint64_t, Held> held_;
  std::vector<Delivery> due_;
};

}  // namespace networked_estimation
