// Helpers the experiments share (experiment_support.hpp): series from a call's moments, the call's
// statistics, the step axis.
#include "experiments/experiment_support.hpp"

#include <limits>

namespace networked_estimation
{
namespace mc
{

SeriesResult makeSeries(const std::string& name, const Moments& m, std::size_t first, std::size_t count, double window0,
                        double window1)
{
  SeriesResult s;
  s.name = name;
  s.mean.assign(m.mean.begin() + static_cast<std::ptrdiff_t>(first),
                m.mean.begin() + static_cast<std::ptrdiff_t>(first + count));
  s.sd.assign(m.sd.begin() + static_cast<std::ptrdiff_t>(first),
              m.sd.begin() + static_cast<std::ptrdiff_t>(first + count));
  s.n = m.n;
  s.window0 = window0;
  s.window1 = window1;
  resizeTails(s, count, m);
  for (std::size_t i = 0; i < count; ++i)
    setTails(s, i, m, first + i);
  for (std::size_t k = 0; k < m.spans.size(); ++k)
  {
    const SeriesSpan& sp = m.spans[k];
    if (sp.first != first || sp.x.size() != count)
      continue;
    s.growth = m.growth_mean[k];
    s.growth_sd = m.growth_sd[k];
    s.growth_window0 = sp.x[count / 2];
    s.growth_window1 = sp.x.back();
    if (sp.window0 == window0 && sp.window1 == window1)
      s.time_average_sd = m.average_sd[k];
  }
  return s;
}

void resizeTails(SeriesResult& s, std::size_t count, const Moments& m)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!m.sketches.empty())
    for (std::vector<double>* q : {&s.p5, &s.p25, &s.median, &s.p75, &s.p95})
      q->assign(count, nan);
  s.exceed.assign(m.thresholds.size(), std::vector<double>(count, nan));
}

void setTails(SeriesResult& s, std::size_t i, const Moments& m, std::size_t v)
{
  if (!m.sketches.empty())
  {
    const QuantileSketch& q = m.sketches.at(v);
    s.p5.at(i) = q.quantile(0.05);
    s.p25.at(i) = q.quantile(0.25);
    s.median.at(i) = q.quantile(0.5);
    s.p75.at(i) = q.quantile(0.75);
    s.p95.at(i) = q.quantile(0.95);
  }
  const std::size_t nt = m.thresholds.size();
  for (std::size_t t = 0; t < nt && t < s.exceed.size(); ++t)
    s.exceed[t].at(i) = m.exceed.at(v * nt + t);
}

CallStatistics callStatistics(const RunConfig& rc)
{
  CallStatistics st;
  st.quantiles = true;
  if (rc.config)
    st.thresholds = rc.config->thresholds;
  return st;
}

void addSpan(CallStatistics& st, std::size_t first, const std::vector<double>& x, double window0, double window1)
{
  SeriesSpan sp;
  sp.first = first;
  sp.x = x;
  sp.window0 = window0;
  sp.window1 = window1;
  st.spans.push_back(std::move(sp));
}

std::vector<double> stepAxis(long steps)
{
  std::vector<double> x(static_cast<std::size_t>(steps));
  for (long k = 1; k <= steps; ++k)
    x[static_cast<std::size_t>(k - 1)] = static_cast<double>(k);
  return x;
}

}  // namespace mc
}  // namespace networked_estimation
