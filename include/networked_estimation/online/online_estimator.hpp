// Online sample assembly for an estimator fed by a stream (the Estimator nodelet's core, ROS-free).
//
// Measurements of each sensor and the known commands arrive one message at a time, possibly lost,
// late, duplicated or out of order. The caller (the nodelet) calls process() once per sample k at
// the deadline of step k; process() takes exactly one filter step with what is in hand:
// gamma_k = 1 iff some sensor's y_k arrived before that call. What arrives for a step already
// processed is either dropped and counted (LatePolicy::DROP) or fused by rewinding a bounded
// history and re-filtering (LatePolicy::REWIND).
//
// With a sensor schedule (model key `schedule`), a sensor is *due* at step k only when it is
// scheduled to transmit there: a periodic schedule is known from k; a random schedule's draw is
// offered per step (offerSchedule, e.g. by whoever draws it). A sensor that is not due is not
// waited for and is not a loss (lastDue()); gamma still means "some y_k arrived".
//
// StepClock maps steps to times: stamp_k = t0 + k * period, deadline_k = stamp_k + latency_budget.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/online/sensor_lattice.hpp"
#include "networked_estimation/online/sensor_sample.hpp"

namespace networked_estimation
{

enum class LatePolicy
{
  DROP,   ///< a measurement for a step already processed is dropped and counted
  REWIND  ///< it is fused: the filter goes back to the step before it and re-filters to now
};

/// "drop" / "rewind"; throws ConfigError naming `source` for anything else.
LatePolicy latePolicyFromString(const std::string& name, const std::string& source);
std::string toString(LatePolicy p);

struct OnlineOptions
{
  LatePolicy late_policy = LatePolicy::DROP;
  /// Steps kept for rewinding (REWIND): a measurement up to this many steps late is still fused.
  std::size_t history_length = 100;
  /// A step this far (or further) ahead of the next step to process is rejected (far future).
  long max_future_steps = 1000;
  /// A step this far (or further) behind the next step is rejected as bad input (far past), not
  /// counted as late. At least history_length.
  long max_past_steps = 1000;
  /// Per sensor (model order; empty = all 1): the model's rate over the sensor's nominal rate,
  /// >= 1. A sensor with a ratio r > 1 is due only at its own steps, every r steps on its own
  /// phase, both learnt from its samples (SensorLattice: jitter and dropouts tolerated). Before its
  /// first sample it is not due.
  std::vector<double> rate_ratio;
  /// Per sensor (empty = none): the largest Mahalanobis distance sqrt(nu' S^-1 nu) of the
  /// sensor's innovation nu = y - C xpred (its angular rows wrapped), S = C Ppred C' + R, that is
  /// still fused (as robot_localization's *_rejection_threshold); +inf = off. xpred, Ppred and S
  /// are the estimator's own prior of the step (Estimator::predict, the Prior): kf/kfio's
  /// A x + Bu u and A P A' + B Q B', ekfio's f and F P F' + Q dt for a built-in motion, rseio's
  /// robust prediction and pseudo-covariance for the sensors in hand, aoe/oe's moments of the
  /// predicted mixture over the command's outcome (docs/algorithms.md 2.8), with the command as
  /// sent. The step then updates that same prediction (one prediction per step). A measurement
  /// beyond it is not fused and counts as not arrived (a loss for the link statistics).
  std::vector<double> rejection_threshold;
  /// Seconds from one step to the next (Sample::dt of every step; 0: the model's period). The
  /// Estimator sets its `period`, which may differ from the model's: a built-in motion then
  /// predicts over the steps' actual spacing (a linear model's A stays per its own period).
  double step_duration = 0.0;
};

/// Validates options (history_length >= 1 for rewind, max_future_steps >= 1, max_past_steps >=
/// history_length, every rate_ratio finite and >= 1, every rejection_threshold > 0). Throws
/// ConfigError naming `source` and the key.
void validateOnlineOptions(const OnlineOptions& o, const std::string& source);

/// What happened to one offered message.
enum class Offer
{
  ACCEPTED,      ///< in hand for a step not processed yet
  LATE_FUSED,    ///< late, fused by rewinding (REWIND)
  LATE_DROPPED,  ///< late: dropped (DROP, or older than the history with REWIND)
  DUPLICATE,     ///< this sensor's (or command's) data for that step was already in hand: ignored
  REJECTED,      ///< bad input (see reason): wrong size, not finite, unknown sensor, step out of range
  DISABLED       ///< the message says it has no estimate of the sensor's fields: not fused, not due
};

struct OfferResult
{
  Offer offer = Offer::ACCEPTED;
  std::string reason;  ///< for REJECTED: what is wrong, naming the field and expected vs found
};

struct OnlineCounters
{
  std::uint64_t processed = 0;  ///< filter steps taken (published estimates)
  std::uint64_t arrivals = 0;   ///< steps processed with gamma_k = 1
  std::uint64_t accepted = 0;   ///< measurements in hand before their deadline
  std::uint64_t late_fused = 0;
  std::uint64_t late_dropped = 0;
  std::uint64_t duplicates = 0;
  std::uint64_t rejected = 0;
  std::uint64_t rewinds = 0;            ///< re-filterings done (one per late-fused message)
  std::uint64_t missing_commands = 0;   ///< steps processed without the command u_k (zero input used)
  std::uint64_t estimates_set = 0;      ///< setEstimate calls that took effect (set_pose)
  std::uint64_t divergence_resets = 0;  ///< the covariance overflowed: the filter was reset to x0, P0
  /// Random schedule: steps processed without their schedule draw in hand (then a sensor counts
  /// as due only when its y_k arrived).
  std::uint64_t schedule_missing = 0;
  /// Measurements of a sensor that was not scheduled at their step (accepted and fused).
  std::uint64_t unscheduled = 0;
  /// Sensor samples due at the processed steps (sum over steps of the sensors due there), and
  /// those of them in hand at the step: their ratio is the arrival rate of what was sent.
  std::uint64_t due = 0, due_arrived = 0;
  /// Measurements refused by their sensor's rejection_threshold (total, and per sensor).
  std::uint64_t gated = 0;
  std::vector<std::uint64_t> gated_per_sensor;
  /// Per sensor: its messages that were not rejected, those dropped as late, and those whose
  /// message disabled the sensor's fields (offerDisabled).
  std::vector<std::uint64_t> received_per_sensor, late_dropped_per_sensor, disabled_per_sensor;
};

class OnlineEstimator
{
public:
  /// Throws ConfigError (bad settings for the model, bad options).
  OnlineEstimator(const Model& model, const EstimatorSettings& settings, const OnlineOptions& options);

