// The fits of a recorded link (link/link_fit.hpp, link/link_trace.hpp), the estimates they share
// with the live monitors (link/link_estimates.hpp), and reading ROS bags (io/ros_bag.hpp).
//
// Statistics. Every trace is drawn with a fixed seed from the package's own loss models (20 000
// messages unless said). A single fit is checked by its 95 % interval holding the true parameter;
// the intervals' coverage by R seeded repetitions: the number of intervals that hold the truth is
// Binomial(R, 0.95) when they are right, so the test accepts a coverage within 3.5 of its standard
// deviations sqrt(0.95 * 0.05 / R) of 0.95 (a false failure has probability below 5e-4). Point
// estimates with a known standard error (SE) are checked within 5 SE.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "networked_estimation/channel/channel.hpp"
#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/io/ros_bag.hpp"
#include "networked_estimation/link/link_estimates.hpp"
#include "networked_estimation/link/link_fit.hpp"
#include "networked_estimation/link/link_report.hpp"
#include "networked_estimation/link/channel_trace.hpp"
#include "networked_estimation/link/link_trace.hpp"
#include "networked_estimation/stability/joint_link_monitor.hpp"
#include "networked_estimation/stability/link_monitor.hpp"
#include "test_support.hpp"

using namespace networked_estimation;

