// The result of a Monte Carlo experiment and its files (ROS-free).
//
// Output contract (read by the plot scripts, docs/formats.md):
//   DIR/<experiment>.csv    case,series,x,mean,sd,n,se,p5,p25,median,p75,p95[,P_gt_M...]  (%.10g)
//   DIR/<experiment>.json   metadata, plot hints and per-series summaries (experimentJson)
//   DIR/zhou_fig2_samples.csv  case,run,P11,P12,P21,P22   (zhou_fig2 only)
//   sweep: DIR/sweep.csv holds one row per (grid point, estimator) instead (sweep.hpp), and
//   DIR/sweep.json a "sweep" member with the grid, the verdicts and the critical curve
// A sharded run writes DIR/<experiment>.shard-K-of-N.json instead (montecarlo_shards.hpp).
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace networked_estimation
{

// ---------------------------------------------------------------------------------------------
// Results

struct SeriesResult
{
  std::string name;
  std::vector<double> mean, sd;         ///< one per x of the case
  long n = 0;                           ///< runs
  double window0 = 0.0, window1 = 0.0;  ///< x range of time_average (inclusive)
  double time_average = 0.0;            ///< mean over x in the window of `mean`
  double final_value = 0.0;             ///< mean at the last x
  bool bound = false;                   ///< a bound (JSON "bound": true: plotted dashed)
  // Heavy tails (docs/formats.md, "Heavy tails"); NaN where the experiment does not compute them.
  /// Per x: the quantiles over the runs (within QuantileSketch::kRelativeError).
  std::vector<double> p5, p25, median, p75, p95;
  /// Per threshold of ExperimentResult::thresholds, per x: the fraction of runs above it.
  std::vector<std::vector<double>> exceed;
  /// The sd over the runs of a run's own time average (its standard error: / sqrt(n)).
  double time_average_sd = std::numeric_limits<double>::quiet_NaN();
  /// The growth exponent of log value per unit of x (CallStatistics::spans): mean and sd over the
  /// runs, and the x range it is fitted over.
  double growth = std::numeric_limits<double>::quiet_NaN(), growth_sd = std::numeric_limits<double>::quiet_NaN();
  double growth_window0 = std::numeric_limits<double>::quiet_NaN(),
         growth_window1 = std::numeric_limits<double>::quiet_NaN();
  /// Whether the mean is estimable (summarise()): every mean finite, its standard error at most a
  /// fifth of it, and not above the 95th percentile; `mean_note` says why not. The plots draw the
  /// median with a quantile band where it is not.
  bool mean_estimable = true;
  std::string mean_note;
};

struct CaseResult
{
  std::string name, title;
  std::vector<double> x;
  std::vector<SeriesResult> series;
};

/// Per-run values of one case (zhou_fig2: P_{T|T} of every run).
struct SampleSet
{
  std::string case_name;
  std::vector<double> values;  ///< runs x columns, row-major
};

struct SweepResult;  // sweep.hpp

/// How an experiment is drawn (scripts/plot_montecarlo.py reads them from the JSON's "plot" member;
/// the axes' labels and scales are ExperimentResult's x_label, y_label, log_x and log_y).
struct PlotHints
{
  enum class Kind
  {
    SERIES,    ///< "series": NAME.png, one panel per case, every series against x
    AVERAGED,  ///< "averaged": NAME_<case>.png per case, the full x range and a zoom whose legend
               ///< gives each series' time average
    DENSITY,   ///< "density": NAME.png, the kernel density of the per-run samples (NAME_samples.csv)
    SWEEP      ///< "sweep": NAME.png, the stability map of the "sweep" member
  };
  Kind kind = Kind::SERIES;
  /// NAME_tail.png besides when the CSV has P_gt_M columns (series and averaged).
  bool tails = true;
  /// averaged: the x range of the zoom panel (the second half of x when it holds fewer than 2 points).
  double zoom0 = 0.0, zoom1 = 0.0;
  /// density: one panel per column of the samples file drawn.
  struct DensityColumn
  {
    std::string column;  ///< a column of sample_columns
    std::string label;   ///< the x axis' label
    std::string title;   ///< the panel's title
  };
  std::vector<DensityColumn> density_columns;
  std::string density_title;  ///< density: the figure's title (after "NAME: ")
  /// density: the legend text of each case (case name, label); a case not named here shows its title.
  std::vector<std::pair<std::string, std::string>> case_labels;
};

/// The name of a plot kind in the JSON: "series", "averaged", "density" or "sweep".
std::string plotKindName(PlotHints::Kind kind);

struct ExperimentResult
{
  std::string experiment;
  long runs = 0, steps = 0;
  std::vector<double> thresholds;  ///< --threshold: the M of the tail probabilities P(value > M)
  std::uint64_t seed = 1;
  int threads = 1;
  double wall_seconds = 0.0;
  std::string x_label, y_label;
  bool log_x = false, log_y = false;
  PlotHints plot;  ///< how the plot script draws it (the JSON's "plot" member)
  std::vector<std::string> assumptions, notes;
  std::vector<CaseResult> cases;
  std::vector<std::string> sample_columns;  ///< empty: no samples file
  std::vector<SampleSet> samples;
  /// sweep only: the grid (then `cases` is empty and the CSV is sweepCsv's).
  std::shared_ptr<const SweepResult> sweep;
};

/// Fills time_average and final_value of every series from its window, and mean_estimable.
void summarise(ExperimentResult& result);

/// `case,series,x,mean,sd,n,se,p5,p25,median,p75,p95` and a P_gt_M column per threshold, rows
/// (numbers with %.10g, NaN as nan, empty where not computed).
std::string experimentCsv(const ExperimentResult& result);
/// The JSON metadata document with the plot hints (docs/formats.md, "NAME.json"; strings escaped).
std::string experimentJson(const ExperimentResult& result);
/// `case,run,<columns>` rows of the samples (empty string when there are none).
std::string samplesCsv(const ExperimentResult& result);
/// Writes DIR/<experiment>.csv, .json (and _samples.csv) atomically, creating DIR if needed.
/// Throws InputError when a file cannot be written.
void writeExperiment(const ExperimentResult& result, const std::string& dir);
/// Creates DIR and its parents when missing. Throws InputError when it cannot, or when a part of
/// the path is not a directory.
void makeOutputDirectory(const std::string& dir);

/// The name of the tail probability column of threshold M: "P_gt_" + M (%.10g).
std::string thresholdColumn(double threshold);

}  // namespace networked_estimation
