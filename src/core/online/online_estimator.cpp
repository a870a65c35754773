// The OnlineEstimator (online_estimator.hpp): its options, construction and reset, and the steps:
// each complete (or due) sample assembled and filtered, late data dropped or rewound. What arrives
// is taken in by online_estimator_inputs.cpp.
#include "networked_estimation/online/online_estimator.hpp"

#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/covariance.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

LatePolicy latePolicyFromString(const std::string& name, const std::string& source)
{
  if (name == "drop")
    return LatePolicy::DROP;
  if (name == "rewind")
    return LatePolicy::REWIND;
  throw ConfigError(source + ": late_policy: expected drop or rewind, found '" + name + "'");
}

std::string toString(LatePolicy p)
{
  return p == LatePolicy::DROP ? "drop" : "rewind";
}

void validateOnlineOptions(const OnlineOptions& o, const std::string& source)
{
  if (o.history_length < 1)
    throw ConfigError(source + ": history_length: expected >= 1, found " + std::to_string(o.history_length));
  if (o.history_length > 100000)
    throw ConfigError(source + ": history_length: expected <= 100000, found " + std::to_string(o.history_length));
  if (o.max_future_steps < 1 || o.max_future_steps > 1000000)
    throw ConfigError(source + ": max_future_steps: expected in [1, 1000000], found " +
                      std::to_string(o.max_future_steps));
  for (std::size_t i = 0; i < o.rejection_threshold.size(); ++i)
    if (!(o.rejection_threshold[i] > 0.0))
      throw ConfigError(source + ": rejection_threshold[" + std::to_string(i) + "]: expected > 0 (+inf: off), found " +
                        std::to_string(o.rejection_threshold[i]));
  if (!(o.step_duration >= 0.0 && o.step_duration <= 3600.0))
    throw ConfigError(source + ": step_duration: expected seconds in [0, 3600] (0: the model's period), found " +
                      std::to_string(o.step_duration));
  for (std::size_t i = 0; i < o.rate_ratio.size(); ++i)
    if (!(o.rate_ratio[i] >= 1.0 && o.rate_ratio[i] <= 1e9))
      throw ConfigError(source + ": rate_ratio[" + std::to_string(i) + "]: expected in [1, 1e9] (a sensor rate at or " +
                        "below the model's), found " + std::to_string(o.rate_ratio[i]));
  if (o.max_past_steps < static_cast<long>(o.history_length) || o.max_past_steps > 1000000)
    throw ConfigError(source + ": max_past_steps: expected in [history_length = " + std::to_string(o.history_length) +
                      ", 1000000], found " + std::to_string(o.max_past_steps));
}

OnlineEstimator::OnlineEstimator(const Model& model, const EstimatorSettings& settings, const OnlineOptions& options)
  : model_(model), settings_(settings), options_(options)
{
  validateOnlineOptions(options_, "online estimator options");
  live_ = makeEstimator(model_, settings_);
  if (options_.late_policy == LatePolicy::REWIND)
    newCheckpoint(false);
  const std::size_t width = options_.history_length + static_cast<std::size_t>(options_.max_future_steps) + 1;
  ring_.resize(width);
  for (Slot& s : ring_)
  {
    s.y = Eigen::VectorXd::Constant(model_.m(), std::numeric_limits<double>::quiet_NaN());
    s.have.assign(model_.sensors.size(), 0);
    s.scheduled.assign(model_.sensors.size(), 0);
    s.own_R.assign(model_.sensors.size(), 0);
    s.gated.assign(model_.sensors.size(), 0);
    s.excused.assign(model_.sensors.size(), 0);
  }
  counters_.gated_per_sensor.assign(model_.sensors.size(), 0);
  counters_.received_per_sensor.assign(model_.sensors.size(), 0);
  counters_.late_dropped_per_sensor.assign(model_.sensors.size(), 0);
  counters_.disabled_per_sensor.assign(model_.sensors.size(), 0);
  if (!options_.rejection_threshold.empty() && options_.rejection_threshold.size() != model_.sensors.size())
    throw ConfigError("online estimator options: rejection_threshold: expected " +
                      std::to_string(model_.sensors.size()) + " values (one per sensor), found " +
                      std::to_string(options_.rejection_threshold.size()));

  sample_.y.resize(model_.m());
  last_arrived_.assign(model_.sensors.size(), false);
  last_due_.assign(model_.sensors.size(), true);
  if (!options_.rate_ratio.empty() && options_.rate_ratio.size() != model_.sensors.size())
    throw ConfigError("online estimator options: rate_ratio: expected " + std::to_string(model_.sensors.size()) +
                      " values (one per sensor), found " + std::to_string(options_.rate_ratio.size()));
  for (std::size_t i = 0; i < model_.sensors.size(); ++i)
    lattice_.emplace_back(options_.rate_ratio.empty() ? 1.0 : options_.rate_ratio[i]);
  angle_rows_.resize(model_.sensors.size());
  for (const int row : angularRows(model_))
    for (std::size_t i = 0; i < model_.sensors.size(); ++i)
      if (row >= model_.sensors[i].offset && row < model_.sensors[i].offset + model_.sensors[i].size)
        angle_rows_[i].push_back(row - model_.sensors[i].offset);
}

