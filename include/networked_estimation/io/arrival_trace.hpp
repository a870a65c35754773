// A recorded arrival pattern per sensor, for the stability evidence that needs no loss model
// (Gan and Liu's excitation, stability/excitation.hpp). Two file formats are read:
//   - a replay input CSV (docs/formats.md, "Replay input"): sensor s arrived at step k when the
//     row has gamma = 1 and that sensor's cells are numbers;
//   - `rostopic echo -p` of a LossyChannel's ~events (networked_estimation/ChannelEvent), for one
//     named sensor: a message arrived when its `field.outcome` is 0 (DELIVERED).
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

struct ArrivalTrace
{
  std::string path;
  /// Per sensor of the model: its arrivals in time order (empty: the file has none for it).
  std::vector<std::vector<bool>> arrivals;
};

/// Reads FILE (a replay input CSV) or NAME=FILE (an events CSV for sensor NAME). Throws InputError
/// naming the file, the line and the column (an unknown format, missing columns, a bad outcome)
/// or ConfigError naming NAME when it is not a sensor of the model.
ArrivalTrace readArrivalTrace(const std::string& spec, const Model& model);

}  // namespace networked_estimation
