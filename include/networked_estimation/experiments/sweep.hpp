// Stability maps: `montecarlo --experiment sweep` runs the custom experiment's model, links and
// estimators at every point of a grid of one or two parameters and writes, per grid point and
// estimator, the mean and spread of tr(P) and of the squared error, the analytic verdict of the
// point and the critical curve of the stability analysis (docs/formats.md, section 8,
// "Stability maps"). ROS-free.
//
// An axis is NAME=LO:HI:N, N values LO + (HI - LO) i / (N - 1), i = 0 .. N-1, NAME one of
//   SENSOR.arrival_rate   the sensor's link becomes i.i.d. (bernoulli) with P(arrived) = value
//   SENSOR.loss           its bernoulli link's loss
//   SENSOR.recovery_rate, SENSOR.r, SENSOR.p, SENSOR.loss_good, SENSOR.loss_bad
//                         that key of its gilbert_elliott link (the others as in the file)
//   ESTIMATOR.mu, ESTIMATOR.recovery, ESTIMATOR.failure
//                         that key of the estimator's settings (ESTIMATOR: a --settings name)
//   model.A[i][j], model.C[i][j]   that entry of the model (0-based; C stacked over the sensors)
//   model.Q*, model.R*    a factor on Q, on R (every sensor's)
#pragma once

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// One axis of a sweep.
class JsonWriter;

struct SweepAxis
{
  /// What an axis changes: a sensor's link, an estimator's settings, or the model.
  enum class Kind
  {
    LINK,
    SETTINGS,
    MODEL
  };
  std::string arg;  ///< the --axis argument as given
  Kind kind = Kind::LINK;
  /// The sensor (LINK), the estimator (SETTINGS) or "model" (MODEL).
  std::string sensor;
  /// LINK and SETTINGS: the key ("arrival_rate", "mu", ...); MODEL: "A", "C", "Q*" or "R*".
  std::string param;
  int row = -1, col = -1;  ///< MODEL A and C: the entry
  int sensor_index = -1;   ///< LINK: into Model::sensors; SETTINGS: into the estimators (resolveSweepAxes)
  double lo = 0.0, hi = 0.0;
  long count = 0;
  std::vector<double> values;
  /// As written before '=': "gnss.arrival_rate", "kfio.mu", "model.A[0][0]", "model.Q*".
  std::string name() const;
};

/// The parameters of a sensor's link an axis can name.
const std::vector<std::string>& sweepParameters();
/// The parameters of an estimator's settings an axis can name.
const std::vector<std::string>& sweepSettingsParameters();

/// N values from lo to hi, both included (lo alone when n = 1).
std::vector<double> sweepValues(double lo, double hi, long n);

/// Parses "NAME=LO:HI:N" (not yet against a model). Throws ConfigError naming the argument for a
/// bad form, an unknown parameter, N < 1 (or > 10000), LO > HI, N = 1 with LO != HI, or a value
/// outside the parameter's range ([0, 1] for probabilities, (0, 1] for mu, > 0 for the factors,
/// finite for the entries).
SweepAxis parseSweepAxis(const std::string& arg);

/// Resolves the axes against the model, the sensors' links (one per sensor, none = lossless) and
/// the estimators' names (`estimators`; empty: no settings axis allowed): the sensor or estimator
/// must exist, a gilbert_elliott key needs that sensor's link to be gilbert_elliott and loss a
/// bernoulli one, an entry must lie in the matrix of a linear model, mu needs rseio, recovery and
/// failure aoe or oe with control_link; at most two axes, none twice, at most 10000 grid points.
/// Throws ConfigError naming the argument.
void resolveSweepAxes(std::vector<SweepAxis>& axes, const Model& model,
                      const std::vector<std::optional<ChannelSettings>>& links,
                      const std::vector<std::string>& estimators = {},
                      const std::vector<EstimatorSettings>& settings = {});

/// The links at one grid point: `links` with each link axis's sensor changed to its value.
std::vector<std::optional<ChannelSettings>> sweepPointLinks(const std::vector<std::optional<ChannelSettings>>& links,
                                                            const std::vector<SweepAxis>& axes,
                                                            const std::vector<double>& values);
