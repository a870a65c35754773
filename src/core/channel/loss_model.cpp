#include "networked_estimation/channel/loss_model.hpp"

#include <algorithm>
#include <limits>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/link/channel_trace.hpp"

namespace networked_estimation
{

namespace
{

/// Mean length of a loss run from the long-run loss rate and the long-run rate of
/// "received at k, lost at k+1" transitions (one such transition starts every run).
double meanBurstLength(double loss_rate, double run_start_rate)
{
  if (loss_rate <= 0.0)
    return std::numeric_limits<double>::quiet_NaN();
  if (run_start_rate <= 0.0)
    return std::numeric_limits<double>::infinity();
  return loss_rate / run_start_rate;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// BernoulliLoss

BernoulliLoss::BernoulliLoss(double loss, std::uint64_t seed) : loss_(loss), rng_(seed) {}

bool BernoulliLoss::nextLost()
{
  return rng_.bernoulli(loss_);
}

double BernoulliLoss::stationaryLossRate() const
{
  return loss_;
}

double BernoulliLoss::stationaryMeanBurstLength() const
{
  return meanBurstLength(loss_, (1.0 - loss_) * loss_);
}

void BernoulliLoss::reseed(std::uint64_t seed)
{
  rng_.reseed(seed);
}

// ---------------------------------------------------------------------------------------------
// GilbertElliottLoss

GilbertElliottLoss::GilbertElliottLoss(double p, double r, double loss_bad, double loss_good, std::uint64_t seed)
  : p_(p), r_(r), loss_bad_(loss_bad), loss_good_(loss_good), rng_(seed)
{
}

bool GilbertElliottLoss::nextLost()
{
  // Fixed order of draws from the one generator: [initial state | transition], then the loss.
  if (!started_)
  {
    bad_ = rng_.uniform() < stationaryBadProbability();
    started_ = true;
  }
  else if (bad_)
  {
    bad_ = !rng_.bernoulli(r_);
  }
  else
  {
    bad_ = rng_.bernoulli(p_);
  }
  return rng_.bernoulli(bad_ ? loss_bad_ : loss_good_);
}

double GilbertElliottLoss::stationaryBadProbability() const
{
  const double sum = p_ + r_;
  return sum > 0.0 ? p_ / sum : 0.0;
}

double GilbertElliottLoss::stationaryLossRate() const
{
  const double pi_bad = stationaryBadProbability();
  return pi_bad * loss_bad_ + (1.0 - pi_bad) * loss_good_;
}

double GilbertElliottLoss::stationaryMeanBurstLength() const
{
  const double pi[2] = {1.0 - stationaryBadProbability(), stationaryBadProbability()};
  const double lost[2] = {loss_good_, loss_bad_};
  const double T[2][2] = {{1.0 - p_, p_}, {r_, 1.0 - r_}};  // T[s][s'] = P(s -> s')
  double run_start = 0.0;                                   // P(received at k, lost at k+1) in the stationary law
  for (int s = 0; s < 2; ++s)
    for (int t = 0; t < 2; ++t)
      run_start += pi[s] * (1.0 - lost[s]) * T[s][t] * lost[t];
  return meanBurstLength(stationaryLossRate(), run_start);
}

void GilbertElliottLoss::reseed(std::uint64_t seed)
{
  rng_.reseed(seed);
  bad_ = false;
  started_ = false;
}

// ---------------------------------------------------------------------------------------------
// TraceLoss

TraceLoss::TraceLoss(std::shared_ptr<const ChannelTrace> trace, std::size_t start) : trace_(std::move(trace))
{
  if (!trace_ || trace_->slots() == 0)
    throw ConfigError("channel settings: trace: no recorded messages to replay");
  next_ = start % trace_->slots();
}

bool TraceLoss::nextLost()
{
  slot_ = next_;
  next_ = next_ + 1 == trace_->slots() ? 0 : next_ + 1;
  return trace_->arrived[slot_] == 0;
}

double TraceLoss::stationaryLossRate() const
{
  const std::size_t n = trace_->slots();
  return static_cast<double>(n - static_cast<std::size_t>(
                                     std::count(trace_->arrived.begin(), trace_->arrived.end(), std::uint8_t(1)))) /
         static_cast<double>(n);
}

double TraceLoss::stationaryMeanBurstLength() const
{
  // The trace repeats: its runs of losses, counting one that wraps around once.
  const std::vector<std::uint8_t>& a = trace_->arrived;
  std::size_t lost = 0, starts = 0;
  for (std::size_t k = 0; k < a.size(); ++k)
  {
    lost += a[k] ? 0 : 1;
    starts += (!a[k] && a[k == 0 ? a.size() - 1 : k - 1]) ? 1 : 0;
  }
  return meanBurstLength(static_cast<double>(lost) / static_cast<double>(a.size()),
                         static_cast<double>(starts) / static_cast<double>(a.size()));
}

void TraceLoss::reseed(std::uint64_t seed)
{
  next_ = static_cast<std::size_t>(seed % trace_->slots());
}

// ---------------------------------------------------------------------------------------------

std::unique_ptr<LossModel> makeLossModel(const ChannelSettings& settings, std::uint64_t seed)
{
  switch (settings.model)
  {
    case LossModelKind::GILBERT_ELLIOTT:
      return std::make_unique<GilbertElliottLoss>(settings.p, settings.r, settings.loss_bad, settings.loss_good, seed);
    case LossModelKind::TRACE:
      if (!settings.replay)
        throw ConfigError("channel settings: model trace without its loaded trace (" + settings.trace + ")");
      return std::make_unique<TraceLoss>(settings.replay, static_cast<std::size_t>(seed % settings.replay->slots()));
    case LossModelKind::BERNOULLI:
    default:
      return std::make_unique<BernoulliLoss>(settings.loss, seed);
  }
}

}  // namespace networked_estimation