namespace
{

constexpr std::size_t kN = 20000;

std::vector<std::uint8_t> arrivalsOf(LossModel& model, std::size_t n)
{
  std::vector<std::uint8_t> a(n);
  for (std::size_t k = 0; k < n; ++k)
    a[k] = model.nextLost() ? 0 : 1;
  return a;
}

std::vector<std::uint8_t> bernoulli(double loss, std::uint64_t seed, std::size_t n = kN)
{
  BernoulliLoss m(loss, seed);
  return arrivalsOf(m, n);
}

std::vector<std::uint8_t> gilbertElliott(double p, double r, double loss_bad, double loss_good, std::uint64_t seed,
                                         std::size_t n = kN)
{
  GilbertElliottLoss m(p, r, loss_bad, loss_good, seed);
  return arrivalsOf(m, n);
}

bool holds(const RateEstimate& e, double truth)
{
  return e.lower <= truth && truth <= e.upper;
}

bool holds(const ParameterEstimate& e, double truth)
{
  return e.lower <= truth && truth <= e.upper;
}

/// The accepted range of the number of intervals out of R that hold the truth (see the top).
void expectCoverage(std::size_t covered, std::size_t R, const std::string& what)
{
  const double sd = std::sqrt(0.95 * 0.05 / static_cast<double>(R));
  const double c = static_cast<double>(covered) / static_cast<double>(R);
  EXPECT_NEAR(c, 0.95, 3.5 * sd) << what << ": " << covered << " of " << R << " intervals hold the truth";
}

/// A record of a periodic sender: slot k stamped t0 + k T, received `delay` later, for the kept slots.
LinkRecord periodicRecord(const std::vector<std::uint8_t>& kept, double period, double delay, bool with_seq,
                          double t0 = 1000.0)
{
  LinkRecord r;
  r.source = "test";
  for (std::size_t k = 0; k < kept.size(); ++k)
    if (kept[k])
    {
      r.stamp.push_back(t0 + static_cast<double>(k) * period);
      r.receipt.push_back(t0 + static_cast<double>(k) * period + delay);
      if (with_seq)
        r.seq.push_back(static_cast<std::uint32_t>(k + 7));
    }
  return r;
}

/// The slots from the first received to the last of a kept pattern.
std::vector<std::uint8_t> trimmed(const std::vector<std::uint8_t>& kept)
{
  std::size_t first = 0, last = kept.size() - 1;
  while (!kept[first])
    ++first;
  while (!kept[last])
    --last;
  return std::vector<std::uint8_t>(kept.begin() + static_cast<long>(first), kept.begin() + static_cast<long>(last) + 1);
}

std::string tempPath(const std::string& name)
{
  return ::testing::TempDir() + "ne_link_fit_" + name;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The estimates the live monitors and the offline fit share

TEST(LinkEstimates, LiveMonitorAndOfflineFitGiveTheSameNumbers)
{
  // One arrival sequence fed to the live monitors (a window holding all of it) and to the fit.
  const std::vector<std::uint8_t> a = gilbertElliott(0.05, 0.3, 1.0, 0.0, 11, 5000);
  LinkMonitor monitor(a.size());
  const Model model = test::scalarTwoSensorModel(0.9, "a", "b");
  JointLinkMonitor joint(model, a.size(), true, 100);
  for (std::uint8_t x : a)
  {
    monitor.add(x != 0);
    joint.add({x != 0, true});
  }
  FitOptions o;
  o.fit_ge = false;
  const LossFit fit = fitLoss(a, o);
  auto same = [](const RateEstimate& x, const RateEstimate& y, const char* what)
  {
    EXPECT_EQ(x.value, y.value) << what;
    EXPECT_EQ(x.lower, y.lower) << what;
    EXPECT_EQ(x.upper, y.upper) << what;
    EXPECT_EQ(x.successes, y.successes) << what;
    EXPECT_EQ(x.trials, y.trials) << what;
  };
  same(monitor.arrivalRate(), fit.estimate.arrival, "arrival");
  same(monitor.failureRate(), fit.estimate.failure, "p");
  same(monitor.recoveryRate(), fit.estimate.recovery, "r");
  const JointLinkStatus js = joint.evaluate();
  same(js.sensors[0].failure, fit.estimate.failure, "joint p");
  same(js.sensors[0].recovery, fit.estimate.recovery, "joint r");
  // The links the verdicts are taken on, at both ends of the intervals and at the estimates.
  ASSERT_EQ(fit.chosen, "gilbert");
  const std::pair<IntervalEnd, const LinkModel*> ends[] = {{IntervalEnd::PESSIMISTIC, &js.pessimistic_links[0]},
                                                           {IntervalEnd::OPTIMISTIC, &js.optimistic_links[0]},
                                                           {IntervalEnd::POINT, &js.point_links[0]}};
  for (const auto& e : ends)
  {
    const LinkModel offline = fittedLink(fit, e.first);
    EXPECT_EQ(offline.p, e.second->p);
    EXPECT_EQ(offline.r, e.second->r);
    EXPECT_EQ(offline.kind, e.second->kind);
  }
  // The maximum-likelihood formulas p = n01 / (n00 + n01), r = n10 / (n10 + n11).
  std::size_t n00 = 0, n01 = 0, n10 = 0, n11 = 0;
  for (std::size_t k = 1; k < a.size(); ++k)
  {
    const bool lost_before = !a[k - 1], lost = !a[k];
    (lost_before ? (lost ? n11 : n10) : (lost ? n01 : n00))++;
  }
  EXPECT_DOUBLE_EQ(fit.estimate.failure.value, double(n01) / double(n00 + n01));
  EXPECT_DOUBLE_EQ(fit.estimate.recovery.value, double(n10) / double(n10 + n11));
}

// ---------------------------------------------------------------------------------------------
// Loss fits

TEST(LinkFit, BernoulliIntervalCoverage)
{
  const double loss = 0.1;
  const std::size_t R = 300;
  std::size_t covered = 0;
  FitOptions o;
  o.fit_ge = false;
  for (std::size_t rep = 0; rep < R; ++rep)
  {
    const LossFit f = fitLoss(bernoulli(loss, 1000 + rep), o);
    covered += holds(f.estimate.arrival, 1.0 - loss) ? 1 : 0;
  }
  expectCoverage(covered, R, "Bernoulli arrival rate");
}

TEST(LinkFit, GilbertIntervalCoverage)
{
  const double p = 0.05, r = 0.3;
  const std::size_t R = 300;
  std::size_t cp = 0, cr = 0;
  FitOptions o;
  o.fit_ge = false;
  for (std::size_t rep = 0; rep < R; ++rep)
  {
    const LossFit f = fitLoss(gilbertElliott(p, r, 1.0, 0.0, 2000 + rep), o);
    cp += holds(f.estimate.failure, p) ? 1 : 0;
    cr += holds(f.estimate.recovery, r) ? 1 : 0;
  }
  expectCoverage(cp, R, "Gilbert p");
  expectCoverage(cr, R, "Gilbert r");
}

TEST(LinkFit, ModelChosenByBic)
{
  // Each model's own traces: BIC picks it (checked on 5 seeds each).
  for (std::uint64_t seed = 1; seed <= 5; ++seed)
  {
    EXPECT_EQ(fitLoss(bernoulli(0.1, seed)).chosen, "bernoulli") << seed;
    EXPECT_EQ(fitLoss(gilbertElliott(0.03, 0.25, 1.0, 0.0, seed)).chosen, "gilbert") << seed;
    EXPECT_EQ(fitLoss(gilbertElliott(0.01, 0.1, 0.6, 0.02, seed)).chosen, "gilbert_elliott") << seed;
  }
}

TEST(LinkFit, GilbertElliottFitAndCoverage)
{
  // Four parameters by Baum-Welch; their Wald intervals on the logits from the observed
  // information. One fit in detail, then the coverage over R repetitions.
  const double p = 0.01, r = 0.1, lb = 0.6, lg = 0.02;
  const std::vector<std::uint8_t> a = gilbertElliott(p, r, lb, lg, 77);
  const LossFit f = fitLoss(a);
  ASSERT_EQ(f.chosen, "gilbert_elliott");
  EXPECT_TRUE(f.ge.converged);
  EXPECT_TRUE(holds(f.ge.p, p)) << f.ge.p.lower << " " << f.ge.p.upper;
  EXPECT_TRUE(holds(f.ge.r, r)) << f.ge.r.lower << " " << f.ge.r.upper;
  EXPECT_TRUE(holds(f.ge.loss_bad, lb)) << f.ge.loss_bad.lower << " " << f.ge.loss_bad.upper;
  EXPECT_TRUE(holds(f.ge.loss_good, lg)) << f.ge.loss_good.lower << " " << f.ge.loss_good.upper;
  // The maximum: no start does better than the one kept, and the truth is not more likely.
  EXPECT_GE(f.ge.log_likelihood, logLikelihood(a, LinkModel::gilbertElliott(p, r, lb, lg)));
  EXPECT_GT(f.ge.log_likelihood, f.gilbert.log_likelihood);

  const std::size_t R = 60;
  std::size_t c[4] = {0, 0, 0, 0};
  for (std::size_t rep = 0; rep < R; ++rep)
  {
    FitOptions o;
    o.ge_starts = 2;
    const GilbertElliottFit g = fitGilbertElliott(gilbertElliott(p, r, lb, lg, 3000 + rep), o);
    c[0] += holds(g.p, p);
    c[1] += holds(g.r, r);
    c[2] += holds(g.loss_good, lg);
    c[3] += holds(g.loss_bad, lb);
  }
  expectCoverage(c[0], R, "GE p");
  expectCoverage(c[1], R, "GE r");
  expectCoverage(c[2], R, "GE loss_good");
  expectCoverage(c[3], R, "GE loss_bad");
}

TEST(LinkFit, BurstLengthLawMatchesTheChains)
{
  // Gilbert: geometric in r. Bernoulli: geometric in the arrival rate. GE: the observed histogram
  // of a long trace within 5 SE of each length's expected count (SE of a Poisson-like count sqrt(e)).
  const std::vector<double> g = burstLengthLaw(LinkModel::gilbertElliott(0.05, 0.3), 5);
  for (int k = 1; k <= 5; ++k)
    EXPECT_NEAR(g[k], std::pow(0.7, k - 1) * 0.3, 1e-12);
  const std::vector<double> b = burstLengthLaw(LinkModel::iid(0.8), 4);
  for (int k = 1; k <= 4; ++k)
    EXPECT_NEAR(b[k], std::pow(0.2, k - 1) * 0.8, 1e-12);
  const LinkModel ge = LinkModel::gilbertElliott(0.01, 0.1, 0.6, 0.02);
  SlotTrace t;
  t.period = 0.02;
  t.arrived = gilbertElliott(0.01, 0.1, 0.6, 0.02, 5, 200000);
  const LinkStatistics s = linkStatistics(t);
  std::size_t total = 0;
  for (std::size_t k = 1; k < s.bursts.size(); ++k)
    total += s.bursts[k];
  const std::vector<double> law = burstLengthLaw(ge, 4);
  for (std::size_t k = 1; k <= 4; ++k)
  {
    const double e = law[k] * static_cast<double>(total);
    EXPECT_NEAR(static_cast<double>(s.bursts[k]), e, 5.0 * std::sqrt(e)) << k;
  }
}

TEST(LinkFit, StatisticsOnAHandMadeTrace)
{
  SlotTrace t;
  t.period = 0.1;
  t.arrived = {1, 0, 0, 1, 1, 0, 1, 0, 0, 0, 1};
  const LinkStatistics s = linkStatistics(t);
  EXPECT_EQ(s.expected, 11u);
  EXPECT_EQ(s.lost, 6u);
  EXPECT_EQ(s.longest_burst, 3u);
  EXPECT_NEAR(s.longest_outage, 0.4, 1e-12);
  EXPECT_NEAR(s.mean_burst, 2.0, 1e-12);      // bursts 2, 1, 3
  EXPECT_NEAR(s.mean_gap, 5.0 / 4.0, 1e-12);  // gaps 1, 2, 1, 1
  ASSERT_GE(s.bursts.size(), 4u);
  EXPECT_EQ(s.bursts[1], 1u);
  EXPECT_EQ(s.bursts[2], 1u);
  EXPECT_EQ(s.bursts[3], 1u);
  EXPECT_EQ(s.gaps[1], 3u);
  EXPECT_EQ(s.gaps[2], 1u);
}

// ---------------------------------------------------------------------------------------------
// Delays

namespace
{

/// A trace of n received slots with delays drawn by a LossyChannel of this law (sampled_delay).
SlotTrace delayTrace(double delay, double jitter, DelayDistribution law, std::uint64_t seed, std::size_t n = kN)
{
  ChannelSettings s;
  s.delay = delay;
  s.jitter = jitter;
  s.distribution = law;
  s.reorder = true;
  s.seed = seed;
  s.queue_limit = n + 1;  // nothing popped: every message stays in flight
  LossyChannel channel(s);
  SlotTrace t;
  t.period = 0.02;
  for (std::size_t k = 0; k < n; ++k)
  {
    const ChannelRecord rec = channel.offer(k, 0.02 * static_cast<double>(k));
    t.arrived.push_back(1);
    t.delay.push_back(rec.sampled_delay);
    t.copies.push_back(1);
    t.receipt_order.push_back(k);
  }
  std::stable_sort(t.receipt_order.begin(), t.receipt_order.end(),
                   [&](std::size_t a, std::size_t b)
                   { return 0.02 * double(a) + t.delay[a] < 0.02 * double(b) + t.delay[b]; });
  return t;
}

}  // namespace

TEST(LinkFit, DelayLawsRecovered)
{
  const double n = static_cast<double>(kN);
  {
    // Normal: the law's delay is the mean (SE jitter / sqrt n), its jitter the sd (SE jitter / sqrt 2n).
    const DelayFit d = fitDelay(delayTrace(0.05, 0.01, DelayDistribution::NORMAL, 3));
    EXPECT_EQ(d.distribution, DelayDistribution::NORMAL);
    EXPECT_NEAR(d.delay, 0.05, 5 * 0.01 / std::sqrt(n));
    EXPECT_NEAR(d.jitter, 0.01, 5 * 0.01 / std::sqrt(2 * n));
    // The median: SE = sqrt(q (1 - q) / n) / f(x_q) = 1.2533 sd / sqrt n.
    EXPECT_NEAR(d.p50, 0.05, 5 * 1.2533 * 0.01 / std::sqrt(n));
    // RFC 3550 on i.i.d. delays estimates E|D| = 2 sd / sqrt(pi) (its own sd about 0.15 sd: an
    // exponential average of 1/16).
    EXPECT_NEAR(d.rfc3550_jitter, 2 * 0.01 / std::sqrt(M_PI), 5 * 0.15 * 0.01);
    // Independent delays: lag-1 correlation within 5 / sqrt n of 0.
    EXPECT_NEAR(d.lag1, 0.0, 5 / std::sqrt(n));
  }
  {
    // Uniform on [0.03, 0.07]: the ends from the extremes (error of order range / n).
    const DelayFit d = fitDelay(delayTrace(0.05, 0.02, DelayDistribution::UNIFORM, 4));
    EXPECT_EQ(d.distribution, DelayDistribution::UNIFORM);
    EXPECT_NEAR(d.delay, 0.05, 10 * 0.04 / n);
    EXPECT_NEAR(d.jitter, 0.02, 10 * 0.04 / n);
  }
  {
    // Pareto (heavy right tail): the law chosen, its mean (= delay) within 5 SE of the mean
    // (the law's sd is the jitter), its jitter within 10 % (its sample sd converges slowly: the
    // fourth moment is infinite).
    const DelayFit d = fitDelay(delayTrace(0.05, 0.01, DelayDistribution::PARETO, 5));
    EXPECT_EQ(d.distribution, DelayDistribution::PARETO);
    EXPECT_NEAR(d.delay, 0.05, 5 * 0.01 / std::sqrt(n));
    EXPECT_NEAR(d.jitter, 0.01, 0.001);
  }
}

TEST(LinkFit, Rfc3550JitterAndLag1ByHand)
{
  SlotTrace t;
  t.period = 0.1;
  t.arrived = {1, 1, 1, 1};
  t.delay = {0.1, 0.3, 0.2, 0.2};
  t.copies = {1, 1, 1, 1};
  t.receipt_order = {0, 2, 1, 3};  // slot 2 overtook slot 1
  const DelayFit d = fitDelay(t);
  // In arrival order the transit times are 0.1, 0.2, 0.3, 0.2: D = 0.1, 0.1, -0.1.
  double j = 0.0;
  for (double D : {0.1, 0.1, -0.1})
    j += (std::abs(D) - j) / 16.0;
  EXPECT_NEAR(d.rfc3550_jitter, j, 1e-15);
  EXPECT_NEAR(d.p50, 0.2, 1e-15);
  EXPECT_NEAR(d.max, 0.3, 1e-15);
}

TEST(LinkFit, Lag1OfCorrelatedDelays)
{
  // AR(1) delays with phi = 0.8: the lag-1 estimate's SE is about sqrt((1 - phi^2) / n).
  Rng rng(9);
  SlotTrace t;
  t.period = 0.02;
  double x = 0.0;
  for (std::size_t k = 0; k < kN; ++k)
  {
    x = 0.8 * x + 0.002 * rng.normal();
    t.arrived.push_back(1);
    t.delay.push_back(0.05 + x);
    t.copies.push_back(1);
    t.receipt_order.push_back(k);
  }
  EXPECT_NEAR(fitDelay(t).lag1, 0.8, 5 * std::sqrt((1 - 0.64) / double(kN)));
}

namespace
{

/// A trace of received slots with these delays, in slot order.
SlotTrace traceOfDelays(const std::vector<double>& delays)
{
  SlotTrace t;
  t.period = 0.02;
  for (std::size_t k = 0; k < delays.size(); ++k)
  {
    t.arrived.push_back(1);
    t.delay.push_back(delays[k]);
    t.copies.push_back(1);
    t.receipt_order.push_back(k);
  }
  return t;
}

}  // namespace

TEST(LinkFit, DelayQuantileIntervalsCoverTheTruth)
{
  // Independent delays, uniform on [0.01, 0.05] (q-quantile 0.01 + 0.04 q), 2000 per trace: each
  // of the p50, p90 and p99 intervals holds its true quantile in about 95 % of R = 1000 traces
  // (coverage within 3.5 standard deviations, as at the top; the rounding of the ranks outwards
  // makes the intervals a little conservative, well inside that).
  const std::size_t R = 1000, n = 2000;
  std::size_t covered[3] = {0, 0, 0};
  Rng rng(31);
  for (std::size_t rep = 0; rep < R; ++rep)
  {
    std::vector<double> delays(n);
    for (double& d : delays)
      d = 0.01 + 0.04 * rng.uniform();
    const DelayFit d = fitDelay(traceOfDelays(delays));
    ASSERT_FALSE(d.p99_open) << "2000 delays are enough for p99";
    covered[0] += d.p50_lower <= 0.03 && 0.03 <= d.p50_upper;
    covered[1] += d.p90_lower <= 0.046 && 0.046 <= d.p90_upper;
    covered[2] += d.p99_lower <= 0.0496 && 0.0496 <= d.p99_upper;
  }
  std::printf("delay quantile intervals, independent delays: coverage p50 %.3f, p90 %.3f, p99 %.3f of %zu\n",
              double(covered[0]) / double(R), double(covered[1]) / double(R), double(covered[2]) / double(R), R);
  expectCoverage(covered[0], R, "p50");
  expectCoverage(covered[1], R, "p90");
  expectCoverage(covered[2], R, "p99");
}

TEST(LinkFit, DelayQuantileIntervalsWidenForCorrelatedDelays)
{
  // AR(1) delays (phi = 0.8, stationary sd 0.002 / sqrt(1 - 0.64) = 0.00333 s about 0.05 s): the
  // median is 0.05 s. Intervals that took the 2000 delays as independent would hold it far less
  // often than 95 % (the sample median's variance is about (1 + phi) / (1 - phi) = 9 times the
  // independent one's for the delays; less for the indicator below the median: the independent
  // formula's intervals held it in 0.573 of these traces when measured); with n_eff = n (1 -
  // lag1) / (1 + lag1) they hold it at least 95 % of the time (one-sided: the correction errs wide),
  // within 3.5 standard deviations over R = 400 traces.
  const std::size_t R = 400, n = 2000;
  std::size_t covered = 0;
  Rng rng(32);
  for (std::size_t rep = 0; rep < R; ++rep)
  {
    std::vector<double> delays(n);
    double x = 0.002 / std::sqrt(1 - 0.64) * rng.normal();
    for (double& d : delays)
    {
      d = 0.05 + x;
      x = 0.8 * x + 0.002 * rng.normal();
    }
    const DelayFit d = fitDelay(traceOfDelays(delays));
    covered += d.p50_lower <= 0.05 && 0.05 <= d.p50_upper;
    EXPECT_LT(d.effective_samples, 0.2 * double(n)) << "lag-1 " << d.lag1;
  }
  const double sd = std::sqrt(0.95 * 0.05 / double(R));
  std::printf("delay quantile intervals, AR(1) delays: p50 coverage %.3f of %zu\n", double(covered) / double(R), R);
  EXPECT_GE(double(covered) / double(R), 0.95 - 3.5 * sd) << covered << " of " << R;
}

TEST(LinkFit, DelayQuantileIntervalsOpenWithFewDelays)
{
  // 50 delays 0, 1, ..., 49 ms in a shuffled order: p99's upper rank is past the largest, so its
  // interval ends at the largest delay and says it is open; p50's is not.
  std::vector<double> delays;
  for (int k = 0; k < 50; ++k)
    delays.push_back(0.001 * k);
  Rng rng(33);
  for (std::size_t i = delays.size() - 1; i > 0; --i)
    std::swap(delays[i], delays[static_cast<std::size_t>(rng.uniform() * double(i + 1))]);
  const DelayFit d = fitDelay(traceOfDelays(delays));
  EXPECT_TRUE(d.p99_open);
  EXPECT_DOUBLE_EQ(d.p99_upper, 0.049);
  EXPECT_FALSE(d.p50_open);
  EXPECT_LE(d.p50_lower, d.p50);
  EXPECT_GE(d.p50_upper, d.p50);
  EXPECT_LE(d.effective_samples, 50.0);
}

// ---------------------------------------------------------------------------------------------
// Finding the expected messages

TEST(LinkTrace, SlotsFromSeqAndFromStamps)
{
  const std::vector<std::uint8_t> kept = gilbertElliott(0.05, 0.3, 1.0, 0.0, 21, 3000);
  const std::vector<std::uint8_t> expect = trimmed(kept);
  for (bool seq : {true, false})
  {
    const SlotTrace t = analyseLink(periodicRecord(kept, 0.02, 0.015, seq), {});
    EXPECT_EQ(t.arrived, expect) << seq;
    EXPECT_EQ(t.slots_from, seq ? "header.seq" : "the stamps (rate learnt from them)");
    EXPECT_NEAR(t.period, 0.02, 1e-9);
    EXPECT_EQ(t.duplicates, 0u);
    EXPECT_EQ(t.reordered, 0u);
    EXPECT_FALSE(t.relative_delay);
    for (std::size_t s = 0; s < t.slots(); ++s)
    {
      if (t.arrived[s])
      {
        ASSERT_NEAR(t.delay[s], 0.015, 1e-9);
      }
    }
  }
  // Stamps with jitter of up to a fifth of a period (a step then errs by less than 0.4 periods),
  // no seq, and more than half of the messages lost.
  Rng rng(4);
  const std::vector<std::uint8_t> many_lost = bernoulli(0.6, 8, 3000);
  LinkRecord r = periodicRecord(many_lost, 0.02, 0.01, false);
  for (double& s : r.stamp)
    s += rng.uniform(-0.004, 0.004);
  EXPECT_EQ(analyseLink(r, {}).arrived, trimmed(many_lost));
}

TEST(LinkTrace, SeqKeptWhenTheSendersStampsJitter)
{
  // A sender that stamps with its clock when it wakes (rospy.Rate at 200 Hz on a loaded machine):
  // each stamp up to a quarter period late, and in 3 % of the slots a stall of 2 to 5 periods after
  // which the late messages go out at once (0.1 ms apart) until it has caught up. header.seq still
  // numbers the messages and is used; the stamps alone could not place them.
  const std::vector<std::uint8_t> kept = gilbertElliott(0.05, 0.3, 1.0, 0.0, 31, 3000);
  LinkRecord r;
  r.source = "test";
  Rng rng(12);
  double clock = 0.0;
  for (std::size_t k = 0; k < kept.size(); ++k)
  {
    clock = std::max(clock + 0.0001, 0.005 * static_cast<double>(k) + rng.uniform(0.0, 0.00125));
    if (rng.uniform(0.0, 1.0) < 0.03)
      clock += rng.uniform(0.01, 0.025);
    if (kept[k])
    {
      r.stamp.push_back(1000.0 + clock);
      r.receipt.push_back(1000.0 + clock + 0.02);
      r.seq.push_back(static_cast<std::uint32_t>(k + 1));
    }
  }
  const SlotTrace t = analyseLink(r, {});
  EXPECT_EQ(t.slots_from, "header.seq") << t.note;
  EXPECT_EQ(t.arrived, trimmed(kept));
  EXPECT_NEAR(t.period, 0.005, 1e-4);
  // Numbers that do not follow the stamps are still refused, and the note says so: two publishers
  // interleaved, each counting from 0; a publisher restarted (its numbers go back to 0).
  LinkRecord two = periodicRecord(std::vector<std::uint8_t>(400, 1), 0.005, 0.02, true);
  for (std::size_t i = 0; i < two.seq.size(); ++i)
    two.seq[i] = static_cast<std::uint32_t>(i % 2 == 0 ? i / 2 : 1000 + i / 2);
  const SlotTrace u = analyseLink(two, {});
  EXPECT_NE(u.slots_from, "header.seq");
  EXPECT_NE(u.note.find("header.seq not used"), std::string::npos) << u.note;
  LinkRecord restarted = periodicRecord(std::vector<std::uint8_t>(400, 1), 0.005, 0.02, true);
  for (std::size_t i = 300; i < restarted.seq.size(); ++i)
    restarted.seq[i] = static_cast<std::uint32_t>(i - 300);
  const SlotTrace v = analyseLink(restarted, {});
  EXPECT_NE(v.slots_from, "header.seq");
  EXPECT_NE(v.note.find("does not run from the first stamp's number to the last's"), std::string::npos) << v.note;
  EXPECT_EQ(v.received(), 400u);
  // A relay that numbers what it forwards (a roscpp publisher): consecutive numbers over a link that
  // lost 5 %. The numbers count 95 % of the stamps' periods: not used, the losses found from the stamps.
  const std::vector<std::uint8_t> lossy = gilbertElliott(0.02, 0.4, 1.0, 0.0, 32, 3000);
  LinkRecord relayed = periodicRecord(lossy, 0.005, 0.02, true);
  for (std::size_t i = 0; i < relayed.seq.size(); ++i)
    relayed.seq[i] = static_cast<std::uint32_t>(i + 1);
  const SlotTrace w = analyseLink(relayed, {});
  EXPECT_EQ(w.slots_from, "the stamps (rate learnt from them)");
  EXPECT_NE(w.note.find("a relay that numbers what it forwards"), std::string::npos) << w.note;
  EXPECT_EQ(w.arrived, trimmed(lossy));
}

TEST(LinkTrace, DuplicatesReorderingAndRate)
{
  const std::vector<std::uint8_t> kept(500, 1);
  LinkRecord r = periodicRecord(kept, 0.1, 0.05, true);
  // Message 10 again, later; messages 20 and 21 received in swapped order.
  r.stamp.push_back(r.stamp[10]);
  r.receipt.push_back(r.receipt[10] + 0.3);
  r.seq.push_back(r.seq[10]);
  std::swap(r.receipt[20], r.receipt[21]);
  const SlotTrace t = analyseLink(r, {});
  EXPECT_EQ(t.duplicates, 1u);
  EXPECT_EQ(t.copies[10], 2);
  EXPECT_EQ(t.reordered, 1u);
  EXPECT_EQ(t.received(), 500u);
  // A rate the stamps contradict is refused, naming what the stamps say.
  TraceOptions o;
  o.rate = 20.0;
  try
  {
    analyseLink(r, o);
    FAIL() << "a contradicting rate was accepted";
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("--rate 20 Hz contradicts"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("(10 Hz)"), std::string::npos) << e.what();
  }
  o.rate = 10.0;
  EXPECT_EQ(analyseLink(r, o).received(), 500u);
}

TEST(LinkTrace, Refusals)
{
  auto message = [](const LinkRecord& r, const TraceOptions& o) -> std::string
  {
    try
    {
      analyseLink(r, o);
    }
    catch (const InputError& e)
    {
      return e.what();
    }
    return "accepted";
  };
  const TraceOptions o;
  EXPECT_NE(message(periodicRecord(std::vector<std::uint8_t>(49, 1), 0.1, 0.0, true), o)
                .find("49 messages, fewer "
                      "than the 50"),
            std::string::npos);
  LinkRecord zero = periodicRecord(std::vector<std::uint8_t>(100, 1), 0.1, 0.0, false);
  for (double& s : zero.stamp)
    s = 0.0;
  EXPECT_NE(message(zero, o).find("have header.stamp 0"), std::string::npos) << message(zero, o);
  LinkRecord irregular = periodicRecord(std::vector<std::uint8_t>(300, 1), 0.1, 0.0, false);
  Rng rng(3);
  for (double& s : irregular.stamp)
    s = 1000.0 + rng.uniform(0.0, 30.0);
  EXPECT_NE(message(irregular, o).find("not periodic"), std::string::npos) << message(irregular, o);
  LinkRecord nan = periodicRecord(std::vector<std::uint8_t>(100, 1), 0.1, 0.0, false);
  nan.receipt[5] = std::nan("");
  EXPECT_NE(message(nan, o).find("message 5"), std::string::npos);
}

TEST(LinkTrace, ClockOffset)
{
  // The recorder's clock 5 s behind the sender's: receipts before stamps, the clocks differ.
  const std::vector<std::uint8_t> kept(300, 1);
  LinkRecord r = periodicRecord(kept, 0.1, 0.0, true);
  Rng rng(6);
  for (double& t : r.receipt)
    t += -5.0 + 0.02 + rng.uniform(0.0, 0.01);
  const SlotTrace t = analyseLink(r, {});
  EXPECT_TRUE(t.relative_delay);
  EXPECT_NEAR(t.clock_offset, -4.98, 0.0001);
  double smallest = 1.0;
  for (std::size_t s = 0; s < t.slots(); ++s)
    smallest = std::min(smallest, t.delay[s]);
  EXPECT_EQ(smallest, 0.0);
  EXPECT_NE(t.clock_note.find("only the delay relative to the smallest"), std::string::npos);
  TraceOptions same;
  same.clock = ClockMode::SAME;
  EXPECT_THROW(analyseLink(r, same), InputError);
  // Told the clocks differ, a positive offset is removed too.
  LinkRecord later = periodicRecord(kept, 0.1, 2.5, true);
  TraceOptions different;
  different.clock = ClockMode::DIFFERENT;
  EXPECT_NEAR(analyseLink(later, different).clock_offset, 2.5, 1e-9);
  EXPECT_NEAR(analyseLink(later, {}).delay[3], 2.5, 1e-9);
}

TEST(LinkTrace, CsvAndEventsFiles)
{
  const std::string csv = tempPath("trace.csv");
  const LinkRecord r = periodicRecord(bernoulli(0.2, 5, 400), 0.05, 0.01, true);
  writeLinkCsv(r, csv);
  const LinkRecord back = readLinkCsv(csv);
  EXPECT_EQ(back.stamp, r.stamp);
  EXPECT_EQ(back.receipt, r.receipt);
  EXPECT_EQ(back.seq, r.seq);
  EXPECT_FALSE(isEventsCsv(csv));
  {
    std::ofstream bad(tempPath("bad.csv"));
    bad << "stamp,receipt\n1.0,1.1\n2.0,x\n";
  }
  try
  {
    readLinkCsv(tempPath("bad.csv"));
    FAIL();
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(":3: receipt"), std::string::npos) << e.what();
  }
  {
    std::ofstream nocol(tempPath("nocol.csv"));
    nocol << "time,receipt\n1.0,1.1\n";
  }
  EXPECT_THROW(readLinkCsv(tempPath("nocol.csv")), InputError);
  // A LossyChannel's ~events as `rostopic echo -p` prints them.
  const std::string ev = tempPath("events.csv");
  {
    std::ofstream out(ev);
    out << "%time,field.header.seq,field.header.stamp,field.header.frame_id,field.seq,field.input_stamp,"
           "field.outcome,field.duplicated,field.state,field.delay,field.sampled_delay\n";
    for (int k = 0; k < 60; ++k)
      out << k << "," << k << "," << (1000000000LL + 20000000LL * k) << ",," << (k + 3) << ",0," << (k % 5 == 0 ? 1 : 0)
          << "," << (k == 7 ? "True" : "False") << ",0," << (k % 5 == 0 ? 0.0 : 0.01 * (k % 3)) << ",0\n";
  }
  EXPECT_TRUE(isEventsCsv(ev));
  const SlotTrace t = readEventSlots(ev);
  ASSERT_EQ(t.slots(), 60u);
  EXPECT_EQ(t.received(), 48u);
  EXPECT_EQ(t.duplicates, 1u);
  EXPECT_NEAR(t.period, 0.02, 1e-12);
  EXPECT_NEAR(t.delay[4], 0.01, 1e-12);
  std::remove(csv.c_str());
  std::remove(ev.c_str());
}

// ---------------------------------------------------------------------------------------------
// Reading ROS bags

TEST(RosBag, ReadsTheJackalBag)
{
  // robot_localization's test2.bag (bz2 chunks): counts and stamps as `rosbag info` gives them.
  const RosBag bag(std::string(NE_SOURCE_DIR) + "/test/data/test2.bag");
  EXPECT_EQ(bag.compression(), "bz2");
  const std::vector<std::string> topics = bag.topics();
  ASSERT_EQ(topics.size(), 2u);
  const std::vector<BagTopicHeaders> h = bag.headers({"/jackal_velocity_controller/odom", "/imu/data"});
  EXPECT_EQ(h[0].type, "nav_msgs/Odometry");
  EXPECT_EQ(h[1].type, "sensor_msgs/Imu");
  EXPECT_TRUE(h[0].has_header);
  EXPECT_EQ(h[0].receipt.size(), 3060u);
  EXPECT_EQ(h[1].receipt.size(), 3061u);
  ASSERT_EQ(h[0].stamp.size(), 3060u);
  // As Python's rosbag reads them: odometry stamps 47.584 to 108.764 s, received 0 to 32 ms after
  // them; IMU stamps 47.58 to 108.78 s.
  double lo = 1e9, hi = 0, late = 0, early = 1;
  for (std::size_t i = 0; i < h[0].stamp.size(); ++i)
  {
    lo = std::min(lo, h[0].stamp[i]);
    hi = std::max(hi, h[0].stamp[i]);
    late = std::max(late, h[0].receipt[i] - h[0].stamp[i]);
    early = std::min(early, h[0].receipt[i] - h[0].stamp[i]);
  }
  EXPECT_NEAR(lo, 47.584, 1e-6);
  EXPECT_NEAR(hi, 108.764, 1e-6);
  EXPECT_NEAR(late, 0.032, 1e-6);
  EXPECT_NEAR(early, 0.0, 1e-6);
  EXPECT_NEAR(*std::min_element(h[1].stamp.begin(), h[1].stamp.end()), 47.58, 1e-6);
  EXPECT_NEAR(*std::max_element(h[1].stamp.begin(), h[1].stamp.end()), 108.78, 1e-6);
  try
  {
    bag.headers({"/gps"});
    FAIL();
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("no topic /gps in the bag (its topics: /imu/data, "
                                         "/jackal_velocity_controller/odom)"),
              std::string::npos)
        << e.what();
  }
}

