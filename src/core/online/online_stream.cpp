// The Estimator's input side: timeline, latency budget and sample assembly (online_stream.hpp).
#include "networked_estimation/online/online_stream.hpp"
#include "io/tokens.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace networked_estimation
{
namespace
{

constexpr long kStepsPerCall = 1000;  ///< steps taken per call at most (the inputs are not starved)

std::string streamSeconds(double s)
{
  return tokens::format(s, 6);
}

}  // namespace

OnlineStream::OnlineStream(const Model& model, const EstimatorSettings& settings, const OnlineOptions& online,
                           const TimelineOptions& timeline, const RuntimeSettings& runtime)
  : online_(std::make_unique<OnlineEstimator>(model, settings, online)),
    timeline_(timeline, 0.0),
    latency_(model.sensors.size(), latencyOptions(runtime, timeline.period)),
    runtime_(runtime)
{
  timeline_.clock().setBudget(latency_.budget());
  refused_.assign(model.sensors.size(), 0);
  last_refused_.resize(model.sensors.size());
}

bool OnlineStream::admit(std::size_t sensor, double stamp, long step, const Clocks& now, OfferResult& refusal)
{
  const bool provisional = timeline_.anchored() && !timeline_.confirmed();
  const double poisoned = timeline_.anchorStamp();
  const Timeline::Admission a = timeline_.admit(stamp, step, now.ros);
  std::string why = a.reason;
  if (a.verdict == Timeline::Verdict::ACCEPT)
    return true;
  if (a.verdict != Timeline::Verdict::REFUSE && step == 0)
    why = "step: expected >= 1, found 0";  // cannot anchor
  else if (a.verdict != Timeline::Verdict::REFUSE)
  {
    if (a.verdict == Timeline::Verdict::RESTART)
    {
      ++restarts_;
      last_restart_ = {why, now.wall};
      if (provisional)  // the message that anchored it was poisoned: counted as refused, after the fact
        refuse(anchor_sensor_,
               "stamp " + tokens::format(poisoned, 10) +
                   " anchored the timeline, and a later message "
                   "contradicted it (" +
                   why + ")",
               now);
      restart(why);
    }
    anchor_sensor_ = sensor;
    const long k = step >= 1 ? step : 1;
    timeline_.anchor(k, stamp);
    latency_.start(now.ros);
    // A stream seen from its start is filtered from step 1 (the steps before the first message
    // are losses); joining a running stream starts at the first step seen.
    online_->start(k - 1 <= static_cast<long>(online_->options().history_length) ? 1 : k);
    return true;
  }
  refuse(sensor, why, now);
  refusal.offer = Offer::REJECTED;
  refusal.reason = why;
  return false;
}

void OnlineStream::refuse(std::size_t sensor, const std::string& why, const Clocks& now)
{
  if (sensor < refused_.size())
  {
    ++refused_[sensor];
    last_refused_[sensor] = {why, now.wall};
    latency_.refused(sensor, now.ros);
  }
  else
  {
    ++refused_other_;
    last_refused_other_ = {why, now.wall};
  }
}

void OnlineStream::restart(const std::string& why)
{
  online_->reset();
  timeline_.clear();
  latency_.clear();
  timeline_.clock().setBudget(latency_.budget());
  last_now_ = -std::numeric_limits<double>::infinity();
  if (on_restart)
    on_restart(why);
}

long OnlineStream::place(std::size_t sensor, double stamp, long step, const Clocks& now, double& position)
{
  position = step >= 1 ? static_cast<double>(step) : timeline_.position(stamp);
  const long k = step >= 1 ? step : online_->stepOf(sensor, position);
  const double grid = timeline_.clock().stamp(k);
  if (step < 1)
  {
    const double off = std::fabs(stamp - grid);
    offset_sum_ += off;
    offset_max_ = std::max(offset_max_, off);
    ++offset_count_;
  }
  if (now.ros > 0.0)
  {
    latency_.at(now.ros);
    latency_.arrived(sensor, now.ros - grid, now.ros);
    timeline_.clock().setBudget(latency_.budget());
  }
  return k;
}

bool OnlineStream::arrive(std::size_t sensor, double stamp, long step, const Clocks& now, OfferResult& r,
                          double& position)
{
  if (sensor >= refused_.size())
  {
    r.offer = Offer::REJECTED;
    r.reason = "sensor index " + std::to_string(sensor) + " out of range";
    return false;
  }
  if (!admit(sensor, stamp, step, now, r))
    return false;
  place(sensor, stamp, step, now, position);
  // Steps whose deadline has passed are taken first (their wait may not have timed out yet): what
  // arrives after a deadline is late, exactly, whichever callback notices first.
  catchUp(now);
  return true;
}

OfferResult OnlineStream::measurement(const SensorSample& s, const Clocks& now)
{
  OfferResult r;
  double position = 0.0;
  if (!arrive(s.sensor, s.stamp, s.step, now, r, position))
    return r;
  r = s.step >= 1 ? online_->offerMeasurement(s) : online_->offerSample(position, s);
  if (r.offer == Offer::LATE_DROPPED)
    latency_.lost(s.sensor, now.ros);
  drainComplete(now);
  return r;
}

OfferResult OnlineStream::disabled(std::size_t sensor, double stamp, long step, const Clocks& now)
{
  OfferResult r;
  double position = 0.0;
  if (!arrive(sensor, stamp, step, now, r, position))
    return r;
  r = online_->offerDisabled(sensor, position, step >= 1 ? step : -1);
  drainComplete(now);
  return r;
}

bool OnlineStream::admitCommand(double stamp, const Clocks& now, OfferResult& r)
{
  const Timeline::Admission a = timeline_.plausible(stamp, now.ros);
  if (a.verdict != Timeline::Verdict::REFUSE)
    return true;
  ++refused_other_;
  r.offer = Offer::REJECTED;
  r.reason = "command: " + a.reason;
  last_refused_other_ = {r.reason, now.wall};
  return false;
}

OfferResult OnlineStream::command(const CommandSample& c, const Clocks& now)
{
  OfferResult r;
  if (!online_->started())
    return r;  // the timeline starts with the measurements
  if (!admitCommand(c.stamp, now, r))
    return r;
  catchUp(now);
  r = online_->offerCommand(c);
  drainComplete(now);
  return r;
}

OfferResult OnlineStream::heldCommand(const CommandSample& c, const Clocks& now)
{
  OfferResult r;
  if (!admitCommand(c.stamp, now, r))
    return r;
  if (held_.size() >= 1000)
    held_.erase(held_.begin());
  held_[c.stamp].assign(c.u, c.u + c.size);  // kept before the timeline starts, too
  if (!online_->started())
    return r;
  catchUp(now);
  r = online_->offerCommand({timeline_.clock().stepAt(c.stamp), c.u, c.size});
  drainComplete(now);
  return r;
}

void OnlineStream::offerHeld(long k)
{
  auto latest = held_.end();
  for (auto it = held_.begin(); it != held_.end() && timeline_.clock().stepAt(it->first) <= k; ++it)
    latest = it;
  if (latest == held_.end())
    return;
  held_.erase(held_.begin(), latest);
  if (!online_->hasCommand(k))
    online_->offerCommand({k, latest->second.data(), latest->second.size()});
}

OfferResult OnlineStream::schedule(long step, double stamp, const std::vector<bool>& transmitting, const Clocks& now)
{
  OfferResult r;
  // The draw of a step leaves before its measurements: it may start the timeline.
  if (!admit(refused_.size(), stamp, step, now, r))
    return r;
  catchUp(now);
  r = online_->offerSchedule(step, transmitting);
  drainComplete(now);
  return r;
}

void OnlineStream::step()
{
  const long k = online_->nextStep();
  if (!held_.empty())
    offerHeld(k);  // zero-order hold
  online_->process();
  timeline_.stepped();
  if (after_step)
    after_step(k);
}

void OnlineStream::drainComplete(const Clocks& now)
{
  // A step whose data is all in hand is taken at once, but not before ROS time reaches its stamp
  // minus Timeline::kAhead: no estimate is stamped further ahead of ROS time (deadlines() takes it
  // then; nextDeadline() says when).
  while (online_->started() && online_->nextComplete() && !(now.ros < gate(online_->nextStep())))
    step();
}

double OnlineStream::gate(long k) const
{
  return timeline_.clock().stamp(k) - Timeline::kAhead;
}

void OnlineStream::catchUp(const Clocks& now)
{
  if (!online_->started() || now.ros < nextDeadline())
    return;
  const long allowed = std::min(kStepsPerCall, timeline_.allowance(now.wall, now.rate));
  long taken = 0;
  while (online_->started() && now.ros >= nextDeadline())
  {
    if (taken >= allowed)
    {
      throttled_ = true;
      break;
    }
    step();
    ++taken;
    drainComplete(now);
  }
  timeline_.spend(taken);
}

bool OnlineStream::wentBack(const Clocks& now)
{
  const double period = timeline_.options().period;
  if (now.ros > 0.0 && now.ros < last_now_ - 0.5 * period)
  {
    // The clock went back (a bag looped, a simulator restarted): start over cleanly.
    const double back = last_now_ - now.ros;
    ++time_resets_;
    restart("time jumped back by " + streamSeconds(back) + " s: estimator reset, waiting for the stream to restart");
    return true;
  }
  last_now_ = now.ros;
  return false;
}

void OnlineStream::observe(const Clocks& now)
{
  if (online_->started())
    wentBack(now);
}

bool OnlineStream::deadlines(const Clocks& now)
{
  throttled_ = false;
  if (!online_->started() || wentBack(now))
    return false;
  latency_.at(now.ros);
  timeline_.clock().setBudget(latency_.budget());
  if (timeline_.stale(online_->nextStep(), now.ros))
  {
    const double behind = now.ros - timeline_.clock().deadline(online_->nextStep());
    ++time_resets_;
    restart("ROS time is " + streamSeconds(behind) + " s past the next step's deadline, more than max_stamp_behind " +
            streamSeconds(timeline_.options().max_behind) +
            " s (time jumped forward, or the estimator stalled): "
            "estimator reset, waiting for the stream to restart");
    return false;
  }
  catchUp(now);
  return !throttled_ && online_->started() && now.ros >= nextDeadline();
}

double OnlineStream::nextDeadline() const
{
  if (!online_->started())
    return std::numeric_limits<double>::infinity();
  const long k = online_->nextStep();
  const double deadline = timeline_.clock().deadline(k);
  return online_->nextComplete() ? std::min(deadline, gate(k)) : deadline;
}

std::vector<std::string> OnlineStream::stampWarnings(double wall) const
{
  std::vector<std::string> out;
  auto recent = [&](const Event& e) { return !e.reason.empty() && wall - e.wall <= kRecentSeconds; };
  auto ago = [&](const Event& e) { return tokens::format(std::max(0.0, wall - e.wall), 2) + " s ago: " + e.reason; };
  auto count = [](std::uint64_t n)
  { return std::to_string(n) + (n == 1 ? " message refused for its stamp" : " messages refused for their stamp"); };
  for (std::size_t i = 0; i < refused_.size(); ++i)
    if (recent(last_refused_[i]))
      out.push_back("sensor '" + online_->model().sensors[i].name + "': " + count(refused_[i]) + ", the last " +
                    ago(last_refused_[i]));
  if (recent(last_refused_other_))
    out.push_back("commands and schedules: " + count(refused_other_) + ", the last " + ago(last_refused_other_));
  if (recent(last_restart_))
    out.push_back("timeline restarted " + ago(last_restart_));
  return out;
}

void OnlineStream::setRuntime(const RuntimeSettings& runtime)
{
  runtime_ = runtime;
  latency_.setOptions(latencyOptions(runtime, timeline_.options().period));
  timeline_.clock().setBudget(latency_.budget());
  online_->setLatePolicy(latePolicyFromString(runtime.late_policy, "runtime settings"));
}

}  // namespace networked_estimation