  /// Whether start() was called since construction / reset().
  bool started() const { return started_; }
  /// Begins the timeline: the first step to process is `first_step` (>= 1).
  void start(long first_step);
  /// The step the next process() call takes (valid once started).
  long nextStep() const { return next_; }

  /// Offers y_k of sensor s.sensor for step k = s.step (sensor_sample.hpp; s.stamp is not read).
  /// s.size must equal the sensor's rows. s.R: optionally the sensor's own R_k block for this
  /// sample: that step's filter input then has the model's R with this sensor's block replaced and
  /// its cross-blocks with other sensors zero.
  OfferResult offerMeasurement(const SensorSample& s);
  /// The same for a message without a step number, at step position `position` ((stamp - t0) /
  /// period): its step is the one the sensor's lattice gives it (stepOf); s.step and s.stamp are
  /// not read.
  OfferResult offerSample(double position, const SensorSample& s);
  /// The step a sample of `sensor` at step position `position` belongs to (what offerSample uses).
  long stepOf(std::size_t sensor, double position) const;
  /// A message of `sensor` at `position` (or naming step `given` >= 1) that carries no estimate of
  /// the sensor's fields (sensor_msgs' covariance -1): nothing is fused, the sensor is not due at
  /// that step (not a loss), and it is counted (disabled_per_sensor). Returns DISABLED or REJECTED.
  OfferResult offerDisabled(std::size_t sensor, double position, long given = -1);
  /// The sample lattice learnt for a sensor.
  const SensorLattice& lattice(std::size_t sensor) const { return lattice_[sensor]; }
  /// Offers the command u_k, k = c.step (p values; c.stamp is not read). Only meaningful for
  /// models with control.
  OfferResult offerCommand(const CommandSample& c);

