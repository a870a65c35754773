// A recorded arrival pattern per sensor (arrival_trace.hpp).
#include "networked_estimation/io/arrival_trace.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/io/replay_csv.hpp"

namespace networked_estimation
{
namespace
{

std::vector<std::string> split(const std::string& line)
{
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ','))
    cells.push_back(cell);
  if (!line.empty() && line.back() == ',')
    cells.emplace_back();
  return cells;
}

std::vector<bool> readEvents(const std::string& path, const std::string& sensor)
{
  std::ifstream in(path);
  if (!in)
    throw InputError(path + ": cannot open file");
  std::string line;
  if (!std::getline(in, line))
    throw InputError(path + ":1: empty file (expected the header of `rostopic echo -p` of ~events)");
  if (!line.empty() && line.back() == '\r')
    line.pop_back();
  const std::vector<std::string> header = split(line);
  std::size_t col = header.size();
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == "field.outcome")
      col = i;
  if (col == header.size())
    throw InputError(path +
                     ":1: no column field.outcome (expected `rostopic echo -p` of a LossyChannel's ~events, "
                     "networked_estimation/ChannelEvent, for sensor " +
                     sensor + ")");
  std::vector<bool> arrivals;
  long n = 1;
  while (std::getline(in, line))
  {
    ++n;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (line.empty())
      continue;
    const std::vector<std::string> cells = split(line);
    if (cells.size() != header.size())
      throw InputError(path + ":" + std::to_string(n) + ": expected " + std::to_string(header.size()) +
                       " cells as in the header, found " + std::to_string(cells.size()));
    const std::string& o = cells[col];
    if (o != "0" && o != "1" && o != "2")
      throw InputError(path + ":" + std::to_string(n) +
                       ": field.outcome: expected 0 (delivered), 1 or 2 (dropped), "
                       "found '" +
                       o + "'");
    arrivals.push_back(o == "0");
  }
  return arrivals;
}

}  // namespace

ArrivalTrace readArrivalTrace(const std::string& spec, const Model& model)
{
  ArrivalTrace trace;
  trace.arrivals.assign(model.sensors.size(), {});
  const std::string::size_type eq = spec.find('=');
  if (eq != std::string::npos && eq > 0)
  {
    const std::string name = spec.substr(0, eq);
    trace.path = spec.substr(eq + 1);
    std::size_t index = model.sensors.size();
    std::string names;
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
    {
      names += (i ? ", " : "") + model.sensors[i].name;
      if (model.sensors[i].name == name)
        index = i;
    }
    if (index == model.sensors.size())
      throw ConfigError("--trace " + spec + ": '" + name + "' is not a sensor of model '" + model.name +
                        "' (its sensors: " + names + ")");
    if (trace.path.empty())
      throw ConfigError("--trace " + spec + ": no file after '" + name + "='");
    trace.arrivals[index] = readEvents(trace.path, name);
    return trace;
  }
  if (spec.empty())
    throw ConfigError("--trace '': expected FILE or NAME=FILE, found nothing");
  trace.path = spec;
  const ReplayInput input = readReplayInput(spec, model);
  for (const ReplayRow& row : input.rows)
    for (std::size_t s = 0; s < model.sensors.size(); ++s)
    {
      const Sensor& sensor = model.sensors[s];
      trace.arrivals[s].push_back(row.gamma && row.y.segment(sensor.offset, sensor.size).allFinite());
    }
  return trace;
}

}  // namespace networked_estimation
