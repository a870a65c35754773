// A recorded link to replay (channel settings `model: trace`, docs/formats.md): the expected
// messages of a trace file and, per message, whether it arrived, its delay and its copies; the
// LossyChannel gives its i-th message the outcome of slot i (looping at the end), the simulator's
// loss model likewise from a slot its seed chooses. The loss model fitted to it (fit_link's choice
// by BIC) is what the stability analysis takes for the link.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/config/channel_settings.hpp"

namespace networked_estimation
{

struct ChannelTrace
{
  std::string source;                 ///< the file (and topic) it was read from
  double period = 0.0;                ///< s between expected messages
  std::vector<std::uint8_t> arrived;  ///< per slot
  std::vector<double> delay;          ///< per slot, s (0 when lost)
  std::vector<std::uint8_t> copies;   ///< per slot: copies received (2 or more: a duplicate)
  /// The loss model fitted to the slots (bernoulli or gilbert_elliott), and how it was chosen.
  ChannelSettings fitted;
  std::string fitted_note;

  std::size_t slots() const { return arrived.size(); }
};

/// Reads a trace: a CSV of stamp,receipt[,seq] (fit_link's --csv), `rostopic echo -p` of a
/// LossyChannel's ~events, or a ROS bag (`topic` then names the topic; it must be empty
/// otherwise); `rate` (Hz, 0: learnt) as fit_link's --rate. Throws InputError naming the file.
std::shared_ptr<const ChannelTrace> loadChannelTrace(const std::string& path, const std::string& topic, double rate);

/// True when `path` names a ROS bag (it starts with "#ROSBAG").
bool isRosBag(const std::string& path);

}  // namespace networked_estimation
