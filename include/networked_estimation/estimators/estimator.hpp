// One small interface for every estimator of the package, and the factory that builds one from a
// model and estimator settings.
//
// Time convention (docs/algorithms.md 1.2): step k takes (x_{k-1|k-1}, P_{k-1|k-1}), the command u_k and the
// received part of y_k, and produces (x_{k|k}, P_{k|k}).
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/estimator_settings.hpp"

namespace networked_estimation
{

/// Input of one step. Reuse one Sample across steps to avoid allocations.
struct Sample
{
  /// gamma_k: the sample reached the estimator. kf ignores it (it cannot tell a loss).
  bool gamma = true;
  /// Stacked y_k (size m). NaN cells mark a sensor whose data did not arrive; a sensor block is
  /// either all finite or all NaN. Ignored (may be empty) when gamma is false, except by kf.
  Eigen::VectorXd y;
  /// Commanded input u_k (size p; may be empty when the model has no control = zero input).
  Eigen::VectorXd u;
  /// nu_k: 1 when u_k reached the actuator, 0 when lost, -1 unknown. Only ack_kf reads it.
  int nu = -1;
  /// Optional R_k of this step (m x m, e.g. from the messages' covariances): empty uses the
  /// model's R. Its blocks of the fused sensors must be symmetric positive definite (the caller
  /// validates them); a non-finite entry or a wrong size is an InputError.
  Eigen::MatrixXd R;
  /// The step's duration in seconds, > 0 (0: the model's period). Only a built-in motion reads it
  /// (ekfio discretises f and Q at it); a linear model's A is per period. Negative or not finite:
  /// InputError from ekfio.
  double dt = 0.0;
};

class Estimator
{
public:
  virtual ~Estimator() = default;

  /// One step k-1 -> k. Throws InputError for malformed input (wrong sizes, a partly missing
  /// sensor block, ack_kf without nu) leaving the estimate untouched, and DivergenceError when the
  /// covariance stops being finite (the estimator must then be reset()).
  virtual void step(const Sample& sample) = 0;

  /// x_{k|k}.
  virtual const Eigen::VectorXd& state() const = 0;
  /// P_{k|k} (symmetric). For rseio the pseudo-covariance of the paper.
  virtual const Eigen::MatrixXd& covariance() const = 0;
  /// aoe/oe: posterior probability that the last command u_k reached the actuator; ack_kf: the
  /// told nu_k; NaN for the others.
  virtual double commandArrivalProbability() const { return std::numeric_limits<double>::quiet_NaN(); }
  /// oe: number of mixture components held (1 for the others).
  virtual std::size_t components() const { return 1; }

  /// Back to x0, P0 (and the initial mode probabilities), step counter 0. Keeps the covariance-only
  /// mode.
  virtual void reset() = 0;

  /// Covariance-only mode (montecarlo --covariance-only): step() then computes P_{k|k} exactly as in
  /// the ordinary mode, by the same code, but not the state, which stays at x0 (state() is not an
  /// estimate then). Only which sensors arrived is read from a sample (gamma and the finite or NaN
  /// cells of y, whose values are not used); u and nu are not needed. Offered where P does not depend
  /// on the data: kf, kfio, ack_kf and rseio. Returns whether the estimator has the mode (false: it
  /// stays in the ordinary mode; switching it off always succeeds).
  virtual bool setCovarianceOnly(bool on) { return !on; }

  /// An independent copy in the same state (used to rewind and re-filter a bounded history).
  virtual std::unique_ptr<Estimator> clone() const = 0;

  virtual Algorithm algorithm() const = 0;
  /// Which compiled form of the algorithm runs: "dynamic" (the general one, any size) or the
  /// fixed-size one makeEstimator chose for the model's dimensions, e.g. "fixed n=2 m=1". Both
  /// compute the same estimate; for logs, benchmarks and tests.
  virtual std::string implementation() const { return "dynamic"; }
  /// Number of steps taken since construction / reset.
  long steps() const { return steps_; }
  /// Whether the last step used a measurement (some sensor arrived and was fused).
  bool lastUpdated() const { return last_updated_; }

protected:
  long steps_ = 0;
  bool last_updated_ = false;
};

/// The prior of a step from (x, P) = (x_{k-1|k-1}, P_{k-1|k-1}), as kfio and ekfio predict: for a linear
/// model xp = A x + Bu u (u empty: zero input), Pp = A P A' + B Q B'; for a built-in motion
/// xp = f(x, dt), Pp = F P F' + Q dt (dt = 0: the model's period), two_d_mode applied. Used by the
/// rejection thresholds (OnlineOptions).
void predictPrior(const Model& model, const Eigen::VectorXd& x, const Eigen::MatrixXd& P, const Eigen::VectorXd& u,
                  double dt, Eigen::VectorXd& xp, Eigen::MatrixXd& Pp);

/// The most whole periods predictAhead takes a linear model over (k matrix products).
constexpr long kMaxPredictAheadSteps = 1000;

/// An estimate (x, P) predicted `dt` seconds past its step, with no measurement and not fed back
/// into any filter (the Estimator's predict_to_current_time), by predictPrior's equations with zero
/// input: a built-in motion once over dt (xp = f(x, dt), Pp = F P F' + Q dt, two_d_mode applied);
/// a linear model, whose steps are whole periods of `period` s, k = round(dt / period) times
/// (xp = A^k x, Pp = A Pp A' + B Q B' k times). Returns the time predicted over: dt, or k periods
/// (0: (x, P) as they are). Throws InputError naming dt for a dt that is negative or not finite, a
/// period that is not positive, or a linear k above kMaxPredictAheadSteps.
double predictAhead(const Model& model, double period, const Eigen::VectorXd& x, const Eigen::MatrixXd& P,
                    double dt, Eigen::VectorXd& xp, Eigen::MatrixXd& Pp);

/// Checks sample.R for a step of `model` (nothing when it is empty): m x m, and the block of every
/// sensor the step fuses (gamma set and the sensor's y finite) finite, symmetric and positive
/// definite. Throws InputError "R: ..." naming the sensor, e.g. "R: sensor 'gps': its block is not
/// positive definite". The estimators leave this to their callers (it is per message in the
/// nodelet, per file row in replay); the Python module checks with it.
void checkStepCovariance(const Model& model, const Sample& sample);

/// Builds the estimator named by settings.algorithm. Throws ConfigError when the combination is
/// invalid (e.g. aoe/oe for a model with control but settings without control_link).
/// The estimator keeps its own copy of the model.
std::unique_ptr<Estimator> makeEstimator(const Model& model, const EstimatorSettings& settings);

}  // namespace networked_estimation
