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

/// The prior of a step (Estimator::predict): the predicted mean and covariance from
/// (x_{k-1|k-1}, P_{k-1|k-1}) and the step's command, and for each sensor i the innovation
/// covariance S_i = C_i Pp C_i' + R_i (R_i: the sensor's block of Sample::R when given, else of the
/// model's R). Each algorithm's own prediction:
///   kf, kfio, ack_kf: xp = A x + Bu u (ack_kf: nu_k Bu u), Pp = A P A' + B Q B';
///   ekfio:            a built-in motion's xp = f(x, dt), Pp = F P F' + Q dt (two_d_mode applied), or
///                     kfio's on a linear model;
///   rseio:            the robust prediction (docs/algorithms.md 4.4) for the sensors the sample
///                     holds (the nominal one, kfio's, when none), Pp its pseudo-covariance;
///   aoe, oe:          the moments of the predicted mixture (docs/algorithms.md 2.8): with components
///                     j of weight w_j, mean m_j and the shared covariance Z,
///                     xp = sum_j w_j m_j,  Pp = Z + sum_j w_j (m_j - xp)(m_j - xp)';
///                     for aoe the two outcomes of the command, w = (1 - nubar1, nubar1),
///                     m = (A x, A x + Bu u): xp = A x + nubar1 Bu u, Pp = Zbar + nubar0 nubar1 (Bu u)(Bu u)'.
/// S_i is computed when first asked for (the gate asks for the sensors it examines only). Valid
/// until the estimator's next predict, step, update, reset or restore.
class Prior
{
public:
  /// xp (n).
  const Eigen::VectorXd& mean() const { return x_; }
  /// Pp (n x n, symmetric).
  const Eigen::MatrixXd& covariance() const { return P_; }
  /// Number of sensors (the model's).
  std::size_t sensors() const { return S_.size(); }
  /// S_i = C_i Pp C_i' + R_i of sensor i (model order; size x size). Throws InputError for an index
  /// past the sensors.
  const Eigen::MatrixXd& innovationCovariance(std::size_t sensor) const;

  /// For the estimators: a new prior for `model` (kept by pointer: the estimator's own copy) with
  /// the step's own R (nullptr: the model's R), then its mean and covariance.
  void begin(const Model& model, const Eigen::MatrixXd* step_R);
  template <class V, class M>
  void setMoments(const Eigen::MatrixBase<V>& mean, const Eigen::MatrixBase<M>& covariance)
  {
    x_ = mean;
    P_ = covariance;
  }

private:
  const Model* model_ = nullptr;
  Eigen::VectorXd x_;
  Eigen::MatrixXd P_;
  Eigen::MatrixXd R_;  ///< the step's own R (when own_R_)
  bool own_R_ = false;
  mutable std::vector<Eigen::MatrixXd> S_;
  mutable std::vector<char> have_S_;
};

/// What an estimator carries from one step to the next, as a value (Estimator::snapshot, restore):
/// copying it is what rewinding needs, without the model and the workspace of the estimator.
/// The same value for the fixed-size and the dynamic form of an algorithm.
struct EstimatorState
{
  Algorithm algorithm = Algorithm::KFIO;
  Eigen::VectorXd x;  ///< x_{k|k}
  Eigen::MatrixXd P;  ///< P_{k|k} (rseio: its pseudo-covariance)
  long steps = 0;
  bool last_updated = false;
  bool diverged = false;
  /// aoe, oe: nuhat_k^[1]; ack_kf: the last nu_k told (0 or 1; -1: none yet); NaN for the others.
  double command_arrival = std::numeric_limits<double>::quiet_NaN();
  /// oe: its mixture: the components' means (n x c), log weights and P(newest command bit = 1) (c
  /// each), the shared covariance Mhat (n x n) and whether the cap has discarded a component.
  /// Empty for the others.
  Eigen::MatrixXd means;
  Eigen::VectorXd log_weights, newest_bit;
  Eigen::MatrixXd shared_covariance;
  bool capped = false;
};

class Estimator
{
public:
  virtual ~Estimator() = default;

