// Private: what every experiment of the montecarlo tool uses: its run configuration, the series
// made from a call's moments, the call's statistics and the number format of the outputs.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "networked_estimation/experiments/experiment_registry.hpp"
#include "networked_estimation/experiments/experiment_result.hpp"
#include "networked_estimation/experiments/montecarlo_engine.hpp"

namespace networked_estimation
{
namespace mc
{

/// Everything an experiment needs: resolved runs/steps/threads, the seed, and where its Monte Carlo
/// calls go.
struct RunConfig
{
  long runs = 0, steps = 0;
  std::uint64_t seed = 1;
  int threads = 1;
  const MonteCarloConfig* config = nullptr;
  ProgressCounter* progress = nullptr;
  /// The shard or replay session every runMonteCarlo call of the experiment takes (null: a plain run).
  BlockSession* session = nullptr;
};

/// A series from the moments `m` at offset `first` (values first .. first + x_count - 1), with the
/// heavy-tail statistics the call computed: quantiles, tail probabilities, and from a span of the
/// same values the growth exponent (and the time average's sd when the span has the same window).
SeriesResult makeSeries(const std::string& name, const Moments& m, std::size_t first, std::size_t count, double window0,
                        double window1);
/// Sizes the quantiles and tail probabilities of `s` for `count` points (those `m` has).
void resizeTails(SeriesResult& s, std::size_t count, const Moments& m);
/// Point i of `s`: the quantiles and tail probabilities of value v of `m`.
void setTails(SeriesResult& s, std::size_t i, const Moments& m, std::size_t v);
/// The statistics of an experiment's Monte Carlo calls: quantiles, the --threshold values.
CallStatistics callStatistics(const RunConfig& rc);
/// Adds a span (the series of values first .. first + x.size() - 1) to `st`.
void addSpan(CallStatistics& st, std::size_t first, const std::vector<double>& x, double window0, double window1);

/// %.10g.
inline std::string fmt(double v)
{
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

/// `v` rounded to the digits fmt() prints: the value the JSON outputs hold, as the CSV ones.
inline double rounded(double v)
{
  return std::isfinite(v) ? std::strtod(fmt(v).c_str(), nullptr) : v;
}

/// 1..steps as doubles.
std::vector<double> stepAxis(long steps);

}  // namespace mc
}  // namespace networked_estimation