  /// Whether u_k is in hand (k not processed yet).
  bool hasCommand(long k) const;

  /// Offers the draw of a random schedule for step k: transmitting[s] for every sensor (model
  /// order); it must be one of the schedule's subsets. Rejected (counted) without a random
  /// schedule, on a wrong size, for a subset the schedule does not have, or out of the window.
  OfferResult offerSchedule(long k, const std::vector<bool>& transmitting);

  /// Whether everything step nextStep() can use is in hand (the y_k of every sensor due at k, the
  /// schedule draw of a random schedule, u_k for a model with control, and the first sample of a
  /// slower sensor whose phase is not known yet): processing it before its deadline gives the
  /// same result.
  bool nextComplete() const;

  /// Takes the filter step nextStep() with what is in hand, then advances nextStep().
  /// Never throws for data problems: a covariance overflow resets the filter (counted).
  void process();

  /// The estimator after the last process() (or after a rewind).
  const Estimator& estimator() const { return *live_; }
  /// gamma of the last processed step (some sensor's y_k was in hand).
  bool lastGamma() const { return last_gamma_; }
  /// Number of sensors whose y_k was in hand at the last processed step.
  int lastSensorsReceived() const { return last_sensors_; }
  /// Per sensor (model order), whether its y_k was in hand at the last processed step.
  const std::vector<bool>& lastArrived() const { return last_arrived_; }
  /// Per sensor, whether it was due (scheduled) at the last processed step; all true without a
  /// schedule.
  const std::vector<bool>& lastDue() const { return last_due_; }
  const OnlineCounters& counters() const { return counters_; }
  /// The last error a filter step raised (empty: none).
  const std::string& lastError() const { return last_error_; }
  const Model& model() const { return model_; }
  const OnlineOptions& options() const { return options_; }

  /// Changes the late policy at runtime. To REWIND: the history starts now (data for steps
  /// already taken before the change is dropped, later ones are fused). To DROP: the history is
  /// forgotten.
  void setLatePolicy(LatePolicy policy);

  /// Everything back to the state after construction (filter at the model's x0, P0, nothing in
  /// hand, not started). Counters are kept (they count since construction).
  void reset();

  /// Starts the filter over from a given estimate (set_pose): x_{k|k} = x and P_{k|k} = P at the
  /// last processed step (before the timeline starts: x_{0|0}, P_{0|0}); the next process()
  /// predicts from them. Data still in hand for later steps is kept; with REWIND the history
  /// starts now (data for steps already taken is then late). Angular entries of x are wrapped.
  /// Throws InputError (the estimate unchanged) for a wrong size, a non-finite entry or a P that
  /// is not symmetric positive semidefinite. Counted (counters().estimates_set).
  void setEstimate(const Eigen::VectorXd& x, const Eigen::MatrixXd& P);

private:
  struct Slot
  {
    long k = -1;             ///< step held in this slot (-1: empty)
    Eigen::VectorXd y;       ///< stacked y, NaN where a sensor has not arrived
    std::vector<char> have;  ///< per sensor
    Eigen::VectorXd u;       ///< empty until the command arrives
    bool have_u = false;
    std::vector<char> scheduled;  ///< random schedule: the draw for this step, per sensor
    bool have_schedule = false;
    std::vector<char> own_R;    ///< per sensor: its R_k block was offered (in R)
    std::vector<char> gated;    ///< per sensor: refused by its rejection_threshold when processed
    std::vector<char> excused;  ///< per sensor: its message disabled its fields (not due here)
    Eigen::MatrixXd R;          ///< m x m, allocated on the first own block
  };

