// What fit_link writes (link_report.hpp).
#include "networked_estimation/link/link_report.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include "config/yaml_reader.hpp"
#include "networked_estimation/io/json_writer.hpp"

namespace networked_estimation
{
namespace link_report_detail
{

std::string num(double v, int digits = 4)
{
  if (std::isnan(v))
    return "n/a";
  std::ostringstream os;
  os.precision(digits);
  os << v;
  return os.str();
}

/// A quantile's interval "[lower, upper] s"; an end clamped to the smallest or largest delay
/// (too few delays for that quantile) is marked "(open)".
std::string quantileInterval(double lower, double upper, bool open)
{
  return "[" + num(lower) + ", " + num(upper) + "] s" + (open ? " (open: too few delays)" : "");
}

std::string interval(const RateEstimate& e)
{
  return num(e.value) + " [" + num(e.lower) + ", " + num(e.upper) + "]";
}

std::string interval(const ParameterEstimate& e)
{
  if (std::isnan(e.lower))
    return num(e.value) + " [n/a]";
  return num(e.value) + " [" + num(e.lower) + ", " + num(e.upper) + "]";
}

/// 1 - an arrival estimate: the loss rate with its interval.
ParameterEstimate lossOf(const RateEstimate& arrival)
{
  return ParameterEstimate{1.0 - arrival.value, std::max(0.0, 1.0 - arrival.upper), std::min(1.0, 1.0 - arrival.lower)};
}

const char* distributionName(DelayDistribution d)
{
  static const char* names[] = {"uniform", "normal", "pareto"};
  return names[static_cast<int>(d)];
}

std::string percent(double v)
{
  return num(100.0 * v, 3) + " %";
}

void rate(JsonWriter& w, const RateEstimate& e)
{
  w.beginObject()
      .member("value", e.value)
      .member("lower", e.lower)
      .member("upper", e.upper)
      .member("successes", e.successes)
      .member("trials", e.trials)
      .endObject();
}

void estimate(JsonWriter& w, const ParameterEstimate& e)
{
  w.beginObject().member("value", e.value).member("lower", e.lower).member("upper", e.upper).endObject();
}

void counts(JsonWriter& w, const std::vector<std::size_t>& v)
{
  w.beginArray();
  for (std::size_t k = 1; k < v.size(); ++k)
    w.value(v[k]);
  w.endArray();
}

LinkModel chosenLink(const LinkFit& f)
{
  return fittedLink(f.loss, IntervalEnd::POINT);
}

}  // namespace link_report_detail

std::vector<std::pair<std::size_t, std::size_t>> burstBins(std::size_t longest)
{
  // 1, 2, 3, 4, then 5-8, 9-16, 17-32, ...: each bin twice as long as the one before.
  std::vector<std::pair<std::size_t, std::size_t>> bins;
  for (std::size_t k = 1; k <= std::min<std::size_t>(4, longest); ++k)
    bins.emplace_back(k, k);
  for (std::size_t lo = 5; lo <= longest; lo = 2 * lo - 1)
    bins.emplace_back(lo, 2 * (lo - 1));
  return bins;
}

std::string fittedChannelYaml(const LinkFit& f)
{
  using namespace link_report_detail;
  using detail::formatNumber;
  const ChannelSettings& c = f.channel;
  const LossFit& l = f.loss;
  std::ostringstream os;
  os << "# Fitted by fit_link from " << f.trace.source << ":\n";
  os << "#   " << f.stats.expected << " expected messages at " << num(1.0 / f.trace.period) << " Hz (slots from "
     << f.trace.slots_from << "), " << f.stats.received << " received, loss rate " << num(f.stats.loss_rate) << "\n";
  os << "# Loss model: " << l.chosen << ", " << l.choice_note << ".\n";
  os << "# 95 % intervals: bernoulli loss " << interval(lossOf(l.estimate.arrival)) << "; gilbert p "
     << interval(l.estimate.failure) << ", r " << interval(l.estimate.recovery);
  if (std::isfinite(l.ge.log_likelihood))
    os << "; gilbert_elliott p " << interval(l.ge.p) << ", r " << interval(l.ge.r) << ", loss_good "
       << interval(l.ge.loss_good) << ", loss_bad " << interval(l.ge.loss_bad);
  os << "\n";
  os << "model: " << (c.model == LossModelKind::BERNOULLI ? "bernoulli" : "gilbert_elliott") << "\n";
  if (c.model == LossModelKind::BERNOULLI)
    os << "loss: " << formatNumber(c.loss) << "\n";
  else
    os << "p: " << formatNumber(c.p) << "\nr: " << formatNumber(c.r) << "\nloss_bad: " << formatNumber(c.loss_bad)
       << "\nloss_good: " << formatNumber(c.loss_good) << "\n";
  const DelayFit& d = f.delay;
  os << "# Delay, receipt - stamp" << (f.trace.relative_delay ? " relative to the smallest (the clocks differ)" : "")
     << ", over " << d.samples << " messages: p50 " << num(d.p50) << " s, p90 " << num(d.p90) << " s, p99 "
     << num(d.p99) << " s, max " << num(d.max) << " s; RFC 3550 jitter " << num(d.rfc3550_jitter)
     << " s; lag-1 correlation " << num(d.lag1) << ".\n";
  if (d.samples > 0)
    os << "# 95 % intervals: p50 " << quantileInterval(d.p50_lower, d.p50_upper, d.p50_open) << ", p90 "
       << quantileInterval(d.p90_lower, d.p90_upper, d.p90_open) << ", p99 "
       << quantileInterval(d.p99_lower, d.p99_upper, d.p99_open) << ".\n";
  os << "# The law below: " << distributionName(d.distribution) << " by maximum likelihood (log-likelihood uniform "
     << num(d.law_log_likelihood[0], 8) << ", normal " << num(d.law_log_likelihood[1], 8) << ", pareto "
     << num(d.law_log_likelihood[2], 8) << ").\n";
  os << "delay: " << formatNumber(c.delay) << "\n";
  os << "jitter: " << formatNumber(c.jitter) << "\n";
  os << "distribution: " << distributionName(c.distribution) << "\n";
  os << "# Reordered " << f.stats.reordered << ", duplicated " << f.stats.duplicates << " of " << f.stats.received
     << " received.\n";
  os << "reorder: " << (c.reorder ? "true" : "false") << "\n";
  os << "duplicate: " << formatNumber(c.duplicate) << "\n";
  return os.str();
}

std::string linkFitText(const LinkFit& f)
{
  using namespace link_report_detail;
  const LinkStatistics& s = f.stats;
  const LossFit& l = f.loss;
  const DelayFit& d = f.delay;
  std::ostringstream os;
  os << "link " << f.trace.source << "\n";
  os << "  expected messages " << s.expected << " at " << num(1.0 / f.trace.period) << " Hz (period "
     << num(f.trace.period) << " s; slots from " << f.trace.slots_from << "), received " << s.received << ", lost "
     << s.lost << ", loss rate " << num(s.loss_rate) << "\n";
  if (!f.trace.note.empty())
    os << "  " << f.trace.note << "\n";
  os << "  duplicates " << s.duplicates << " (" << percent(s.duplicate_fraction) << "), reordered " << s.reordered
     << " (" << percent(s.reorder_fraction) << ")\n";
  if (s.lost == 0)
    os << "  loss bursts: none\n";
  else
    os << "  loss bursts: mean " << num(s.mean_burst) << " messages, gaps between them mean " << num(s.mean_gap)
       << "; longest outage " << s.longest_burst << " messages lost in a row (" << num(s.longest_outage)
       << " s between receipts)\n";
  os << "loss models (maximum likelihood, 95 % intervals):\n";
  os << "  bernoulli        loss " << interval(lossOf(l.estimate.arrival)) << "; BIC " << num(l.bernoulli.bic, 8)
     << "\n";
  os << "  gilbert          p " << interval(l.estimate.failure) << ", r " << interval(l.estimate.recovery) << "; BIC "
     << num(l.gilbert.bic, 8) << "\n";
  if (std::isfinite(l.ge.log_likelihood))
    os << "  gilbert_elliott  p " << interval(l.ge.p) << ", r " << interval(l.ge.r) << ", loss_good "
       << interval(l.ge.loss_good) << ", loss_bad " << interval(l.ge.loss_bad) << "; BIC "
       << num(l.gilbert_elliott.bic, 8) << " (Baum-Welch, " << l.ge.starts << " starts, "
       << (l.ge.converged ? "converged" : "not converged") << " in " << l.ge.iterations << " iterations)\n";
  else
    os << "  gilbert_elliott  not fitted: " << l.ge.note << "\n";
  if (std::isfinite(l.ge.log_likelihood) && !l.ge.note.empty())
    os << "    " << l.ge.note << "\n";
  os << "  model: " << l.chosen << " (" << l.choice_note << ")\n";
  os << "delay (" << f.trace.clock_note << "):\n";
  os << "  p50 " << num(d.p50) << " s, p90 " << num(d.p90) << " s, p99 " << num(d.p99) << " s, max " << num(d.max)
     << " s; mean " << num(d.mean) << " s, sd " << num(d.sd) << " s\n";
  if (d.samples > 0)
    os << "  95 % intervals (order statistics over " << num(d.effective_samples) << " effective of " << d.samples
       << " delays): p50 " << quantileInterval(d.p50_lower, d.p50_upper, d.p50_open) << ", p90 "
       << quantileInterval(d.p90_lower, d.p90_upper, d.p90_open) << ", p99 "
       << quantileInterval(d.p99_lower, d.p99_upper, d.p99_open) << "\n";
  os << "  RFC 3550 jitter " << num(d.rfc3550_jitter) << " s, lag-1 correlation " << num(d.lag1) << "\n";
  os << "  channel law: " << distributionName(d.distribution) << ", delay " << num(d.delay) << " s, jitter "
     << num(d.jitter) << " s\n";
  // The burst lengths against the chosen model's.
  if (s.longest_burst > 0)
  {
    const std::vector<double> law = burstLengthLaw(chosenLink(f), s.longest_burst + 1);
    std::size_t total = 0;
    for (std::size_t k = 1; k < s.bursts.size(); ++k)
      total += s.bursts[k];
    const auto bins = burstBins(s.longest_burst);
    std::vector<std::size_t> observed;
    std::vector<double> expected;
    std::size_t top = 1;
    for (const auto& b : bins)
    {
      std::size_t o = 0;
      double e = 0.0;
      for (std::size_t k = b.first; k <= b.second; ++k)
      {
        o += k < s.bursts.size() ? s.bursts[k] : 0;
        e += k < law.size() ? law[k] : 0.0;
      }
      if (&b == &bins.back())  // the last bin: the model's whole tail
      {
        double tail = 1.0;
        for (std::size_t k = 1; k < b.first && k < law.size(); ++k)
          tail -= law[k];
        e = std::max(0.0, tail);
      }
      observed.push_back(o);
      expected.push_back(e * static_cast<double>(total));
      top = std::max(top, o);
    }
    os << "burst lengths (losses in a row: bursts observed, and as the " << l.chosen << " fit expects them):\n";
    for (std::size_t i = 0; i < bins.size(); ++i)
    {
      // The last bin holds the longest burst, and the model's whole tail from its first length.
      const std::string label =
          std::to_string(bins[i].first) + (i + 1 == bins.size()              ? std::string("+")
                                           : bins[i].second != bins[i].first ? "-" + std::to_string(bins[i].second)
                                                                             : std::string());
      const std::size_t bar = (observed[i] * 40 + top - 1) / top;
      os << "  " << std::left << std::setw(8) << label << std::right << std::setw(8) << observed[i] << " " << std::left
         << std::setw(41) << std::string(bar, '#') << std::right << "fit " << num(expected[i], 4) << "\n";
    }
  }
  return os.str();
}

std::string linkFitsJson(const std::vector<LinkFit>& fits, bool series)
{
  using namespace link_report_detail;
  JsonWriter w;
  w.beginObject().key("links").beginArray();
  for (const LinkFit& f : fits)
  {
    const LinkStatistics& s = f.stats;
    const LossFit& l = f.loss;
    const DelayFit& d = f.delay;
    w.br(2).beginObject();
    w.br(4).member("source", f.trace.source).member("slots_from", f.trace.slots_from).member("note", f.trace.note);
    w.br(4)
        .member("period", f.trace.period)
        .member("rate", 1.0 / f.trace.period)
        .member("first_stamp", f.trace.first_stamp);
    w.br(4)
        .member("messages", f.trace.messages)
        .member("expected", s.expected)
        .member("received", s.received)
        .member("lost", s.lost)
        .member("duplicates", s.duplicates)
        .member("reordered", s.reordered);
    w.br(4)
        .member("loss_rate", s.loss_rate)
        .member("mean_burst", s.mean_burst)
        .member("mean_gap", s.mean_gap)
        .member("longest_burst", s.longest_burst)
        .member("longest_outage", s.longest_outage)
        .member("reorder_fraction", s.reorder_fraction)
        .member("duplicate_fraction", s.duplicate_fraction);
    w.br(4).key("bernoulli").beginObject().key("loss");
    estimate(w, lossOf(l.estimate.arrival));
    w.key("arrival");
    rate(w, l.estimate.arrival);
    w.member("log_likelihood", l.bernoulli.log_likelihood).member("bic", l.bernoulli.bic).endObject();
    w.br(4).key("gilbert").beginObject().key("p");
    rate(w, l.estimate.failure);
    w.key("r");
    rate(w, l.estimate.recovery);
    w.member("log_likelihood", l.gilbert.log_likelihood).member("bic", l.gilbert.bic).endObject();
    w.br(4).key("gilbert_elliott").beginObject().member("fitted", std::isfinite(l.ge.log_likelihood));
    for (const auto& e : {std::make_pair("p", &l.ge.p), std::make_pair("r", &l.ge.r),
                          std::make_pair("loss_good", &l.ge.loss_good), std::make_pair("loss_bad", &l.ge.loss_bad)})
    {
      w.key(e.first);
      estimate(w, *e.second);
    }
    w.member("log_likelihood", l.ge.log_likelihood)
        .member("bic", l.gilbert_elliott.bic)
        .member("starts", l.ge.starts)
        .member("iterations", l.ge.iterations)
        .member("converged", l.ge.converged)
        .member("note", l.ge.note)
        .endObject();
    w.br(4).member("model", l.chosen).member("choice", l.choice_note);
    w.br(4)
        .key("delay")
        .beginObject()
        .member("samples", d.samples)
        .member("relative", f.trace.relative_delay)
        .member("clock_offset", f.trace.clock_offset)
        .member("clock_note", f.trace.clock_note);
    w.br(6)
        .member("mean", d.mean)
        .member("sd", d.sd)
        .member("min", d.min)
        .member("p50", d.p50)
        .member("p90", d.p90)
        .member("p99", d.p99)
        .member("max", d.max)
        .member("rfc3550_jitter", d.rfc3550_jitter)
        .member("lag1", d.lag1);
    w.br(6)
        .member("effective_samples", d.effective_samples)
        .member("p50_lower", d.p50_lower)
        .member("p50_upper", d.p50_upper)
        .member("p50_open", d.p50_open)
        .member("p90_lower", d.p90_lower)
        .member("p90_upper", d.p90_upper)
        .member("p90_open", d.p90_open)
        .member("p99_lower", d.p99_lower)
        .member("p99_upper", d.p99_upper)
        .member("p99_open", d.p99_open);
    w.br(6)
        .key("law")
        .beginObject()
        .member("distribution", distributionName(d.distribution))
        .member("delay", d.delay)
        .member("jitter", d.jitter)
        .key("log_likelihood")
        .beginObject()
        .member("uniform", d.law_log_likelihood[0])
        .member("normal", d.law_log_likelihood[1])
        .member("pareto", d.law_log_likelihood[2])
        .endObject()
        .endObject()
        .endObject();
    w.br(4).key("bursts");
    counts(w, s.bursts);
    w.br(4).key("gaps");
    counts(w, s.gaps);
    w.br(4).key("model_bursts");
    const std::vector<double> law = burstLengthLaw(chosenLink(f), std::max<std::size_t>(1, s.longest_burst));
    w.value(std::vector<double>(law.begin() + 1, law.end()));
    const ChannelSettings& c = f.channel;
    w.br(4).key("channel").beginObject().member("model",
                                                c.model == LossModelKind::BERNOULLI ? "bernoulli" : "gilbert_elliott");
    if (c.model == LossModelKind::BERNOULLI)
      w.member("loss", c.loss);
    else
      w.member("p", c.p).member("r", c.r).member("loss_bad", c.loss_bad).member("loss_good", c.loss_good);
    w.member("delay", c.delay)
        .member("jitter", c.jitter)
        .member("distribution", distributionName(c.distribution))
        .member("reorder", c.reorder)
        .member("duplicate", c.duplicate)
        .endObject();
    if (series)
    {
      std::string arrived(f.trace.arrived.size(), '0');
      std::vector<double> delays(f.trace.arrived.size());
      for (std::size_t k = 0; k < arrived.size(); ++k)
      {
        arrived[k] = f.trace.arrived[k] ? '1' : '0';
        delays[k] = f.trace.arrived[k] ? f.trace.delay[k] : std::numeric_limits<double>::quiet_NaN();
      }
      w.br(4).key("series").beginObject().member("arrived", arrived).member("delay", delays).endObject();
    }
    w.br(2).endObject();
  }
  w.br(0).endArray().endObject();
  return w.text() + "\n";
}

}  // namespace networked_estimation
