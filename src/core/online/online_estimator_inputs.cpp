// The OnlineEstimator's inputs (online_estimator.hpp): each measurement, command and schedule
// offered, checked, and stored in its step's slot until the step is filtered
// (online_estimator.cpp).
#include "networked_estimation/online/online_estimator.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

OnlineEstimator::Slot& OnlineEstimator::slot(long k)
{
  return ring_[static_cast<std::size_t>(k) % ring_.size()];
}

OnlineEstimator::Slot* OnlineEstimator::slotFor(long k)
{
  Slot& s = slot(k);
  if (s.k != k)
  {
    s.k = k;
    s.y.setConstant(std::numeric_limits<double>::quiet_NaN());
    std::fill(s.have.begin(), s.have.end(), 0);
    std::fill(s.own_R.begin(), s.own_R.end(), 0);
    std::fill(s.gated.begin(), s.gated.end(), 0);
    std::fill(s.excused.begin(), s.excused.end(), 0);
    s.have_u = false;
    s.have_schedule = false;
  }
  return &s;
}

bool OnlineEstimator::due(const Slot* s, long k, std::size_t sensor) const
{
  if (s && s->k == k && s->excused[sensor])
    return false;  // its message said it has no estimate
  if (!lattice_[sensor].due(k))
    return false;
  const Schedule& sch = model_.schedule;
  switch (sch.kind)
  {
    case Schedule::Kind::NONE:
      return true;
    case Schedule::Kind::PERIODIC:
      return sch.pattern[static_cast<std::size_t>((k - 1) % static_cast<long>(sch.pattern.size()))][sensor];
    case Schedule::Kind::RANDOM:
      if (s && s->have_schedule)
        return s->scheduled[sensor] != 0;
      return s && s->have[sensor];  // the draw is not in hand: what arrived was evidently scheduled
  }
  return true;
}

OfferResult OnlineEstimator::checkStep(long k) const
{
  OfferResult r;
  if (!started_)
  {
    r.offer = Offer::REJECTED;
    r.reason = "the timeline has not started";
  }
  else if (k < 1)
  {
    r.offer = Offer::REJECTED;
    r.reason = "step: expected >= 1, found " + std::to_string(k);
  }
  else if (k >= next_ + options_.max_future_steps)
  {
    r.offer = Offer::REJECTED;
    r.reason = "step " + std::to_string(k) + " is from the far future: the next step to process is " +
               std::to_string(next_) + " (max_future_steps " + std::to_string(options_.max_future_steps) + ")";
  }
  else if (k <= next_ - options_.max_past_steps)
  {
    r.offer = Offer::REJECTED;
    r.reason = "step " + std::to_string(k) + " is from the far past: the next step to process is " +
               std::to_string(next_) + " (max_past_steps " + std::to_string(options_.max_past_steps) + ")";
  }
  return r;
}

OfferResult OnlineEstimator::reject(const std::string& why)
{
  ++counters_.rejected;
  OfferResult r;
  r.offer = Offer::REJECTED;
  r.reason = why;
  return r;
}

void OnlineEstimator::storeR(Slot& s, std::size_t sensor, const double* R)
{
  if (!R)
    return;
  const Sensor& sn = model_.sensors[sensor];
  if (s.R.rows() != model_.m())
    s.R.resize(model_.m(), model_.m());
  s.R.block(sn.offset, sn.offset, sn.size, sn.size) =
      Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(R, sn.size, sn.size);
  s.own_R[sensor] = 1;
}

OfferResult OnlineEstimator::offerMeasurement(const SensorSample& s)
{
  return offerAt(static_cast<double>(s.step), s.step, s);
}

OfferResult OnlineEstimator::offerSample(double position, const SensorSample& s)
{
  return offerAt(position, -1, s);
}

long OnlineEstimator::stepOf(std::size_t sensor, double position) const
{
  return lattice_.at(sensor).fit(position).step;
}

OfferResult OnlineEstimator::offerDisabled(std::size_t sensor, double position, long given)
{
  if (sensor >= model_.sensors.size())
    return reject("sensor index " + std::to_string(sensor) + " out of range (model has " +
                  std::to_string(model_.sensors.size()) + " sensors)");
  if (!std::isfinite(position))
    return reject("the step position of sensor '" + model_.sensors[sensor].name + "' is not finite");
  const SensorLattice::Fit f = lattice_[sensor].fit(position, given);
  OfferResult r = checkStep(f.step);
  if (r.offer == Offer::REJECTED)
    return reject(r.reason);
  lattice_[sensor].learn(position, f);
  ++counters_.received_per_sensor[sensor];
  ++counters_.disabled_per_sensor[sensor];
  if (f.step >= next_)
    slotFor(f.step)->excused[sensor] = 1;
  r.offer = Offer::DISABLED;
  return r;
}

