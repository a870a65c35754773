// The reporting of bench_estimators: the console reporter that collects the time per step of every
// run, and the summary tables (ratios to the baselines, the targets marked PASS / MISS).
#pragma once

#include <benchmark/benchmark.h>

#include <cstddef>
#include <cstdlib>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace networked_estimation
{
namespace bench
{

struct Timing
{
  std::vector<double> reps;  ///< ns per step, one per repetition
  double agg_median = -1.0;  ///< from the aggregates (used when the repetitions were not reported)
  double agg_min = -1.0;
  double components = 1.0;
  std::string error;
};

using Key = std::pair<std::string, int>;  // (benchmark name, n)

inline int parseSize(const std::string& args)
{
  const std::size_t colon = args.rfind(':');
  return std::atoi(args.c_str() + (colon == std::string::npos ? 0 : colon + 1));
}

/// The console reporter, showing only the median and min aggregates when there are repetitions,
/// and collecting every run's real time per step for the summary.
class CollectingReporter : public benchmark::ConsoleReporter
{
public:
  explicit CollectingReporter(bool cpu_time)
    : benchmark::ConsoleReporter(benchmark::ConsoleReporter::OO_Tabular), cpu_time_(cpu_time)
  {
  }

  void ReportRuns(const std::vector<Run>& runs) override
  {
    std::vector<Run> shown;
    for (const Run& r : runs)
    {
      const Key key(r.run_name.function_name, parseSize(r.run_name.args));
      Timing& t = timings_[key];
      const auto comps = r.counters.find("components");
      if (comps != r.counters.end())
      {
        t.components = comps->second.value;
      }
      if (r.error_occurred)
      {
        t.error = r.error_message;
        shown.push_back(r);
        continue;
      }
      if (r.run_type == Run::RT_Iteration)
      {
        t.reps.push_back(timeOf(r));
        if (r.repetitions <= 1)
        {
          shown.push_back(r);
        }
      }
      else if (r.aggregate_name == "median" || r.aggregate_name == "min")
      {
        (r.aggregate_name == "median" ? t.agg_median : t.agg_min) = timeOf(r);
        shown.push_back(r);
      }
    }
    if (!shown.empty())
    {
      benchmark::ConsoleReporter::ReportRuns(shown);
    }
  }

  const std::map<Key, Timing>& timings() const { return timings_; }
  bool cpuTime() const { return cpu_time_; }

private:
  double timeOf(const Run& r) const { return cpu_time_ ? r.GetAdjustedCPUTime() : r.GetAdjustedRealTime(); }

  bool cpu_time_;
  std::map<Key, Timing> timings_;
};

/// Prints the summary tables of the collected timings (CPU or real time per step); `oe_components`
/// is the component limit oe ran with.
void printSummary(const std::map<Key, Timing>& timings, bool cpu_time, std::size_t oe_components);

}  // namespace bench
}  // namespace networked_estimation
