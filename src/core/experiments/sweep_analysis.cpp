// The analytic side of a sweep (sweep.hpp): the stability verdict of every grid point and the
// critical curve of the last axis, from the core stability analysis.
#include "networked_estimation/experiments/sweep.hpp"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

namespace
{

std::vector<LinkModel> linkModels(const std::vector<std::optional<ChannelSettings>>& links)
{
  std::vector<LinkModel> v;
  for (const auto& l : links)
    v.push_back(l ? LinkModel::fromSettings(*l) : LinkModel::iid(1.0));
  return v;
}

}  // namespace

SweepAnalysis analyseSweep(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                           const std::vector<SweepAxis>& axes)
{
  SweepAnalysis out;
  std::vector<int> all;
  for (std::size_t s = 0; s < model.sensors.size(); ++s)
    all.push_back(static_cast<int>(s));
  const std::vector<double>& v1 = axes.front().values;
  const std::vector<double> v2 = axes.size() > 1 ? axes[1].values : std::vector<double>{0.0};
  for (double a : v1)
    for (double b : v2)
    {
      const std::vector<double> point = axes.size() > 1 ? std::vector<double>{a, b} : std::vector<double>{a};
      out.verdicts.push_back(toString(
          stabilityVerdict(sweepPointModel(model, axes, point), all, linkModels(sweepPointLinks(links, axes, point)))
              .kind));
    }
  const SweepAxis& last = axes.back();
  const bool rate = last.kind == SweepAxis::Kind::LINK &&
                    (last.param == "arrival_rate" || last.param == "recovery_rate" || last.param == "r");
  const std::string quantity = last.param == "arrival_rate" ? "arrival rate" : "recovery rate";
  for (std::size_t i = 0; i < (axes.size() > 1 ? v1.size() : 1); ++i)
  {
    SweepAnalysis::Critical c;
    if (axes.size() > 1)
      c.at = v1[i];
    if (!rate)
    {
      c.note = "not applicable: the analysis gives critical arrival and recovery rates, not a critical " + last.name();
      out.critical.push_back(c);
      continue;
    }
    const std::vector<double> point =
        axes.size() > 1 ? std::vector<double>{v1[i], last.values.front()} : std::vector<double>{last.values.front()};
    const std::vector<SensorMargin> margins =
        sensorMargins(sweepPointModel(model, axes, point), linkModels(sweepPointLinks(links, axes, point)));
    const SensorMargin& m = margins.at(static_cast<std::size_t>(last.sensor_index));
    c.note = m.note;
    c.half_line = m.half_line;
    if (m.quantity != quantity)
      c.note = "not applicable: " + (m.quantity.empty() ? m.note : "the margin is on the " + m.quantity);
    else if (m.half_line)
    {
      c.diverges_at = m.band.diverges_at;
      c.converges_at = m.band.converges_at;
      c.undecided_band = m.band.undecided_band;
    }
    else
      c.note = "the stable set along " + last.name() + " is not a half-line (no single critical value): " + m.note;
    out.critical.push_back(c);
  }
  return out;
}

}  // namespace networked_estimation
