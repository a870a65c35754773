// The loss and delay models of a recorded link (docs/stability.md, "Measuring a link"):
//   - Bernoulli: P(lost), and the two-state Gilbert link: p = P(lost | arrived before) =
//     n01 / (n00 + n01), r = P(arrived | lost before) = n10 / (n10 + n11), maximum likelihood with
//     95 % Wilson intervals: link_estimates.hpp, the live monitors' own functions;
//   - the four-parameter Gilbert-Elliott chain (p, r, loss_good, loss_bad) by Baum-Welch from
//     several seeded starts, its 95 % intervals from the observed information (Wald intervals on
//     the logits);
//   - the model chosen by BIC = k ln n - 2 ln L (k = 1, 2, 4 parameters; n the expected messages);
//   - the delay: quantiles, mean, RFC 3550 interarrival jitter, lag-1 correlation, and the
//     channel's delay law (uniform, normal or pareto, by maximum likelihood);
//   - loss rate, bursts and gaps, the longest outage, reordering and duplicates.
// ROS-free.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/link/link_estimates.hpp"
#include "networked_estimation/link/link_trace.hpp"
#include "networked_estimation/stability/link_model.hpp"

namespace networked_estimation
{

/// A parameter with a 95 % interval (NaN ends: not identifiable at the fit).
struct ParameterEstimate
{
  double value = 0.0, lower = 0.0, upper = 1.0;
};

/// One candidate loss model: its log-likelihood on the sequence and its BIC.
struct ModelScore
{
  std::string name;  ///< "bernoulli", "gilbert", "gilbert_elliott"
  int parameters = 0;
  double log_likelihood = 0.0, bic = 0.0;
};

struct GilbertElliottFit
{
  ParameterEstimate p, r, loss_good, loss_bad;
  double log_likelihood = 0.0;
  int starts = 0, iterations = 0;  ///< starts tried; iterations of the best
  bool converged = false;
  std::string note;  ///< e.g. why an interval is missing
};

struct LossFit
{
  ArrivalCounts counts;   ///< of the slots' arrival sequence
  LinkEstimate estimate;  ///< arrival, failure p, recovery r (estimateLink: the live monitors' numbers)
  GilbertElliottFit ge;
  ModelScore bernoulli, gilbert, gilbert_elliott;
  std::string chosen;       ///< the name of the least BIC
  std::string choice_note;  ///< "chosen by BIC: ..."
};

struct DelayFit
{
  std::size_t samples = 0;
  double mean = 0.0, sd = 0.0, min = 0.0, p50 = 0.0, p90 = 0.0, p99 = 0.0, max = 0.0;
  double rfc3550_jitter = 0.0;  ///< J after the last message: J += (|D| - J) / 16, D the change of transit time
  double lag1 = 0.0;            ///< correlation of the delays of consecutive slots that both arrived (NaN: too few)
  /// 95 % intervals of p50, p90 and p99 from order statistics (distribution-free): the ranks
  /// n q -+ 1.96 sqrt(n q (1 - q) n / n_eff), with n_eff = n (1 - lag1) / (1 + lag1) when the
  /// delays are positively correlated (an AR(1) reading of the correlation; n otherwise). A rank
  /// outside 1..n is clamped: that end is then the smallest or largest delay (too few samples
  /// for the quantile), and `*_open` says so. NaN without delays.
  double p50_lower = 0.0, p50_upper = 0.0, p90_lower = 0.0, p90_upper = 0.0, p99_lower = 0.0, p99_upper = 0.0;
  bool p50_open = false, p90_open = false, p99_open = false;
  double effective_samples = 0.0;  ///< n_eff above
  /// The channel's law: delay + jitter Z, Z of `distribution` (channel.hpp), by maximum likelihood.
  double delay = 0.0, jitter = 0.0;
  DelayDistribution distribution = DelayDistribution::UNIFORM;
  double law_log_likelihood[3] = {0.0, 0.0, 0.0};  ///< uniform, normal, pareto
};

struct LinkStatistics
{
  std::size_t expected = 0, received = 0, lost = 0, duplicates = 0, reordered = 0;
  double loss_rate = 0.0, mean_burst = 0.0, mean_gap = 0.0;
  std::size_t longest_burst = 0;    ///< messages in the longest run of losses
  double longest_outage = 0.0;      ///< s between the two received messages around it: (run + 1) periods
  double reorder_fraction = 0.0;    ///< reordered / received
  double duplicate_fraction = 0.0;  ///< duplicates / received
  /// bursts[k]: runs of exactly k losses (k >= 1; index 0 unused); gaps likewise for arrivals.
  std::vector<std::size_t> bursts, gaps;
};

struct FitOptions
{
  int ge_starts = 5;  ///< Baum-Welch starts: one from the Gilbert fit, the others drawn from `seed`;
                      ///< each runs 10 iterations, the best of them then to convergence
  std::uint64_t seed = 1;
  int max_iterations = 1000;
  double tolerance = 1e-2;  ///< stop when an iteration adds less than this to the log-likelihood
  bool fit_ge = true;       ///< false: Bernoulli and Gilbert only
};

struct LinkFit
{
  SlotTrace trace;
  LinkStatistics stats;
  LossFit loss;
  DelayFit delay;
  /// The fitted channel: the chosen loss model, the delay law, reorder and duplicate as measured.
  ChannelSettings channel;
};

LinkStatistics linkStatistics(const SlotTrace& trace);
/// Bernoulli, Gilbert and Gilbert-Elliott fits of an arrival sequence (1 arrived, 0 lost).
LossFit fitLoss(const std::vector<std::uint8_t>& arrived, const FitOptions& options = {});
/// Baum-Welch alone (fitLoss calls it).
GilbertElliottFit fitGilbertElliott(const std::vector<std::uint8_t>& arrived, const FitOptions& options = {});
/// Log-likelihood of the sequence under a link (the hidden chain started in its stationary law).
double logLikelihood(const std::vector<std::uint8_t>& arrived, const LinkModel& link);
DelayFit fitDelay(const SlotTrace& trace);
/// Everything: the statistics, the loss and delay fits and the channel.
LinkFit fitLink(const SlotTrace& trace, const FitOptions& options = {});

/// The fitted loss model as a link (analyze's input), at an end of its intervals: Bernoulli and
/// Gilbert through linkAt (the live monitor's own ends), Gilbert-Elliott with every parameter at
/// the bad (or good) end of its interval.
LinkModel fittedLink(const LossFit& fit, IntervalEnd end);
/// A link as channel settings (bernoulli or gilbert_elliott), the other settings from `base`.
ChannelSettings settingsOf(const LinkModel& link, const ChannelSettings& base = {});

/// P(a loss burst has exactly k losses), k = 1 .. kmax (index 0 unused), under a link.
std::vector<double> burstLengthLaw(const LinkModel& link, std::size_t kmax);

}  // namespace networked_estimation
