#include "networked_estimation/channel/channel.hpp"
#include "networked_estimation/common/numbers.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/link/channel_trace.hpp"

namespace networked_estimation
{

namespace
{

constexpr double kTwoPi = 6.283185307179586476925286766559;

void requireProbability(double v, const char* key)
{
  if (!(v >= 0.0 && v <= 1.0))
    throw ConfigError(std::string("channel settings: ") + key + ": expected a probability in [0, 1], found " +
                      std::to_string(v));
}

void requireSeconds(double v, const char* key)
{
  if (!(v >= 0.0) || !std::isfinite(v))
    throw ConfigError(std::string("channel settings: ") + key + ": expected a finite number of seconds >= 0, found " +
                      std::to_string(v));
}

}  // namespace

std::string toString(ChannelOutcome outcome)
{
  switch (outcome)
  {
    case ChannelOutcome::DELIVERED:
      return "delivered";
    case ChannelOutcome::DROPPED_MODEL:
      return "dropped_model";
    case ChannelOutcome::DROPPED_QUEUE:
      return "dropped_queue";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Settings

void LossyChannel::validate(const ChannelSettings& s)
{
  if (s.model == LossModelKind::BERNOULLI)
  {
    requireProbability(s.loss, "loss");
  }
  else if (s.model == LossModelKind::TRACE)
  {
    if (!s.replay || s.replay->slots() == 0)
      throw ConfigError("channel settings: trace: no recorded messages to replay (" + s.trace + ")");
  }
  else
  {
    requireProbability(s.p, "p");
    requireProbability(s.r, "r");
    requireProbability(s.loss_bad, "loss_bad");
    requireProbability(s.loss_good, "loss_good");
  }
  requireSeconds(s.delay, "delay");
  requireSeconds(s.jitter, "jitter");
  requireProbability(s.duplicate, "duplicate");
  if (s.queue_limit == 0)
    throw ConfigError("channel settings: queue_limit: expected an integer >= 1, found 0");
}

bool LossyChannel::sameLossModel(const ChannelSettings& a, const ChannelSettings& b)
{
  if (a.model != b.model)
    return false;
  if (a.model == LossModelKind::BERNOULLI)
    return a.loss == b.loss;
  if (a.model == LossModelKind::TRACE)
    return a.replay == b.replay;
  return a.p == b.p && a.r == b.r && a.loss_bad == b.loss_bad && a.loss_good == b.loss_good;
}

LossyChannel::LossyChannel(const ChannelSettings& s) : settings_(s)
{
  validate(s);
  delays_.assign(kDelayWindow, 0.0);
  seedStreams();
}

std::unique_ptr<LossModel> LossyChannel::makeLoss(std::uint64_t seed)
{
  // A trace is replayed from its first slot, whatever the seed.
  trace_ = nullptr;
  if (settings_.model != LossModelKind::TRACE)
    return makeLossModel(settings_, seed);
  auto trace = std::make_unique<TraceLoss>(settings_.replay, 0);
  trace_ = trace.get();
  return trace;
}

void LossyChannel::seedStreams()
{
  loss_ = makeLoss(deriveSeed(settings_.seed, 0));
  loss_generation_ = 0;
  delay_rng_.reseed(deriveSeed(settings_.seed, 1));
  dup_rng_.reseed(deriveSeed(settings_.seed, 2));
}

void LossyChannel::reconfigure(const ChannelSettings& s)
{
  validate(s);
  const ChannelSettings old = settings_;
  settings_ = s;
  if (s.seed != old.seed)
  {
    seedStreams();
  }
  else if (!sameLossModel(s, old))
  {
    ++loss_generation_;
    loss_ = makeLoss(deriveSeed(deriveSeed(s.seed, 0), loss_generation_));
  }
}

// ---------------------------------------------------------------------------------------------
// Offer / deliver

double LossyChannel::drawDelay()
{
  // Always exactly two uniforms, whatever the settings (see the header).
  const double u1 = delay_rng_.uniform();
  const double u2 = delay_rng_.uniform();
  if (settings_.jitter == 0.0)
    return settings_.delay;
  double z = 0.0;
  switch (settings_.distribution)
  {
    case DelayDistribution::UNIFORM:
      z = 2.0 * u1 - 1.0;
      break;
    case DelayDistribution::NORMAL:
      z = std::sqrt(-2.0 * std::log1p(-u1)) * std::cos(kTwoPi * u2);
      break;
    case DelayDistribution::PARETO:
      // 1 - u1 in (0, 1]: X = (1 - u1)^(-1/3) >= 1, at most 2^(53/3).
      z = (std::pow(1.0 - u1, -1.0 / 3.0) - 1.5) / std::sqrt(0.75);
      break;
  }
  return std::max(0.0, settings_.delay + settings_.jitter * z);
}

void LossyChannel::recordDrop()
{
  ++stat_dropped_;
  if (!in_run_)
    ++stat_runs_;
  in_run_ = true;
}

ChannelRecord LossyChannel::offer(std::uint64_t seq, double now)
{
  if (!std::isfinite(now))
    throw InputError("LossyChannel::offer: time: expected a finite number of seconds, found " + std::to_string(now));
  ChannelRecord ev;
  ev.seq = seq;
  ev.arrival = now;

  const std::uint64_t order = offers_++;
  const bool lost = loss_->nextLost();
  ev.state = loss_->state();
  double d = drawDelay();
  bool want_copy = dup_rng_.uniform() < settings_.duplicate;
  if (trace_)  // the recorded delay and copies of this slot (the streams still drawn as always)
  {
    d = trace_->trace().delay[trace_->slot()];
    want_copy = want_copy || trace_->trace().copies[trace_->slot()] > 1;
  }

  ++counters_.received;
  ++stat_offers_;
  if (lost)
  {
    ev.outcome = ChannelOutcome::DROPPED_MODEL;
    ++counters_.dropped_model;
    recordDrop();
    return ev;
  }
  if (counters_.in_flight >= settings_.queue_limit)
  {
    ev.outcome = ChannelOutcome::DROPPED_QUEUE;
    ++counters_.dropped_queue;
    recordDrop();
    return ev;
  }
  in_run_ = false;

  double due = now + d;
  if (!settings_.reorder && !schedule_.empty() && max_due_ > due)
    due = max_due_;
  max_due_ = schedule_.empty() ? due : std::max(max_due_, due);
  ev.outcome = ChannelOutcome::DELIVERED;
  ev.delay = (due == now + d) ? d : due - now;
  ev.sampled_delay = d;

  schedule_.push(Entry{due, order, false, seq});
  ++counters_.in_flight;
  if (want_copy && counters_.in_flight < settings_.queue_limit)
  {
    schedule_.push(Entry{due, order, true, seq});
    ++counters_.in_flight;
    ++counters_.duplicated;
    ev.duplicated = true;
  }

  delays_[delay_next_] = ev.delay;
  delay_next_ = (delay_next_ + 1) % kDelayWindow;
  delay_count_ = std::min(delay_count_ + 1, kDelayWindow);
  return ev;
}

void LossyChannel::pop(std::vector<Delivery>& out)
{
  const Entry& e = schedule_.top();
  out.push_back(Delivery{e.seq, e.duplicate, e.due});
  schedule_.pop();
  --counters_.in_flight;
  ++counters_.delivered;
}

std::size_t LossyChannel::popDue(double now, std::vector<Delivery>& out)
{
  out.clear();
  while (!schedule_.empty() && schedule_.top().due <= now)
    pop(out);
  return out.size();
}

std::size_t LossyChannel::popAll(std::vector<Delivery>& out)
{
  out.clear();
  while (!schedule_.empty())
    pop(out);
  return out.size();
}

double LossyChannel::nextDue() const
{
  return schedule_.empty() ? kInf : schedule_.top().due;
}

// ---------------------------------------------------------------------------------------------
// Statistics

double LossyChannel::lossRate() const
{
  if (stat_offers_ == 0)
    return kNaN;
  return static_cast<double>(stat_dropped_) / static_cast<double>(stat_offers_);
}

double LossyChannel::meanBurstLength() const
{
  if (stat_runs_ == 0)
    return kNaN;
  return static_cast<double>(stat_dropped_) / static_cast<double>(stat_runs_);
}

double LossyChannel::delayQuantile(double q) const
{
  if (!(q >= 0.0 && q <= 1.0))
    throw std::invalid_argument("LossyChannel::delayQuantile: q must be in [0, 1], found " + std::to_string(q));
  const std::size_t n = delay_count_;
  if (n == 0)
    return kNaN;
  // The oldest samples are overwritten in place; order does not matter for a quantile.
  std::vector<double> v(delays_.begin(), delays_.begin() + static_cast<std::ptrdiff_t>(n));
  const double h = static_cast<double>(n - 1) * q;
  const std::size_t lo = static_cast<std::size_t>(std::floor(h));
  const double frac = h - static_cast<double>(lo);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
  const double x_lo = v[lo];
  if (frac == 0.0 || lo + 1 >= n)
    return x_lo;
  // The next order statistic is the smallest element above position lo.
  const double x_hi = *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(lo) + 1, v.end());
  return x_lo + frac * (x_hi - x_lo);
}

void LossyChannel::clearStatistics()
{
  stat_offers_ = 0;
  stat_dropped_ = 0;
  stat_runs_ = 0;
  in_run_ = false;
  delay_next_ = 0;
  delay_count_ = 0;
}

}  // namespace networked_estimation