void OnlineEstimator::start(long first_step)
{
  if (first_step < 1)
    throw InputError("online estimator: first step must be >= 1, found " + std::to_string(first_step));
  next_ = first_step;
  checkpoint_k_ = first_step - 1;
  started_ = true;
}

void OnlineEstimator::reset()
{
  const bool rebuilt = estimate_set_;
  if (estimate_set_)
  {
    live_ = makeEstimator(model_, settings_);  // back to the model's own x0, P0
    estimate_set_ = false;
  }
  else
    live_->reset();
  next_ = 1;
  checkpoint_k_ = 0;
  if (checkpoint_)
    newCheckpoint(rebuilt);
  for (Slot& s : ring_)
    s.k = -1;
  started_ = false;
  for (SensorLattice& l : lattice_)
    l.reset();
  last_gamma_ = false;
  last_sensors_ = 0;
}

void OnlineEstimator::setEstimate(const Eigen::VectorXd& x, const Eigen::MatrixXd& P)
{
  const long n = model_.n();
  if (x.size() != n || P.rows() != n || P.cols() != n)
    throw InputError("set estimate: expected a state of " + std::to_string(n) + " entries and a " + std::to_string(n) +
                     " x " + std::to_string(n) + " covariance, found " + std::to_string(x.size()) + " and " +
                     std::to_string(P.rows()) + " x " + std::to_string(P.cols()));
  if (!x.allFinite() || !P.allFinite())
    throw InputError("set estimate: the state and covariance must be finite");
  const CovarianceCheck check = checkCovariance(P, Definiteness::SEMIDEFINITE);
  if (check.problem == CovarianceCheck::Problem::NOT_SYMMETRIC)
    throw InputError("set estimate: the covariance is not symmetric");
  if (!check.ok())
    throw InputError("set estimate: the covariance is not positive semidefinite (smallest eigenvalue " +
                     std::to_string(check.smallest) + ")");
  Model from = model_;
  from.x0 = x;
  for (const int a : model_.angles)
    from.x0[a] = wrapAngle(from.x0[a]);
  from.P0 = 0.5 * (P + P.transpose());
  live_ = makeEstimator(from, settings_);
  set_model_ = std::move(from);
  estimate_set_ = true;
  if (checkpoint_)
    newCheckpoint(true);
  ++counters_.estimates_set;
}

