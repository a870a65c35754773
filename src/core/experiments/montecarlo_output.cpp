// Monte Carlo results and their files (experiment_result.hpp): the summaries of the series, the
// CSV, the JSON and the samples file.
#include "networked_estimation/experiments/experiment_result.hpp"

#include <cerrno>
#include <cmath>
#include <limits>
#include <sstream>
#include <sys/stat.h>

#include "experiments/experiment_support.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/experiments/sweep.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/io/json_writer.hpp"

namespace networked_estimation
{

namespace
{

/// Why a series' mean is not estimable ("" when it is): a mean that is not finite, a standard error
/// above a fifth of the mean, or a mean above the 95th percentile (a few runs carry it).
std::string meanProblem(const CaseResult& c, const SeriesResult& s)
{
  for (std::size_t i = 0; i < s.mean.size(); ++i)
  {
    const std::string at = i < c.x.size() ? " at x = " + mc::fmt(c.x[i]) : "";
    if (!std::isfinite(s.mean[i]))
      return "the mean is not finite" + at + " (some runs overflowed)";
    if (s.n > 1 && i < s.sd.size())
    {
      const double se = s.sd[i] / std::sqrt(static_cast<double>(s.n));
      if (!(se <= 0.2 * std::abs(s.mean[i])))
        return "its standard error is " + mc::fmt(std::round(100.0 * se / std::abs(s.mean[i]))) + " % of it" + at;
    }
    if (i < s.p95.size() && std::isfinite(s.p95[i]) && s.mean[i] > s.p95[i] && s.mean[i] > 0.0)
      return "it lies above the 95th percentile" + at + " (a few runs carry it)";
  }
  return "";
}

}  // namespace

void summarise(ExperimentResult& result)
{
  for (CaseResult& c : result.cases)
    for (SeriesResult& s : c.series)
    {
      s.mean_note = s.bound ? "" : meanProblem(c, s);
      s.mean_estimable = s.mean_note.empty();
      double sum = 0.0;
      long count = 0;
      for (std::size_t i = 0; i < c.x.size() && i < s.mean.size(); ++i)
        if (c.x[i] >= s.window0 && c.x[i] <= s.window1)
        {
          sum += s.mean[i];
          ++count;
        }
      s.time_average = count > 0 ? sum / static_cast<double>(count) : std::nan("");
      s.final_value = s.mean.empty() ? std::nan("") : s.mean.back();
    }
}

namespace
{

std::string csvField(const std::string& s)
{
  if (s.find_first_of(",\"\n") == std::string::npos)
    return s;
  std::string out = "\"";
  for (char c : s)
  {
    if (c == '"')
      out += '"';
    out += c;
  }
  return out + "\"";
}

/// A list of strings, one a line, indented by `indent` (or [] when empty).
void writeLines(JsonWriter& w, const std::vector<std::string>& v, int indent)
{
  w.beginArray();
  for (const std::string& s : v)
    w.br(indent + 2).value(s);
  if (!v.empty())
    w.br(indent);
  w.endArray();
}

}  // namespace

std::string thresholdColumn(double threshold)
{
  return "P_gt_" + mc::fmt(threshold);
}

namespace
{

/// Entry i of v, or an empty cell when v holds none (not computed).
std::string cell(const std::vector<double>& v, std::size_t i)
{
  return i < v.size() ? mc::fmt(v[i]) : std::string();
}

}  // namespace

std::string experimentCsv(const ExperimentResult& result)
{
  if (result.sweep)
    return sweepCsv(*result.sweep);
  std::ostringstream os;
  os << "case,series,x,mean,sd,n,se,p5,p25,median,p75,p95";
  for (double m : result.thresholds)
    os << ',' << thresholdColumn(m);
  os << '\n';
  for (const CaseResult& c : result.cases)
    for (const SeriesResult& s : c.series)
      for (std::size_t i = 0; i < c.x.size(); ++i)
      {
        os << csvField(c.name) << ',' << csvField(s.name) << ',' << mc::fmt(c.x[i]) << ',' << mc::fmt(s.mean[i]) << ','
           << mc::fmt(s.sd[i]) << ',' << s.n << ','
           << (s.n > 0 ? mc::fmt(s.sd[i] / std::sqrt(static_cast<double>(s.n))) : std::string());
        for (const std::vector<double>* q : {&s.p5, &s.p25, &s.median, &s.p75, &s.p95})
          os << ',' << cell(*q, i);
        for (std::size_t t = 0; t < result.thresholds.size(); ++t)
          os << ',' << (t < s.exceed.size() ? cell(s.exceed[t], i) : std::string());
        os << '\n';
      }
  return os.str();
}

std::string plotKindName(PlotHints::Kind kind)
{
  switch (kind)
  {
    case PlotHints::Kind::SERIES:
      return "series";
    case PlotHints::Kind::AVERAGED:
      return "averaged";
    case PlotHints::Kind::DENSITY:
      return "density";
    case PlotHints::Kind::SWEEP:
      return "sweep";
  }
  return "series";
}

namespace
{

/// The "plot" member: the kind, whether to draw the tails, and the kind's own hints.
void writePlotHints(JsonWriter& w, const PlotHints& p)
{
  w.beginObject().member("kind", plotKindName(p.kind)).member("tails", p.tails);
  if (p.kind == PlotHints::Kind::AVERAGED)
    w.key("zoom").beginArray().value(mc::rounded(p.zoom0)).value(mc::rounded(p.zoom1)).endArray();
  if (p.kind == PlotHints::Kind::DENSITY)
  {
    w.member("title", p.density_title);
    w.br(4).key("columns").beginArray();
    for (const PlotHints::DensityColumn& c : p.density_columns)
    {
      w.br(6).beginObject().member("column", c.column).member("label", c.label).member("title", c.title);
      w.endObject();
    }
    w.br(4).endArray();
    w.br(4).key("case_labels").beginObject();
    for (const auto& c : p.case_labels)
      w.br(6).member(c.first, c.second);
    w.br(4).endObject();
    w.br(2);
  }
  w.endObject();
}

}  // namespace

std::string experimentJson(const ExperimentResult& r)
{
  JsonWriter w;
  w.beginObject();
  w.br(2).member("experiment", r.experiment);
  w.br(2).member("runs", r.runs);
  w.br(2).member("steps", r.steps);
  w.br(2).member("seed", r.seed);
  w.br(2).member("threads", r.threads);
  w.br(2).member("wall_seconds", mc::rounded(r.wall_seconds));
  w.br(2).member("x_label", r.x_label);
  w.br(2).member("y_label", r.y_label);
  w.br(2).member("log_x", r.log_x);
  w.br(2).member("log_y", r.log_y);
  w.br(2).key("plot");
  writePlotHints(w, r.plot);
  w.br(2).key("thresholds").value(r.thresholds);
  w.br(2).member("quantile_relative_error", QuantileSketch::kRelativeError);
  w.br(2).key("assumptions");
  writeLines(w, r.assumptions, 2);
  w.br(2).key("cases").beginArray();
  for (const CaseResult& cr : r.cases)
  {
    w.br(4).beginObject();
    w.br(6).member("name", cr.name);
    w.br(6).member("title", cr.title);
    w.br(6).key("series").beginArray();
    for (const SeriesResult& sr : cr.series)
    {
      const double rn = sr.n > 0 ? std::sqrt(static_cast<double>(sr.n)) : std::nan("");
      w.br(8).beginObject().member("name", sr.name);
      w.member("time_average", mc::rounded(sr.time_average)).member("final", mc::rounded(sr.final_value));
      w.key("window").beginArray().value(mc::rounded(sr.window0)).value(mc::rounded(sr.window1)).endArray();
      if (sr.bound)
        w.member("bound", true);
      w.br(10).member("time_average_se", mc::rounded(sr.time_average_sd / rn));
      w.member("final_se", mc::rounded(sr.sd.empty() ? std::nan("") : sr.sd.back() / rn));
      w.key("growth");
      if (std::isfinite(sr.growth))
      {
        const double half = 1.96 * sr.growth_sd / rn;  // the 95 % interval of the mean over the runs
        w.beginObject().member("rate", mc::rounded(sr.growth)).member("low", mc::rounded(sr.growth - half));
        w.member("high", mc::rounded(sr.growth + half));
        w.key("window").beginArray().value(mc::rounded(sr.growth_window0)).value(mc::rounded(sr.growth_window1));
        w.endArray().endObject();
      }
      else
        w.null();
      w.member("statistic", sr.mean_estimable ? "mean" : "median");
      if (!sr.mean_estimable)
        w.member("mean_note", "mean not estimable: " + sr.mean_note);
      w.endObject();
    }
    w.br(6).endArray();
    w.br(4).endObject();
  }
  if (!r.cases.empty())
    w.br(2);
  w.endArray();
  if (r.sweep)
  {
    w.br(2).key("sweep");
    writeSweepJson(w, *r.sweep, 2);
  }
  w.br(2).key("notes");
  writeLines(w, r.notes, 2);
  w.br(0).endObject();
  return w.text() + "\n";
}

std::string samplesCsv(const ExperimentResult& r)
{
  if (r.sample_columns.empty())
    return "";
  std::ostringstream os;
  os << "case,run";
  for (const std::string& c : r.sample_columns)
    os << ',' << csvField(c);
  os << '\n';
  const std::size_t cols = r.sample_columns.size();
  for (const SampleSet& s : r.samples)
    for (std::size_t row = 0; row * cols < s.values.size(); ++row)
    {
      os << csvField(s.case_name) << ',' << row;
      for (std::size_t j = 0; j < cols; ++j)
        os << ',' << mc::fmt(s.values[row * cols + j]);
      os << '\n';
    }
  return os.str();
}

void makeOutputDirectory(const std::string& dir)
{
  std::string partial;
  std::stringstream ss(dir);
  std::string part;
  if (!dir.empty() && dir[0] == '/')
    partial = "/";
  while (std::getline(ss, part, '/'))
  {
    if (part.empty())
      continue;
    partial += part;
    struct stat st;
    if (stat(partial.c_str(), &st) != 0)
    {
      if (mkdir(partial.c_str(), 0777) != 0 && errno != EEXIST)
        throw InputError(dir + ": cannot create the output directory (" + partial + ")");
    }
    else if (!S_ISDIR(st.st_mode))
      throw InputError(dir + ": not a directory (" + partial + ")");
    partial += "/";
  }
}

void writeExperiment(const ExperimentResult& result, const std::string& dir)
{
  makeOutputDirectory(dir);
  const std::string base = (dir.empty() ? std::string(".") : dir) + "/" + result.experiment;
  AtomicFile csv(base + ".csv");
  csv.stream() << experimentCsv(result);
  AtomicFile json(base + ".json");
  json.stream() << experimentJson(result);
  if (!result.sample_columns.empty())
  {
    AtomicFile samples(base + "_samples.csv");
    samples.stream() << samplesCsv(result);
    samples.commit();
  }
  csv.commit();
  json.commit();
}

}  // namespace networked_estimation