/// The model at one grid point (its model axes applied, validated). Throws ConfigError naming the
/// axis when the point's model is invalid (e.g. R not positive definite).
Model sweepPointModel(const Model& model, const std::vector<SweepAxis>& axes, const std::vector<double>& values);
/// The estimators' settings at one grid point (its settings axes applied).
std::vector<EstimatorSettings> sweepPointSettings(const std::vector<EstimatorSettings>& settings,
                                                  const std::vector<SweepAxis>& axes,
                                                  const std::vector<double>& values);

/// The analytic side of a sweep (core stability analysis, docs/stability.md 2.1 and 4.3).
struct SweepAnalysis
{
  /// Per grid point (axis 1 major: point = i1 * N2 + i2): "stable", "unstable", "undecided" or
  /// "not applicable".
  std::vector<std::string> verdicts;
  /// The critical value of the last axis: for a two-axis sweep one per value of axis 1 (the other
  /// links as at that value), for one axis a single one. Unstable at and below diverges_at, stable
  /// at and above converges_at (NaN: none found in [0, 1]); undecided_band when rates in between
  /// were neither. Only when the stable set along the axis is a half-line (`note` says otherwise).
  struct Critical
  {
    double at = std::numeric_limits<double>::quiet_NaN();  ///< axis 1 value (NaN for one axis)
    double diverges_at = std::numeric_limits<double>::quiet_NaN();
    double converges_at = std::numeric_limits<double>::quiet_NaN();
    bool undecided_band = false;
    bool half_line = true;
    std::string note;  ///< how it was found (sensorMargins), or why there is none
  };
  std::vector<Critical> critical;
};

/// Verdicts of every grid point (its model and links) and the critical curve of the last axis
/// (when it is an arrival or recovery rate).
SweepAnalysis analyseSweep(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                           const std::vector<SweepAxis>& axes);

/// What a sweep computes per (grid point, estimator): over the n runs, the mean and sample sd of
/// tr(P_T) and |x_T - xhat_T|^2 at the final step T and of their averages over the last half of the
/// horizon (k = floor(T/2) + 1 .. T). Undefined (NaN, written as empty / null) unless every run
/// completed: `diverged` runs where the estimator failed (DivergenceError, or a non-finite tr P or
/// error), `floored` runs where the plant crossed the rounding floor (simulator.hpp: no estimator
/// statistic is meaningful there).
struct SweepCell
{
  long n = 0, diverged = 0, floored = 0;
  double trP_mean = std::nan(""), trP_sd = std::nan("");
  double err_mean = std::nan(""), err_sd = std::nan("");
  double trP_avg_mean = std::nan(""), trP_avg_sd = std::nan("");
  double err_avg_mean = std::nan(""), err_avg_sd = std::nan("");
  // Heavy tails (docs/formats.md, "Heavy tails"): quantiles of tr P_T over the runs, the fraction of
  // runs with tr P_T above each threshold (SweepResult::thresholds), the median of the final squared
  // error, and the growth exponent of log tr P_k over the last half (mean and sd over the runs).
  double trP_p5 = std::nan(""), trP_p25 = std::nan(""), trP_median = std::nan(""), trP_p75 = std::nan(""),
         trP_p95 = std::nan("");
  std::vector<double> trP_exceed;
  double err_median = std::nan("");
  double growth = std::nan(""), growth_sd = std::nan("");
};

struct SweepResult
{
  std::vector<SweepAxis> axes;
  std::vector<std::string> estimators;
  long points = 0;
  std::vector<std::vector<double>> point_values;  ///< per point, the value of each axis
  std::vector<SweepCell> cells;                   ///< point-major: cells[point * estimators + j]
  SweepAnalysis analysis;
  std::vector<double> thresholds;  ///< --threshold
};

/// `point,i1,i2,<axis 1>,<axis 2>,estimator,n,diverged,floored,trP_mean,...,verdict` rows.
std::string sweepCsv(const SweepResult& sweep);
/// Writes the "sweep" member of DIR/sweep.json (an object, its lines indented by `indent` spaces).
void writeSweepJson(JsonWriter& w, const SweepResult& sweep, int indent);

}  // namespace networked_estimation
