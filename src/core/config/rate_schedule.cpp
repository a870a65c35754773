// Sensor rates as a periodic schedule (rate_schedule.hpp).
#include "networked_estimation/config/rate_schedule.hpp"

#include <cmath>
#include <numeric>

namespace networked_estimation
{

Model withSensorRates(const Model& model, const std::vector<double>& ratio, std::string* note)
{
  auto refuse = [&](const std::string& why)
  {
    if (note)
      *note = why + ": the stability verdicts assume every sensor can arrive at every step";
    return model;
  };
  if (note)
    note->clear();
  std::vector<long> q;
  bool all_one = true;
  for (std::size_t s = 0; s < ratio.size() && s < model.sensors.size(); ++s)
  {
    const long whole = std::lround(ratio[s]);
    if (whole < 1 || std::fabs(ratio[s] - static_cast<double>(whole)) > 1e-9 * ratio[s])
      return refuse("sensor '" + model.sensors[s].name + "' is sampled every " + std::to_string(ratio[s]) +
                    " steps, not a whole number");
    q.push_back(whole);
    all_one = all_one && whole == 1;
  }
  if (all_one || q.size() != model.sensors.size())
    return model;
  if (model.schedule.kind == Schedule::Kind::RANDOM)
    return refuse("a random sensor schedule and sensor rates");
  long period = model.schedule.kind == Schedule::Kind::PERIODIC ? model.schedule.period() : 1;
  for (long v : q)
  {
    period = std::lcm(period, v);
    if (period > kMaxRateSchedulePeriod)
      return refuse("the sensors' rates repeat only after more than " + std::to_string(kMaxRateSchedulePeriod) +
                    " steps");
  }
  Model out = model;
  out.schedule = Schedule();
  out.schedule.kind = Schedule::Kind::PERIODIC;
  out.schedule.pattern.assign(static_cast<std::size_t>(period), std::vector<bool>(model.sensors.size(), false));
  for (long t = 0; t < period; ++t)
    for (std::size_t s = 0; s < q.size(); ++s)
    {
      const bool own = model.schedule.kind != Schedule::Kind::PERIODIC ||
                       model.schedule.pattern[static_cast<std::size_t>(t % model.schedule.period())][s];
      out.schedule.pattern[static_cast<std::size_t>(t)][s] = own && t % q[s] == 0;
    }
  return out;
}

}  // namespace networked_estimation