  Slot& slot(long k);
  /// The slot of step k, cleared when it held another step. Null when k is outside the window.
  Slot* slotFor(long k);
  /// The filter input of step k from its slot (a loss when nothing arrived for k).
  void fillSample(long k, Sample& sample) const;
  /// est.step(sample) (est.update(sample) when `predicted`: the gate predicted with it), a
  /// divergence reset and a malformed sample dealt with.
  void stepChecked(Estimator& est, const Sample& sample, bool predicted = false);
  /// REWIND: the checkpoint filter takes the live filter's state (a value copy) at step
  /// nextStep() - 1; `rebuild`: it is built again first (the live one was built from another model).
  void newCheckpoint(bool rebuild);
  void rewind();
  OfferResult checkStep(long k) const;
  /// The rejection thresholds at step k: refuses (in `sample` and the slot) every arrived sensor
  /// whose innovation on the live filter's prior (Estimator::predict) is beyond its threshold.
  /// Returns whether it predicted (the step then only updates: stepChecked).
  bool gate(Slot& s, Sample& sample);
  /// Keeps a sensor's own R_k block in the slot (no-op for R = nullptr).
  void storeR(Slot& s, std::size_t sensor, const double* R);
  /// Whether sensor `sensor` is due at step k (slot `s` holds k, or is null when nothing is in
  /// hand for k).
  bool due(const Slot* s, long k, std::size_t sensor) const;
  /// Counts a rejected offer and returns it with its reason.
  OfferResult reject(const std::string& why);
  /// offerMeasurement / offerSample: `given` >= 1 is the step the message names (s.step is not read).
  OfferResult offerAt(double position, long given, const SensorSample& s);

  Model model_;
  EstimatorSettings settings_;
  OnlineOptions options_;
  std::unique_ptr<Estimator> live_;
  /// REWIND: a filter at step checkpoint_k_, stepped along behind the live one; a rewind copies
  /// its state (a value) into the live filter.
  std::unique_ptr<Estimator> checkpoint_;
  long checkpoint_k_ = 0;
  EstimatorState saved_;       ///< the state copied at a rewind or a new checkpoint (storage reused)
  bool estimate_set_ = false;  ///< live_ was built from a setEstimate (reset() rebuilds it from model_)
  Model set_model_;            ///< estimate_set_: the model live_ was built from (x0, P0 = the estimate)
  std::vector<Slot> ring_;
  long next_ = 1;
  bool started_ = false;
  bool last_gamma_ = false;
  int last_sensors_ = 0;
  std::vector<bool> last_arrived_;
  std::vector<bool> last_due_;
  std::vector<SensorLattice> lattice_;        ///< per sensor: when it samples (options_.rate_ratio, or 1)
  std::vector<std::vector<int>> angle_rows_;  ///< per sensor: its rows that measure an angle (angularRows)
  Sample sample_;
  OnlineCounters counters_;
  std::string last_error_;
};

/// Sample times of a stream: stamp_k = t0 + k period; deadline_k = stamp_k + latency_budget.
class StepClock
{
public:
  StepClock(double period, double latency_budget) : period_(period), budget_(latency_budget) {}
  bool anchored() const { return anchored_; }
  /// Anchors the clock on a sample k stamped t (t0 = t - k period).
  void anchor(long k, double t)
  {
    t0_ = t - static_cast<double>(k) * period_;
    anchored_ = true;
  }
  void clear() { anchored_ = false; }
  double stamp(long k) const { return t0_ + static_cast<double>(k) * period_; }
  double deadline(long k) const { return stamp(k) + budget_; }
  /// The step whose stamp is nearest to t (for message types without a step number).
  long stepAt(double t) const;
  double period() const { return period_; }
  double budget() const { return budget_; }
  /// A new latency budget (runtime change): deadlines of the steps not taken yet move with it.
  void setBudget(double latency_budget) { budget_ = latency_budget; }

private:
  double period_, budget_;
  double t0_ = 0.0;
  bool anchored_ = false;
};

}  // namespace networked_estimation