void OnlineEstimator::fillSample(long k, Sample& sample) const
{
  const Slot& s = ring_[static_cast<std::size_t>(k) % ring_.size()];
  sample.dt = options_.step_duration;  // the steps' grid: k - 1 to k is one step_duration
  if (s.k != k)                        // nothing arrived for step k
  {
    sample.gamma = false;
    sample.y.setConstant(std::numeric_limits<double>::quiet_NaN());
    sample.u.resize(0);
    sample.R.resize(0, 0);
    return;
  }
  int arrived = 0;
  for (std::size_t i = 0; i < s.have.size(); ++i)
    arrived += s.have[i] && !s.gated[i] ? 1 : 0;
  sample.gamma = arrived > 0;
  sample.y = s.y;
  for (std::size_t i = 0; i < s.gated.size(); ++i)
    if (s.gated[i])  // refused by its rejection threshold when the step was first taken
      sample.y.segment(model_.sensors[i].offset, model_.sensors[i].size)
          .setConstant(std::numeric_limits<double>::quiet_NaN());
  // Own R_k blocks: the model's R with each such sensor's block replaced, its cross-blocks zero.
  bool own = false;
  for (std::size_t i = 0; i < s.own_R.size(); ++i)
    own = own || (s.own_R[i] && s.have[i]);
  if (!own)
    sample.R.resize(0, 0);
  else
  {
    sample.R = model_.R;
    for (std::size_t i = 0; i < s.own_R.size(); ++i)
      if (s.own_R[i] && s.have[i])
      {
        const Sensor& sn = model_.sensors[i];
        sample.R.middleRows(sn.offset, sn.size).setZero();
        sample.R.middleCols(sn.offset, sn.size).setZero();
        sample.R.block(sn.offset, sn.offset, sn.size, sn.size) = s.R.block(sn.offset, sn.offset, sn.size, sn.size);
      }
  }
  if (s.have_u)
    sample.u = s.u;
  else
    sample.u.resize(0);  // zero input
}

void OnlineEstimator::newCheckpoint(bool rebuild)
{
  if (!checkpoint_ || rebuild)  // a filter whose reset() goes where the live one's goes
    checkpoint_ = makeEstimator(estimate_set_ ? set_model_ : model_, settings_);
  live_->snapshot(saved_);
  checkpoint_->restore(saved_);
  checkpoint_k_ = next_ - 1;
}

void OnlineEstimator::stepChecked(Estimator& est, const Sample& sample, bool predicted)
{
  try
  {
    if (predicted)
      est.update(sample);  // the prediction the gate made (process)
    else
      est.step(sample);
  }
  catch (const DivergenceError&)
  {
    // The expected error is unbounded on this link: start over from the prior rather than
    // publish an overflowed covariance.
    ++counters_.divergence_resets;
    est.reset();
  }
  catch (const InputError& e)
  {
    // Cannot happen with offers validated on the way in; if it does, the step is a prediction
    // (counted) rather than an exception escaping into the caller's thread.
    ++counters_.rejected;
    last_error_ = e.what();
    Sample predict = sample;
    predict.gamma = false;
    predict.y.setConstant(std::numeric_limits<double>::quiet_NaN());
    predict.u.resize(0);
    predict.R.resize(0, 0);
    est.step(predict);
  }
}

bool OnlineEstimator::nextComplete() const
{
  if (!started_)
    return false;
  const Slot& s = ring_[static_cast<std::size_t>(next_) % ring_.size()];
  if (s.k != next_ || (model_.hasControl() && !s.have_u))
    return false;
  if (model_.schedule.kind == Schedule::Kind::RANDOM && !s.have_schedule)
    return false;
  for (std::size_t i = 0; i < s.have.size(); ++i)
  {
    if (s.have[i] || s.excused[i])
      continue;
    if (due(&s, next_, i))
      return false;
    // A slower sensor before its first sample: its phase is unknown, any step may be its own, so
    // the step waits for it up to the deadline (without counting it as due there).
    if (lattice_[i].configured() > 1.0 && !lattice_[i].locked())
      return false;
  }
  return true;
}