OfferResult OnlineEstimator::offerAt(double position, long given, const SensorSample& sample)
{
  const std::size_t sensor = sample.sensor, size = sample.size;
  const double* y = sample.y;
  OfferResult r;
  if (sensor >= model_.sensors.size())
    return reject("sensor index " + std::to_string(sensor) + " out of range (model has " +
                  std::to_string(model_.sensors.size()) + " sensors)");
  const Sensor& sn = model_.sensors[sensor];
  if (size != static_cast<std::size_t>(sn.size))
    return reject("y: sensor '" + sn.name + "' expects " + std::to_string(sn.size) + " values, found " +
                  std::to_string(size));
  for (std::size_t i = 0; i < size; ++i)
    if (!std::isfinite(y[i]))
      return reject("y[" + std::to_string(i) + "] of sensor '" + sn.name + "' is not finite");
  if (!std::isfinite(position))
    return reject("the step position of sensor '" + sn.name + "' is not finite");
  const SensorLattice::Fit f = lattice_[sensor].fit(position, given);
  const long k = f.step;
  r = checkStep(k);
  if (r.offer == Offer::REJECTED)
    return reject(r.reason);
  lattice_[sensor].learn(position, f);
  ++counters_.received_per_sensor[sensor];
  if (k < next_)
  {
    const bool rewindable = options_.late_policy == LatePolicy::REWIND && k > checkpoint_k_;
    Slot& s = slot(k);
    if (s.k == k && s.have[sensor])
    {
      ++counters_.duplicates;
      r.offer = Offer::DUPLICATE;
      return r;
    }
    if (!rewindable)
    {
      ++counters_.late_dropped;
      ++counters_.late_dropped_per_sensor[sensor];
      r.offer = Offer::LATE_DROPPED;
      // Remember it for duplicate detection while its step is still held (never claim a slot:
      // it may belong to a future step by now).
      if (s.k == k)
        s.have[sensor] = 1;
      return r;
    }
    Slot* d = slotFor(k);
    d->have[sensor] = 1;
    d->y.segment(sn.offset, sn.size) = Eigen::Map<const Eigen::VectorXd>(y, sn.size);
    storeR(*d, sensor, sample.R);
    ++counters_.late_fused;
    rewind();
    r.offer = Offer::LATE_FUSED;
    return r;
  }
  Slot* s = slotFor(k);
  if (s->have[sensor])
  {
    ++counters_.duplicates;
    r.offer = Offer::DUPLICATE;
    return r;
  }
  s->have[sensor] = 1;
  s->y.segment(sn.offset, sn.size) = Eigen::Map<const Eigen::VectorXd>(y, sn.size);
  storeR(*s, sensor, sample.R);
  ++counters_.accepted;
  if (model_.schedule.active() && !due(s, k, sensor))
    ++counters_.unscheduled;
  r.offer = Offer::ACCEPTED;
  return r;
}

OfferResult OnlineEstimator::offerCommand(const CommandSample& c)
{
  const long k = c.step;
  const std::size_t size = c.size;
  const double* u = c.u;
  OfferResult r;
  if (!model_.hasControl())
    return reject("command: model '" + model_.name + "' has no control input");
  if (size != static_cast<std::size_t>(model_.p()))
    return reject("u: expected " + std::to_string(model_.p()) + " values, found " + std::to_string(size));
  for (std::size_t i = 0; i < size; ++i)
    if (!std::isfinite(u[i]))
      return reject("u[" + std::to_string(i) + "] is not finite");
  r = checkStep(k);
  if (r.offer == Offer::REJECTED)
    return reject(r.reason);
  Slot& existing = slot(k);
  if (existing.k == k && existing.have_u)
  {
    ++counters_.duplicates;
    r.offer = Offer::DUPLICATE;
    return r;
  }
  const bool late = k < next_;
  if (late && !(options_.late_policy == LatePolicy::REWIND && k > checkpoint_k_))
  {
    ++counters_.late_dropped;
    r.offer = Offer::LATE_DROPPED;
    return r;
  }
  Slot* s = slotFor(k);
  s->u = Eigen::Map<const Eigen::VectorXd>(u, static_cast<Eigen::Index>(size));
  s->have_u = true;
  if (late)
  {
    ++counters_.late_fused;
    rewind();
    r.offer = Offer::LATE_FUSED;
  }
  return r;
}

bool OnlineEstimator::hasCommand(long k) const
{
  const Slot& s = ring_[static_cast<std::size_t>(k) % ring_.size()];
  return k >= next_ && s.k == k && s.have_u;
}

OfferResult OnlineEstimator::offerSchedule(long k, const std::vector<bool>& transmitting)
{
  const Schedule& sch = model_.schedule;
  if (sch.kind != Schedule::Kind::RANDOM)
    return reject("schedule: model '" + model_.name + "' has no random schedule (" +
                  (sch.kind == Schedule::Kind::PERIODIC ? "its periodic one is known from the step" : "none") + ")");
  if (transmitting.size() != model_.sensors.size())
    return reject("schedule: expected " + std::to_string(model_.sensors.size()) + " flags (one per sensor), found " +
                  std::to_string(transmitting.size()));
  bool known = false;
  for (const std::vector<bool>& subset : sch.subsets)
    known = known || subset == transmitting;
  if (!known)
  {
    std::string names;
    for (std::size_t i = 0; i < transmitting.size(); ++i)
      if (transmitting[i])
        names += (names.empty() ? "" : ", ") + model_.sensors[i].name;
    return reject("schedule: [" + names + "] is not one of the schedule's subsets");
  }
  OfferResult r = checkStep(k);
  if (r.offer == Offer::REJECTED)
    return reject(r.reason);
  if (k < next_)
  {
    // The step is processed: its draw no longer changes anything the filter did.
    ++counters_.late_dropped;
    r.offer = Offer::LATE_DROPPED;
    return r;
  }
  Slot* s = slotFor(k);
  if (s->have_schedule)
  {
    ++counters_.duplicates;
    r.offer = Offer::DUPLICATE;
    return r;
  }
  for (std::size_t i = 0; i < transmitting.size(); ++i)
    s->scheduled[i] = transmitting[i] ? 1 : 0;
  s->have_schedule = true;
  for (std::size_t i = 0; i < transmitting.size(); ++i)
    if (s->have[i] && !transmitting[i])
      ++counters_.unscheduled;
  return r;
}

}  // namespace networked_estimation