  /// One step k-1 -> k: predict(sample) then update(sample), in one call (without forming the
  /// Prior). Throws InputError for malformed input (wrong sizes, a partly missing sensor block,
  /// ack_kf without nu) leaving the estimate untouched, and DivergenceError when the covariance
  /// stops being finite (the estimator must then be reset()).
  virtual void step(const Sample& sample) = 0;

  /// The first half of step(sample): checks the sample as step() does (InputError, nothing
  /// changed) and predicts from x_{k-1|k-1}, P_{k-1|k-1} with the sample's command (and, for
  /// rseio, its arrived sensors). The estimate is not changed: state(), covariance(), steps() are
  /// still those of step k-1 until update(). A second predict replaces the first.
  virtual const Prior& predict(const Sample& sample) = 0;
  /// The second half: fuses the sample's measurements into the pending prediction and ends the step
  /// (step k). The sample is predict's, with possibly fewer sensors (their y NaN, gamma false when
  /// none is left: what a gate refused); u, nu and dt are read by predict only, y, gamma and R here.
  /// When the arrived sensors changed, rseio (whose prediction depends on them) predicts again.
  /// Throws InputError (nothing changed) without a pending prediction or for a malformed y.
  virtual void update(const Sample& sample) = 0;

  /// x_{k|k}.
  virtual const Eigen::VectorXd& state() const = 0;
  /// P_{k|k} (symmetric). For rseio the pseudo-covariance of the paper.
  virtual const Eigen::MatrixXd& covariance() const = 0;
  /// aoe/oe: posterior probability that the last command u_k reached the actuator; ack_kf: the
  /// told nu_k; NaN for the others.
  virtual double commandArrivalProbability() const { return std::numeric_limits<double>::quiet_NaN(); }
  /// oe: number of mixture components held (1 for the others).
  virtual std::size_t components() const { return 1; }

  /// The estimator's state as a value (into `out`, reusing its storage).
  virtual void snapshot(EstimatorState& out) const = 0;
  EstimatorState snapshot() const
  {
    EstimatorState s;
    snapshot(s);
    return s;
  }
  /// Continues from a snapshot of an estimator of the same algorithm and model (either form):
  /// the next step computes what the snapshotted estimator's next step computes. Drops a pending
  /// prediction; keeps the covariance-only mode. Throws InputError naming the field (nothing
  /// changed) for another algorithm or a wrong size.
  virtual void restore(const EstimatorState& state) = 0;

  /// Back to x0, P0 (and the initial mode probabilities), step counter 0. Keeps the covariance-only
  /// mode.
  virtual void reset() = 0;

  /// Covariance-only mode (montecarlo --covariance-only): step() then computes P_{k|k} exactly as in
  /// the ordinary mode, by the same code, but not the state, which stays at x0 (state() is not an
  /// estimate then; nor is the Prior's mean). Only which sensors arrived is read from a sample (gamma and the finite or NaN
  /// cells of y, whose values are not used); u and nu are not needed. Offered where P does not depend
  /// on the data: kf, kfio, ack_kf and rseio. Returns whether the estimator has the mode (false: it
  /// stays in the ordinary mode; switching it off always succeeds).
  virtual bool setCovarianceOnly(bool on) { return !on; }

  /// An independent copy in the same state, model and workspace included (the Python module's
  /// copy; rewinding copies snapshot() values instead).
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

/// The most whole periods predictAhead takes a linear model over (k matrix products).
constexpr long kMaxPredictAheadSteps = 1000;

/// An estimate (x, P) predicted `dt` seconds past its step, with no measurement and not fed back
/// into any filter (the Estimator's predict_to_current_time), by kfio's and ekfio's prediction with
/// zero input (predict_ahead.cpp): a built-in motion once over dt (xp = f(x, dt), Pp = F P F' + Q dt, two_d_mode applied);
/// a linear model, whose steps are whole periods of `period` s, k = round(dt / period) times
/// (xp = A^k x, Pp = A Pp A' + B Q B' k times). Returns the time predicted over: dt, or k periods
/// (0: (x, P) as they are). Throws InputError naming dt for a dt that is negative or not finite, a
/// period that is not positive, or a linear k above kMaxPredictAheadSteps.
double predictAhead(const Model& model, double period, const Eigen::VectorXd& x, const Eigen::MatrixXd& P, double dt,
                    Eigen::VectorXd& xp, Eigen::MatrixXd& Pp);

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