void OnlineEstimator::process()
{
  if (!started_)
    start(1);
  const long k = next_;
  Slot& s = slot(k);
  fillSample(k, sample_);
  // The gate predicts once with the live filter; the step then updates that prediction.
  const bool predicted = s.k == k && !options_.rejection_threshold.empty() && gate(s, sample_);
  last_sensors_ = 0;
  const Slot* held = s.k == k ? &s : nullptr;
  for (std::size_t i = 0; i < last_arrived_.size(); ++i)
  {
    last_arrived_[i] = held && held->have[i] && !held->gated[i];
    last_sensors_ += last_arrived_[i] ? 1 : 0;
    last_due_[i] = due(held, k, i);
    counters_.due += last_due_[i] ? 1 : 0;
    counters_.due_arrived += last_due_[i] && last_arrived_[i] ? 1 : 0;
  }
  if (model_.schedule.kind == Schedule::Kind::RANDOM && !(held && held->have_schedule))
    ++counters_.schedule_missing;
  if (!(s.k == k && s.have_u))
  {
    if (model_.hasControl())
      ++counters_.missing_commands;
  }
  // DROP keeps late data out of the filter: a late measurement may sit in the slot for duplicate
  // detection, but only data accepted before this deadline is used.
  stepChecked(*live_, sample_, predicted);
  last_gamma_ = sample_.gamma;
  ++counters_.processed;
  if (last_gamma_)
    ++counters_.arrivals;
  ++next_;
  if (options_.late_policy == LatePolicy::REWIND)
  {
    const long H = static_cast<long>(options_.history_length);
    while (next_ - 1 - checkpoint_k_ > H)
    {
      const long j = checkpoint_k_ + 1;
      fillSample(j, sample_);
      stepChecked(*checkpoint_, sample_);
      checkpoint_k_ = j;
    }
  }
}

void OnlineEstimator::setLatePolicy(LatePolicy policy)
{
  if (policy == options_.late_policy)
    return;
  options_.late_policy = policy;
  if (policy == LatePolicy::REWIND)
    newCheckpoint(false);
  else
    checkpoint_.reset();
}

bool OnlineEstimator::gate(Slot& s, Sample& sample)
{
  const Prior* prior = nullptr;
  for (std::size_t i = 0; i < model_.sensors.size(); ++i)
  {
    const double threshold = options_.rejection_threshold[i];
    if (!s.have[i] || s.gated[i] || !std::isfinite(threshold))
      continue;
    if (!prior)
    {
      try
      {
        prior = &live_->predict(sample);  // the filter's own prior of this step
      }
      catch (const std::runtime_error&)
      {
        // InputError or DivergenceError: nothing is gated; the step raises it again and
        // stepChecked deals with it as without a threshold.
        break;
      }
    }
    const Sensor& sn = model_.sensors[i];
    const auto C = model_.C.middleRows(sn.offset, sn.size);
    Eigen::VectorXd nu = sample.y.segment(sn.offset, sn.size) - C * prior->mean();
    wrapEntries(nu, angle_rows_[i]);  // the sensor's angular rows (docs/algorithms.md 2.7)
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(prior->innovationCovariance(i));
    const double d2 = nu.dot(ldlt.solve(nu));
    if (!(d2 <= threshold * threshold))  // beyond it, or not computable (S singular, overflow)
    {
      s.gated[i] = 1;
      ++counters_.gated;
      ++counters_.gated_per_sensor[i];
      sample.y.segment(sn.offset, sn.size).setConstant(std::numeric_limits<double>::quiet_NaN());
    }
  }
  bool any = false;
  for (std::size_t i = 0; i < s.have.size(); ++i)
    any = any || (s.have[i] && !s.gated[i]);
  sample.gamma = any;
  return prior != nullptr;
}

void OnlineEstimator::rewind()
{
  ++counters_.rewinds;
  checkpoint_->snapshot(saved_);  // the checkpoint's state, a value: the filter itself stays
  live_->restore(saved_);
  for (long j = checkpoint_k_ + 1; j < next_; ++j)
  {
    fillSample(j, sample_);
    stepChecked(*live_, sample_);
  }
}

long StepClock::stepAt(double t) const
{
  return static_cast<long>(std::llround((t - t0_) / period_));
}

}  // namespace networked_estimation