TEST(RosBag, RefusesWhatIsNotABag)
{
  const std::string notbag = tempPath("not.bag");
  {
    std::ofstream out(notbag);
    out << "stamp,receipt\n";
  }
  try
  {
    RosBag b(notbag);
    FAIL();
  }
  catch (const InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("not a ROS bag"), std::string::npos) << e.what();
  }
  // The first half of a real bag: its index is gone.
  std::ifstream in(std::string(NE_SOURCE_DIR) + "/test/data/test2.bag", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string half = tempPath("half.bag");
  std::ofstream(half, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  EXPECT_THROW(RosBag b(half), InputError);
  EXPECT_THROW(RosBag b(tempPath("missing.bag")), InputError);
  std::remove(notbag.c_str());
  std::remove(half.c_str());
}

TEST(RosBag, DefinitionWithHeader)
{
  EXPECT_TRUE(definitionStartsWithHeader("# comment\n\nHeader header\nfloat64 x\n"));
  EXPECT_TRUE(definitionStartsWithHeader("std_msgs/Header header\n"));
  EXPECT_FALSE(definitionStartsWithHeader("float64 data\n"));
  EXPECT_FALSE(definitionStartsWithHeader("float64 x\nHeader header\n"));
}

TEST(LinkFit, TheJackalBagIsAPerfectLink)
{
  // The real bag lost nothing: Bernoulli with loss 0 chosen, the odometry's delays within 32 ms.
  const std::vector<LinkRecord> r =
      readBagLinks(std::string(NE_SOURCE_DIR) + "/test/data/test2.bag", {"/jackal_velocity_controller/odom"});
  const LinkFit f = fitLink(analyseLink(r[0], {}));
  EXPECT_NEAR(1.0 / f.trace.period, 50.0, 0.1);
  EXPECT_EQ(f.stats.lost, 0u);
  EXPECT_EQ(f.loss.chosen, "bernoulli");
  EXPECT_EQ(f.channel.loss, 0.0);
  EXPECT_LE(f.delay.max, 0.033);
}

// ---------------------------------------------------------------------------------------------
// The trace-driven channel (model: trace)

namespace
{

/// A trace file (CSV) with a Gilbert loss pattern, delays of 10 to 14 ms and slot 5 received twice,
/// and a channel file naming it by a path relative to the channel file.
struct TraceFiles
{
  std::string csv, channel;
  SlotTrace slots;  ///< what fit_link finds in the CSV
};

TraceFiles traceFiles(const std::string& name)
{
  TraceFiles f;
  f.csv = tempPath(name + ".csv");
  f.channel = tempPath(name + ".yaml");
  std::vector<std::uint8_t> kept = gilbertElliott(0.05, 0.3, 1.0, 0.0, 31, 1000);
  kept[0] = kept[5] = kept[999] = 1;
  LinkRecord r = periodicRecord(kept, 0.05, 0.0, true);
  for (std::size_t i = 0; i < r.receipt.size(); ++i)
    r.receipt[i] += 0.010 + 0.001 * static_cast<double>(r.seq[i] % 5);
  const std::size_t five = static_cast<std::size_t>(std::find(r.seq.begin(), r.seq.end(), 7u + 5u) - r.seq.begin());
  r.stamp.push_back(r.stamp[five]);
  r.receipt.push_back(r.receipt[five] + 0.2);
  r.seq.push_back(r.seq[five]);
  writeLinkCsv(r, f.csv);
  std::ofstream(f.channel) << "model: trace\ntrace: " << f.csv.substr(f.csv.rfind('/') + 1) << "\nseed: 3\n";
  f.slots = analyseLink(r, {});
  return f;
}

}  // namespace

TEST(TraceChannel, ReplaysTheRecordedLossesAndDelaysExactly)
{
  const TraceFiles f = traceFiles("replay");
  const ChannelSettings s = loadChannelSettings(f.channel);
  ASSERT_EQ(s.model, LossModelKind::TRACE);
  ASSERT_TRUE(s.replay);
  ASSERT_EQ(s.replay->slots(), f.slots.slots());
  LossyChannel channel(s);
  const std::size_t n = f.slots.slots();
  std::vector<Delivery> out;
  std::size_t delivered = 0;
  for (std::size_t i = 0; i < 2 * n + 7; ++i)  // twice round and more: the trace loops
  {
    const double t = 0.05 * static_cast<double>(i);
    const ChannelRecord rec = channel.offer(i, t);
    const std::size_t k = i % n;
    ASSERT_EQ(rec.outcome, f.slots.arrived[k] ? ChannelOutcome::DELIVERED : ChannelOutcome::DROPPED_MODEL) << i;
    if (f.slots.arrived[k])
    {
      ASSERT_EQ(rec.sampled_delay, f.slots.delay[k]) << i;
      ASSERT_EQ(rec.delay, f.slots.delay[k]) << i;  // in order: nothing held back
      ASSERT_EQ(rec.duplicated, f.slots.copies[k] > 1) << i;
    }
    channel.popDue(t + 0.02, out);  // each due within 14 ms of its offer
    for (const Delivery& d : out)
    {
      ASSERT_EQ(d.due, 0.05 * static_cast<double>(d.seq) + f.slots.delay[d.seq % n]);
      ++delivered;
    }
  }
  // Per round every received slot once and slot 5 (received twice) once more; the last 7 offers
  // are slots 0 to 6 of a third round.
  ASSERT_EQ(f.slots.copies[5], 2);
  std::size_t third = 0;
  for (std::size_t k = 0; k < 7; ++k)
    third += f.slots.copies[k];
  EXPECT_EQ(delivered, 2 * (f.slots.received() + 1) + third);
  std::remove(f.csv.c_str());
  std::remove(f.channel.c_str());
}

TEST(TraceChannel, SettingsAndRefusals)
{
  const TraceFiles f = traceFiles("settings");
  const ChannelSettings s = loadChannelSettings(f.channel);
  auto refusal = [](const std::string& yaml) -> std::string
  {
    try
    {
      parseChannelSettings(YAML::Load(yaml), "chan.yaml");
    }
    catch (const ConfigError& e)
    {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_NE(refusal("model: trace").find("model trace needs trace"), std::string::npos);
  EXPECT_NE(refusal("model: trace\ntrace: " + f.csv + "\ndelay: 0.1")
                .find("key 'delay' does not apply to model "
                      "trace"),
            std::string::npos);
  EXPECT_NE(refusal("model: trace\ntrace: " + f.csv + "\nloss: 0.1")
                .find("key 'loss' applies only to model "
                      "bernoulli (model is trace)"),
            std::string::npos);
  EXPECT_NE(refusal("model: bernoulli\nloss: 0.1\ntrace: x.csv").find("key 'trace' applies only to model trace"),
            std::string::npos);
  const std::string missing = refusal("model: trace\ntrace: " + tempPath("nowhere.csv"));
  EXPECT_NE(missing.find("chan.yaml:2: trace: "), std::string::npos) << missing;
  EXPECT_NE(missing.find("nowhere.csv"), std::string::npos) << missing;
  EXPECT_NE(refusal("model: trace\ntrace: " + f.csv + "\ntrace_topic: /gps").find("not a ROS bag, so trace_topic"),
            std::string::npos);
  const std::string bag = std::string(NE_SOURCE_DIR) + "/test/data/test2.bag";
  EXPECT_NE(refusal("model: trace\ntrace: " + bag).find("trace_topic must name the topic"), std::string::npos);
  EXPECT_NE(refusal("model: trace\ntrace: " + bag + "\ntrace_topic: /gps").find("no topic /gps in the bag"),
            std::string::npos);
  const ChannelSettings b =
      parseChannelSettings(YAML::Load("model: trace\ntrace: " + bag + "\ntrace_topic: /imu/data"), "chan.yaml");
  EXPECT_EQ(b.replay->slots(), 3061u);
  // Written back and read again: the same file; a runtime change keeps the loaded trace.
  const ChannelSettings again = parseChannelSettings(toYaml(s), "again");
  EXPECT_EQ(again.trace, s.trace);
  EXPECT_EQ(again.replay->arrived, s.replay->arrived);
  const ChannelSettings changed = mergeChannelSettings(s, YAML::Load("{reorder: true}"), "change");
  EXPECT_EQ(changed.replay, s.replay);
  EXPECT_TRUE(changed.reorder);
  const ChannelSettings to_bernoulli = mergeChannelSettings(s, YAML::Load("{model: bernoulli, loss: 0.1}"), "change");
  EXPECT_EQ(to_bernoulli.model, LossModelKind::BERNOULLI);
  EXPECT_TRUE(to_bernoulli.trace.empty());
  EXPECT_THROW(mergeChannelSettings(s, YAML::Load("{delay: 0.1}"), "change"), ConfigError);
  std::remove(f.csv.c_str());
  std::remove(f.channel.c_str());
}

TEST(TraceChannel, SimulatorsAndTheAnalysis)
{
  const TraceFiles f = traceFiles("sim");
  const ChannelSettings s = loadChannelSettings(f.channel);
  const std::size_t n = f.slots.slots();
  // The simulators' loss model starts at the slot its seed chooses, and loops.
  for (std::uint64_t seed : {0ull, 17ull, 123456789ull})
  {
    std::unique_ptr<LossModel> m = makeLossModel(s, seed);
    for (std::size_t i = 0; i < n + 3; ++i)
      ASSERT_EQ(m->nextLost(), f.slots.arrived[(seed + i) % n] == 0) << seed << " " << i;
    m->reseed(seed + 1);
    EXPECT_EQ(m->nextLost(), f.slots.arrived[(seed + 1) % n] == 0);
  }
  // The analysis takes the trace's fitted loss model, fit_link's.
  const LossFit fit = fitLoss(f.slots.arrived);
  const LinkModel expect = fittedLink(fit, IntervalEnd::POINT);
  const LinkModel got = LinkModel::fromSettings(s);
  EXPECT_EQ(got.kind, expect.kind);
  EXPECT_EQ(got.arrival, expect.arrival);
  EXPECT_EQ(got.p, expect.p);
  EXPECT_EQ(got.r, expect.r);
  std::remove(f.csv.c_str());
  std::remove(f.channel.c_str());
}

TEST(TraceChannel, SeededChannelsUnchangedBitForBit)
{
  // Digests of 20 000 offers (outcomes, states, copies, delays, deliveries) of two seeded channels,
  // computed with the code before model: trace existed (commit e6c4a26).
  auto digest = [](const ChannelSettings& s)
  {
    std::uint64_t h = 1469598103934665603ull;
    auto add = [&h](const void* p, std::size_t n)
    {
      const unsigned char* c = static_cast<const unsigned char*>(p);
      for (std::size_t i = 0; i < n; ++i)
      {
        h ^= c[i];
        h *= 1099511628211ull;
      }
    };
    auto u = [&add](std::uint64_t x) { add(&x, 8); };
    auto d = [&add](double x) { add(&x, 8); };
    LossyChannel ch(s);
    std::vector<Delivery> out;
    for (int k = 0; k < 20000; ++k)
    {
      const double t = 0.01 * k;
      const ChannelRecord r = ch.offer(static_cast<std::uint64_t>(k), t);
      u(static_cast<std::uint64_t>(r.outcome));
      u(static_cast<std::uint64_t>(r.state));
      u(r.duplicated);
      d(r.delay);
      d(r.sampled_delay);
      ch.popDue(t, out);
      for (const Delivery& e : out)
      {
        u(e.seq);
        u(e.duplicate);
        d(e.due);
      }
    }
    return h;
  };
  ChannelSettings ge;
  ge.model = LossModelKind::GILBERT_ELLIOTT;
  ge.p = 0.05;
  ge.r = 0.4;
  ge.loss_bad = 1.0;
  ge.loss_good = 0.005;
  ge.seed = 1;
  ge.delay = 0.008;
  ge.jitter = 0.004;
  ge.distribution = DelayDistribution::PARETO;
  ge.duplicate = 0.01;
  ChannelSettings b;
  b.model = LossModelKind::BERNOULLI;
  b.loss = 0.2;
  b.seed = 42;
  b.delay = 0.05;
  b.jitter = 0.02;
  b.distribution = DelayDistribution::NORMAL;
  b.reorder = true;
  EXPECT_EQ(digest(ge), 0x782c20661bd13d2full);
  EXPECT_EQ(digest(b), 0x8050bc5d0c94b3aeull);
}
