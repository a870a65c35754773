// The Estimator nodelet (estimator_nodelet.hpp): the steps: taken by the inputs that complete them
// or at their deadlines, and published after the lock is released (the outbox, the receive thread's
// turn, the sim-time clock watch).
#include "estimator_nodelet.hpp"

namespace networked_estimation
{

void EstimatorNodelet::afterInput()
{
  bool wake = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    wake = armLocked();
  }
  if (wake)
    dispatch_.wake();
  if (inRoscppPollThread())
    poll_pending_ = true;  // inside roscpp's delivery: not here (outbox.hpp), on the thread's next turn
  else
    publishPending();
}

void EstimatorNodelet::pollTurn()
{
  bool publish = poll_pending_.load(std::memory_order_relaxed) && poll_pending_.exchange(false);
  if (clock_watch_.takeReached())
  {
    bool more = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      more = deadlineWorkLocked() == 0.0;
    }
    if (more)  // the work bound: the dispatch thread goes on (it lets the inputs in between)
      dispatch_.wake();
    publish = true;
  }
  if (publish)
    publishPending();
}

bool EstimatorNodelet::armLocked()
{
  const double due = stream_->nextDeadline();
  if (clock_watch_.active())
    return !clock_watch_.arm(due);
  const bool earlier = due < wait_until_;
  wait_until_ = std::min(wait_until_, due);
  return earlier;
}

void EstimatorNodelet::publishPending()
{
  sensor_msgs::NavSatFix::Ptr datum;
  {
    std::lock_guard<std::mutex> lock(datum_mutex_);
    datum.swap(pending_datum_);
  }
  if (datum)
    datum_pub_.publish(datum);
  outbox_.flush();
}

Estimate::Ptr EstimatorNodelet::stepLocked(long k)
{
  const OnlineEstimator& online = stream_->online();
  const Estimator& est = online.estimator();
  Estimate::Ptr e = boost::make_shared<Estimate>();
  e->header.stamp.fromSec(stream_->timeline().clock().stamp(k));
  e->header.frame_id = frame_id_;
  e->step = static_cast<std::uint64_t>(k);
  e->algorithm = toString(settings_.algorithm);
  e->gamma = online.lastGamma();
  const Eigen::VectorXd& x = est.state();
  const Eigen::MatrixXd& P = est.covariance();
  const int n = static_cast<int>(x.size());
  e->state.assign(x.data(), x.data() + n);
  e->covariance.resize(static_cast<std::size_t>(n) * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      e->covariance[static_cast<std::size_t>(i) * n + j] = P(i, j);  // row-major (REP-103)
  e->covariance_trace = P.trace();
  e->covariance_is_pseudo = settings_.algorithm == Algorithm::RSEIO;
  const std::uint64_t resets = online.counters().divergence_resets;
  if (live_)
    live_->add(online.lastArrived(), online.lastDue(), online.lastGamma(), P, resets != resets_seen_);
  resets_seen_ = resets;
  const double q = est.commandArrivalProbability();
  e->command_arrival_probability = std::isfinite(q) ? q : -1.0;
  last_trace_ = e->covariance_trace;
  return e;
}

double EstimatorNodelet::deadlineWork()
{
  double wait = 0.0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    wait = deadlineWorkLocked();
  }
  publishPending();
  return wait;
}

double EstimatorNodelet::deadlineWorkLocked()
{
  wait_until_ = std::numeric_limits<double>::infinity();  // set below when there is a deadline to wait for
  if (!stream_->online().started())
    return 1.0;  // the first message wakes us (afterInput: its deadline is earlier than none)
  // Sim time: the clock's rate over the last half second (a bag at -r 4 runs 4 sim seconds per
  // second), for the stream's catch-up work bound.
  const double now = clock_watch_.now(), wall = ros::WallTime::now().toSec();
  if (ros::Time::isSimTime())
  {
    if (wall_ref_ == 0.0 || now < sim_ref_)  // the first wait, or time went back
    {
      sim_ref_ = now;
      wall_ref_ = wall;
    }
    else if (wall - wall_ref_ >= 0.5)
    {
      const double r = (now - sim_ref_) / (wall - wall_ref_);
      clock_rate_ = r > 1e-3 && r < 1e6 ? r : 1e-3;  // paused: the 50 ms cap
      sim_ref_ = now;
      wall_ref_ = wall;
    }
  }
  // Steps whose deadline has passed (at most 1000 per lock hold, so that the inputs are not
  // starved); time jumps restart the stream.
  if (stream_->deadlines(clocks()))
    return 0.0;
  if (stream_->throttled())
    return 0.005;  // the catch-up work bound: tokens come back at twice the rate ROS time needs
  const double due = stream_->nextDeadline();
  if (!std::isfinite(due))
    return 1.0;  // restarted: the stream's next message wakes us
  // Sim time: the receive thread takes the steps after the /clock tick that reaches the deadline
  // (pollTurn; this thread looks again after at most half a second of wall time). Wall time: sleep until the deadline (a
  // message that completes a step takes it at once, in its callback, and moves the deadline on:
  // no wake-up for it unless the new one is earlier).
  if (clock_watch_.active())
    return clock_watch_.arm(due) ? 0.5 : 0.0;
  wait_until_ = due;
  return std::max(0.0, std::min(due - now, 1.0));
}

}  // namespace networked_estimation
