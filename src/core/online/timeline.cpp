// The Estimator's timeline: stamps checked against ROS time, provisional anchors, restarts and the
// catch-up work bound (timeline.hpp).
#include "networked_estimation/online/timeline.hpp"
#include "io/tokens.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace networked_estimation
{
namespace
{

std::string timelineSeconds(double s)
{
  return tokens::format(s, 10);
}

}  // namespace

Timeline::Timeline(const TimelineOptions& options, double latency_budget)
  : options_(options), clock_(options.period, latency_budget)
{
}

Timeline::Admission Timeline::plausible(double stamp, double now) const
{
  Admission a;
  a.verdict = Verdict::REFUSE;
  if (!(stamp > 0.0))
    a.reason = "stamp " + timelineSeconds(stamp) + ": not a sample time (an unset header stamp?)";
  else if (now > 0.0 && stamp > now + options_.max_ahead)
    a.reason = "stamp " + timelineSeconds(stamp) + " is " + timelineSeconds(stamp - now) + " s ahead of ROS time " +
               timelineSeconds(now) + " (max_stamp_ahead " + timelineSeconds(options_.max_ahead) + " s)";
  else if (now > 0.0 && stamp < now - options_.max_behind)
    a.reason = "stamp " + timelineSeconds(stamp) + " is " + timelineSeconds(now - stamp) + " s behind ROS time " +
               timelineSeconds(now) + " (max_stamp_behind " + timelineSeconds(options_.max_behind) + " s)";
  else
    a.verdict = Verdict::ACCEPT;
  return a;
}

Timeline::Admission Timeline::admit(double stamp, long step, double now)
{
  Admission a = plausible(stamp, now);
  if (a.verdict == Verdict::REFUSE)
    return a;
  return decide(stamp, step, now);
}

Timeline::Admission Timeline::decide(double stamp, long step, double now)
{
  Admission a;
  if (!clock_.anchored())
  {
    a.verdict = Verdict::ANCHOR;
    return a;
  }
  // An anchor ahead of ROS time (taken without a clock: at ROS time 0 under sim time) is not
  // confirmed by anything until ROS time reaches it, and the present contradicts it.
  const bool ahead = !confirmed_ && now > 0.0 && anchor_stamp_ > now + kAhead;
  if (step >= 1)
  {
    const double off = stamp - clock_.stamp(step);
    if (std::fabs(off) <= (ahead ? kAhead : kAgree))
    {
      confirmed_ = confirmed_ || !ahead;
      misfits_ = 0;
      return a;
    }
    const std::string what = "stamp " + timelineSeconds(stamp) + " of step " + std::to_string(step) + " is " +
                             timelineSeconds(off) + " s off that step's time on the timeline";
    if (!confirmed_)
    {
      a.verdict = Verdict::RESTART;
      a.reason = what + ", whose anchor nothing confirmed yet: the timeline restarts on this message";
    }
    else if (++misfits_ >= kMisfitsToRestart)
    {
      a.verdict = Verdict::RESTART;
      a.reason = what + ", the " + std::to_string(misfits_) +
                 "th such message in a row: the stream jumped, the "
                 "timeline restarts on it";
    }
    else
    {
      a.verdict = Verdict::REFUSE;
      a.reason = what;
    }
    return a;
  }
  // Stamp-only: a message well before the anchor contradicts it when nothing confirmed the anchor
  // and it lies ahead of ROS time (without a clock: when no step was taken on it yet).
  const bool before = stamp < anchor_stamp_ - (ahead ? kAhead : kAgree);
  if (before && !confirmed_ && (now > 0.0 ? ahead : !stepped_))
  {
    a.verdict = Verdict::RESTART;
    a.reason = "stamp " + timelineSeconds(stamp) + " is " + timelineSeconds(anchor_stamp_ - stamp) +
               " s before the stamp " + timelineSeconds(anchor_stamp_) +
               " that anchored the timeline ahead of ROS time, and nothing confirmed "
               "that anchor: the timeline restarts on this message";
    return a;
  }
  if (!before && !ahead)
    confirmed_ = true;
  return a;
}

void Timeline::anchor(long k, double stamp)
{
  clock_.anchor(k, stamp);
  first_step_ = k;
  anchor_stamp_ = stamp;
  confirmed_ = stepped_ = false;
  misfits_ = 0;
}

void Timeline::clear()
{
  clock_.clear();
  confirmed_ = stepped_ = false;
  misfits_ = 0;
}

double Timeline::position(double stamp) const
{
  return (stamp - clock_.stamp(0)) / options_.period;
}

bool Timeline::stale(long next, double now) const
{
  return clock_.anchored() && now - clock_.deadline(next) > options_.max_behind;
}

long Timeline::allowance(double wall, double clock_rate)
{
  const double per_second = 2.0 * std::max(1.0, clock_rate) / options_.period;
  const double burst = options_.max_behind / options_.period + per_second;
  if (!bucket_started_)
  {
    tokens_ = burst;
    bucket_started_ = true;
  }
  else
    tokens_ = std::min(burst, tokens_ + std::max(0.0, wall - last_wall_) * per_second);
  last_wall_ = wall;
  return tokens_ >= 1.0 ? static_cast<long>(tokens_) : 0;
}

}  // namespace networked_estimation
