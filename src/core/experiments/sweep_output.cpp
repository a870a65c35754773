// The files of a sweep (sweep.hpp): DIR/sweep.csv's rows and the "sweep" member of DIR/sweep.json.
#include "networked_estimation/experiments/sweep.hpp"

#include <cmath>
#include <cstddef>
#include <sstream>
#include <string>
#include <vector>

#include "experiments/experiment_support.hpp"
#include "networked_estimation/experiments/experiment_result.hpp"
#include "networked_estimation/io/json_writer.hpp"

namespace networked_estimation
{

namespace
{

/// %.10g, or `null_text` for NaN / infinity.
std::string sweepNumber(double v, const char* null_text)
{
  return std::isfinite(v) ? mc::fmt(v) : null_text;
}

}  // namespace

std::string sweepCsv(const SweepResult& sw)
{
  std::ostringstream os;
  os << "point,i1,i2,x1,x2,estimator,n,diverged,floored,trP_mean,trP_sd,err_mean,err_sd,trP_avg_mean,trP_avg_sd,"
        "err_avg_mean,err_avg_sd,verdict,trP_se,trP_p5,trP_p25,trP_median,trP_p75,trP_p95,err_se,err_median,growth,"
        "growth_low,growth_high";
  for (double t : sw.thresholds)
    os << ",trP_" << thresholdColumn(t);
  os << '\n';
  const long n2 = sw.axes.size() > 1 ? sw.axes[1].count : 1;
  for (long p = 0; p < sw.points; ++p)
  {
    const std::vector<double>& v = sw.point_values[static_cast<std::size_t>(p)];
    for (std::size_t j = 0; j < sw.estimators.size(); ++j)
    {
      const SweepCell& c = sw.cells[static_cast<std::size_t>(p) * sw.estimators.size() + j];
      os << p << ',' << p / n2 << ',' << (sw.axes.size() > 1 ? p % n2 : 0) << ',' << mc::fmt(v[0]) << ','
         << (v.size() > 1 ? mc::fmt(v[1]) : "") << ',' << sw.estimators[j] << ',' << c.n << ',' << c.diverged << ','
         << c.floored;
      for (double x :
           {c.trP_mean, c.trP_sd, c.err_mean, c.err_sd, c.trP_avg_mean, c.trP_avg_sd, c.err_avg_mean, c.err_avg_sd})
        os << ',' << sweepNumber(x, "");
      os << ',' << sw.analysis.verdicts[static_cast<std::size_t>(p)];
      const double rn = std::sqrt(static_cast<double>(c.n));
      const double half = 1.96 * c.growth_sd / rn;  // the 95 % interval of the mean over the runs
      for (double x : {c.trP_sd / rn, c.trP_p5, c.trP_p25, c.trP_median, c.trP_p75, c.trP_p95, c.err_sd / rn,
                       c.err_median, c.growth, c.growth - half, c.growth + half})
        os << ',' << sweepNumber(x, "");
      for (std::size_t t = 0; t < sw.thresholds.size(); ++t)
        os << ',' << (t < c.trP_exceed.size() ? sweepNumber(c.trP_exceed[t], "") : "");
      os << '\n';
    }
  }
  return os.str();
}

void writeSweepJson(JsonWriter& w, const SweepResult& sw, int in)
{
  w.beginObject();
  w.br(in + 2).key("axes").beginArray();
  for (const SweepAxis& a : sw.axes)
  {
    w.br(in + 4).beginObject().member("name", a.name()).member("sensor", a.sensor).member("param", a.param);
    w.member("arg", a.arg).member("lo", mc::rounded(a.lo)).member("hi", mc::rounded(a.hi)).member("count", a.count);
    w.key("values").beginArray();
    for (double v : a.values)
      w.value(mc::rounded(v));
    w.endArray().endObject();
  }
  w.br(in + 2).endArray();
  w.br(in + 2).member("estimators", sw.estimators);
  w.br(in + 2).member("points", sw.points);
  long incomplete = 0;
  for (const SweepCell& c : sw.cells)
    incomplete += (c.diverged > 0 || c.floored > 0) ? 1 : 0;
  w.br(in + 2).member("incomplete_cells", incomplete);
  w.br(in + 2).member("verdicts", sw.analysis.verdicts);
  const SweepAxis& last = sw.axes.back();
  w.br(in + 2).key("critical").beginObject().member("axis", last.name()).key("along");
  if (sw.axes.size() > 1)
    w.value(sw.axes[0].name());
  else
    w.null();
  w.key("curve").beginArray();
  for (const SweepAnalysis::Critical& c : sw.analysis.critical)
  {
    w.br(in + 4).beginObject().member("at", mc::rounded(c.at)).member("diverges_at", mc::rounded(c.diverges_at));
    w.member("converges_at", mc::rounded(c.converges_at)).member("undecided_band", c.undecided_band);
    w.member("half_line", c.half_line).member("note", c.note).endObject();
  }
  w.br(in + 2).endArray().endObject();
  w.br(in).endObject();
}

}  // namespace networked_estimation
