// Tests of the lossy channel engine (channel.hpp). Deterministic clock, fixed seeds.
//
// Statistical tolerances are derived from the sample size, never tuned to the seeds:
//  - means and proportions: 5 standard errors (two-sided 5-sigma, false alarm ~6e-7);
//  - quantiles: the DKW inequality P(sup_x |F_n(x) - F(x)| > eps) <= 2 exp(-2 n eps^2), i.e.
//    eps = sqrt(ln(2 / alpha) / (2 n)) with alpha = 1e-6 (the same false-alarm level), plus 1/n for
//    the interpolation between order statistics. Then the empirical q-quantile lies in
//    [F^-1(q - eps), F^-1(q + eps)], which is the bound checked.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <stdexcept>
#include <vector>

#include "networked_estimation/channel/channel.hpp"
#include "networked_estimation/channel/channel_deliveries.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/channel_settings.hpp"

namespace ne = networked_estimation;

namespace
{

::testing::AssertionResult balanced(const ne::ChannelCounters& c)
{
  const std::uint64_t in = c.received + c.duplicated;
  const std::uint64_t out = c.delivered + c.dropped_model + c.dropped_queue + c.in_flight;
  if (in == out)
    return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "received " << c.received << " + duplicated " << c.duplicated
                                       << " != delivered " << c.delivered << " + dropped_model " << c.dropped_model
                                       << " + dropped_queue " << c.dropped_queue << " + in_flight " << c.in_flight;
}

/// Lossless, no delay, big queue.
ne::ChannelSettings base(std::uint64_t seed = 42)
{
  ne::ChannelSettings s;
  s.model = ne::LossModelKind::BERNOULLI;
  s.loss = 0.0;
  s.seed = seed;
  s.queue_limit = 1000000;
  return s;
}

struct Trace
{
  std::vector<ne::ChannelRecord> events;
  std::vector<ne::Delivery> deliveries;
};

/// Offers n messages (seq = i) at irregular but deterministic times, popping after every offer,
/// then pops the rest. Optionally reconfigures to `s2` just before offer `switch_at`.
Trace drive(const ne::ChannelSettings& s, int n, int switch_at = -1, const ne::ChannelSettings* s2 = nullptr)
{
  ne::LossyChannel ch(s);
  Trace t;
  std::vector<ne::Delivery> out;
  double now = 0.0;
  for (int i = 0; i < n; ++i)
  {
    if (i == switch_at && s2)
      ch.reconfigure(*s2);
    now += 0.001 * (1 + i % 3);
    t.events.push_back(ch.offer(static_cast<std::uint64_t>(i), now));
    ch.popDue(now, out);
    t.deliveries.insert(t.deliveries.end(), out.begin(), out.end());
  }
  ch.popAll(out);
  t.deliveries.insert(t.deliveries.end(), out.begin(), out.end());
  return t;
}

bool sameEvent(const ne::ChannelRecord& a, const ne::ChannelRecord& b)
{
  return a.seq == b.seq && a.arrival == b.arrival && a.outcome == b.outcome && a.duplicated == b.duplicated &&
         a.state == b.state && a.delay == b.delay;
}

bool sameEvents(const std::vector<ne::ChannelRecord>& a, const std::vector<ne::ChannelRecord>& b)
{
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), sameEvent);
}

bool sameDeliveries(const std::vector<ne::Delivery>& a, const std::vector<ne::Delivery>& b)
{
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(),
                                            [](const ne::Delivery& x, const ne::Delivery& y)
                                            { return x.seq == y.seq && x.duplicate == y.duplicate && x.due == y.due; });
}

double Phi(double x)
{
  return 0.5 * std::erfc(-x / std::sqrt(2.0));
}

double phi(double x)
{
  return std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI);
}

double PhiInv(double q)
{
  double lo = -40.0, hi = 40.0;
  for (int i = 0; i < 200; ++i)
  {
    const double mid = 0.5 * (lo + hi);
    (Phi(mid) < q ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// DKW half-width for n samples (see the top of the file).
double dkwEps(std::size_t n)
{
  const double alpha = 1e-6;
  return std::sqrt(std::log(2.0 / alpha) / (2.0 * static_cast<double>(n))) + 1.0 / static_cast<double>(n);
}

/// n offers every 1 ms with reorder on (so the event delay is the drawn delay, never held),
/// popping as it goes; returns the event delays and leaves the channel for its quantiles.
std::vector<double> delays(ne::LossyChannel& ch, int n)
{
  std::vector<double> d;
  std::vector<ne::Delivery> out;
  for (int i = 0; i < n; ++i)
  {
    const double now = 0.001 * i;
    const ne::ChannelRecord ev = ch.offer(static_cast<std::uint64_t>(i), now);
    EXPECT_EQ(ev.outcome, ne::ChannelOutcome::DELIVERED);
    d.push_back(ev.delay);
    ch.popDue(now, out);
  }
  return d;
}

double mean(const std::vector<double>& v)
{
  double s = 0.0;
  for (double x : v)
    s += x;
  return s / static_cast<double>(v.size());
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// Delivery timing and order

TEST(LossyChannel, ZeroDelayDeliversImmediatelyInOrder)
{
  ne::LossyChannel ch(base());
  std::vector<ne::Delivery> out;
  EXPECT_TRUE(std::isinf(ch.nextDue()));
  for (int i = 0; i < 1000; ++i)
  {
    const double now = 0.01 * i;
    for (int j = 0; j < 3; ++j)
    {
      const std::uint64_t seq = 3 * i + j;
      const ne::ChannelRecord ev = ch.offer(seq, now);
      ASSERT_EQ(ev.outcome, ne::ChannelOutcome::DELIVERED);
      ASSERT_EQ(ev.seq, seq);
      ASSERT_EQ(ev.arrival, now);
      ASSERT_EQ(ev.delay, 0.0);
      ASSERT_FALSE(ev.duplicated);
      ASSERT_TRUE(balanced(ch.counters()));
    }
    ASSERT_EQ(ch.nextDue(), now);
    ASSERT_EQ(ch.popDue(now, out), 3u);
    for (int j = 0; j < 3; ++j)
    {
      ASSERT_EQ(out[j].seq, static_cast<std::uint64_t>(3 * i + j));
      ASSERT_FALSE(out[j].duplicate);
      ASSERT_EQ(out[j].due, now);
    }
    ASSERT_TRUE(balanced(ch.counters()));
    ASSERT_EQ(ch.counters().in_flight, 0u);
    ASSERT_TRUE(std::isinf(ch.nextDue()));
  }
  EXPECT_EQ(ch.counters().received, 3000u);
  EXPECT_EQ(ch.counters().delivered, 3000u);
  EXPECT_EQ(ch.lossRate(), 0.0);
  EXPECT_TRUE(std::isnan(ch.meanBurstLength()));
}

TEST(LossyChannel, FixedDelayDeliversExactlyAtDueNotBefore)
{
  ne::ChannelSettings s = base();
  s.delay = 0.25;
  ne::LossyChannel ch(s);
  std::vector<ne::Delivery> out;
  for (int i = 0; i < 200; ++i)
  {
    const double a = 5.0 + 0.37 * i;
    const ne::ChannelRecord ev = ch.offer(i, a);
    ASSERT_EQ(ev.delay, 0.25);
    ASSERT_EQ(ch.nextDue(), a + 0.25);
    ASSERT_EQ(ch.popDue(a + 0.25 - 1e-9, out), 0u);
    ASSERT_TRUE(out.empty());
    ASSERT_EQ(ch.counters().in_flight, 1u);
    ASSERT_TRUE(balanced(ch.counters()));
    ASSERT_EQ(ch.popDue(a + 0.25, out), 1u);
    ASSERT_EQ(out[0].seq, static_cast<std::uint64_t>(i));
    ASSERT_EQ(out[0].due, a + 0.25);
    ASSERT_TRUE(balanced(ch.counters()));
  }
  // Several in flight, released one at a time as the clock passes each due.
  for (int i = 0; i < 5; ++i)
    ch.offer(1000 + i, 200.0 + i);
  for (int i = 0; i < 5; ++i)
  {
    ASSERT_EQ(ch.popDue(200.25 + i - 1e-9, out), 0u);
    ASSERT_EQ(ch.popDue(200.25 + i, out), 1u);
    EXPECT_EQ(out[0].seq, static_cast<std::uint64_t>(1000 + i));
  }
}

TEST(LossyChannel, NoReorderKeepsOfferOrderDespiteJitter)
{
  ne::ChannelSettings s = base(7);
  s.delay = 0.05;
  s.jitter = 0.05;  // spread 0.1 s >> 1-3 ms between offers: plenty of would-be inversions
  s.reorder = false;
  const Trace t = drive(s, 5000);
  ASSERT_EQ(t.deliveries.size(), 5000u);
  for (std::size_t i = 0; i < t.deliveries.size(); ++i)
  {
    ASSERT_EQ(t.deliveries[i].seq, i);
    ASSERT_EQ(t.deliveries[i].due, t.events[i].arrival + t.events[i].delay);
    if (i > 0)
    {
      ASSERT_GE(t.deliveries[i].due, t.deliveries[i - 1].due);
    }
  }
  // The drawn delays depend only on (seed, offer index), so the reorder run of the same seed shows
  // them unheld: no message leaves earlier than drawn, and many are held back.
  ne::ChannelSettings r = s;
  r.reorder = true;
  const Trace drawn = drive(r, 5000);
  int held = 0;
  for (std::size_t i = 0; i < t.events.size(); ++i)
  {
    ASSERT_GE(t.events[i].delay, drawn.events[i].delay - 1e-12);
    held += t.events[i].delay > drawn.events[i].delay + 1e-12;
  }
  EXPECT_GT(held, 1000);
}

TEST(LossyChannel, ReorderDeliversEachOnceWithInversions)
{
  ne::ChannelSettings s = base(7);
  s.delay = 0.05;
  s.jitter = 0.05;
  s.reorder = true;
  const Trace t = drive(s, 5000);
  ASSERT_EQ(t.deliveries.size(), 5000u);
  std::set<std::uint64_t> seen;
  long inversions = 0;
  for (std::size_t i = 0; i < t.deliveries.size(); ++i)
  {
    const ne::Delivery& d = t.deliveries[i];
    ASSERT_TRUE(seen.insert(d.seq).second) << "seq " << d.seq << " delivered twice";
    ASSERT_EQ(d.due, t.events[d.seq].arrival + t.events[d.seq].delay);
    if (i > 0)
    {
      ASSERT_GE(d.due, t.deliveries[i - 1].due);  // delivery order is by due
      inversions += d.seq < t.deliveries[i - 1].seq;
    }
  }
  EXPECT_EQ(seen.size(), 5000u);
  // Uniform delays 0..0.1 s with offers every 2 ms on average: most neighbours overtake.
  EXPECT_GT(inversions, 1000);
}

// ------------------------------------------------------------------------------------------------
// Delay distributions (20000 offers; the quantile window holds the last 10000)

TEST(LossyChannel, UniformJitterMeanAndMedian)
{
  ne::ChannelSettings s = base(101);
  s.delay = 1.0;
  s.jitter = 0.5;
  s.distribution = ne::DelayDistribution::UNIFORM;
  s.reorder = true;
  ne::LossyChannel ch(s);
  const std::vector<double> d = delays(ch, 20000);
  // U[0.5, 1.5]: mean 1, sd jitter / sqrt(3).
  const double se = 0.5 / std::sqrt(3.0 * d.size());
  EXPECT_NEAR(mean(d), 1.0, 5.0 * se);
  EXPECT_GE(*std::min_element(d.begin(), d.end()), 0.5);
  EXPECT_LE(*std::max_element(d.begin(), d.end()), 1.5);
  ASSERT_EQ(ch.delaySamples(), 10000u);
  const double eps = dkwEps(ch.delaySamples());
  auto Finv = [](double q) { return 0.5 + q; };
  for (const double q : {0.1, 0.5, 0.9})
  {
    const double x = ch.delayQuantile(q);
    EXPECT_GE(x, Finv(q - eps)) << "q " << q;
    EXPECT_LE(x, Finv(q + eps)) << "q " << q;
  }
  std::cout << "[ stats    ] uniform: mean " << mean(d) << " (1, se " << se << "), median " << ch.delayQuantile(0.5)
            << " (1 +- " << eps << ")\n";
}

TEST(LossyChannel, NormalJitterClippedMeanAndMedian)
{
  // delay = jitter = 0.1: a sixth of the draws are clipped at 0, so the exact clipped law is
  // tested: X = max(0, mu + sigma Z), E X = mu Phi(mu/sigma) + sigma phi(mu/sigma),
  // E X^2 = (mu^2 + sigma^2) Phi(mu/sigma) + mu sigma phi(mu/sigma), P(X = 0) = Phi(-mu/sigma).
  const double mu = 0.1, sigma = 0.1;
  ne::ChannelSettings s = base(202);
  s.delay = mu;
  s.jitter = sigma;
  s.distribution = ne::DelayDistribution::NORMAL;
  s.reorder = true;
  ne::LossyChannel ch(s);
  const std::vector<double> d = delays(ch, 20000);
  const double n = static_cast<double>(d.size());
  const double a = mu / sigma;
  const double m1 = mu * Phi(a) + sigma * phi(a);
  const double m2 = (mu * mu + sigma * sigma) * Phi(a) + mu * sigma * phi(a);
  const double se = std::sqrt((m2 - m1 * m1) / n);
  EXPECT_NEAR(mean(d), m1, 5.0 * se);
  const double p0 = Phi(-a);
  const double zeros = static_cast<double>(std::count(d.begin(), d.end(), 0.0));
  EXPECT_NEAR(zeros / n, p0, 5.0 * std::sqrt(p0 * (1.0 - p0) / n));
  // Quantiles above P(X = 0): mu + sigma Phi^-1(q).
  const double eps = dkwEps(ch.delaySamples());
  for (const double q : {0.5, 0.9})
  {
    const double x = ch.delayQuantile(q);
    EXPECT_GE(x, mu + sigma * PhiInv(q - eps)) << "q " << q;
    EXPECT_LE(x, mu + sigma * PhiInv(q + eps)) << "q " << q;
  }
  EXPECT_EQ(ch.delayQuantile(0.05), 0.0);  // 0.05 + eps < P(X = 0) = 0.159
  std::cout << "[ stats    ] normal: mean " << mean(d) << " (" << m1 << ", se " << se << "), P(0) " << zeros / n << " ("
            << p0 << "), median " << ch.delayQuantile(0.5) << "\n";
}

TEST(LossyChannel, ParetoJitterMeanAndTailQuantile)
{
  // Z = (X - 1.5) / sqrt(0.75), X ~ Pareto(1, 3): Z >= -0.577, so delay >= 0.577 jitter never
  // clips; mean = delay, sd = jitter (the 4th moment is infinite, the CLT for the mean holds).
  // Quantile: delay + jitter ((1 - q)^(-1/3) - 1.5) / sqrt(0.75).
  const double delay = 1.0, jitter = 0.5;
  ne::ChannelSettings s = base(303);
  s.delay = delay;
  s.jitter = jitter;
  s.distribution = ne::DelayDistribution::PARETO;
  s.reorder = true;
  ne::LossyChannel ch(s);
  const std::vector<double> d = delays(ch, 20000);
  const double se = jitter / std::sqrt(static_cast<double>(d.size()));
  EXPECT_NEAR(mean(d), delay, 5.0 * se);
  EXPECT_GE(*std::min_element(d.begin(), d.end()), delay - jitter / std::sqrt(3.0));
  auto Finv = [&](double q) { return delay + jitter * (std::pow(1.0 - q, -1.0 / 3.0) - 1.5) / std::sqrt(0.75); };
  const double eps = dkwEps(ch.delaySamples());
  for (const double q : {0.5, 0.9, 0.95})  // q + eps < 1
  {
    const double x = ch.delayQuantile(q);
    EXPECT_GE(x, Finv(q - eps)) << "q " << q;
    EXPECT_LE(x, Finv(q + eps)) << "q " << q;
  }
  // Heavy right tail: the 0.99 quantile is much further above the median than the 0.01 below.
  EXPECT_GT(ch.delayQuantile(0.99) - ch.delayQuantile(0.5), 3.0 * (ch.delayQuantile(0.5) - ch.delayQuantile(0.01)));
  std::cout << "[ stats    ] pareto: mean " << mean(d) << " (1, se " << se << "), q0.9 " << ch.delayQuantile(0.9)
            << " (" << Finv(0.9) << ")\n";
}

// ------------------------------------------------------------------------------------------------
// Duplicates and the queue limit

TEST(LossyChannel, DuplicateFractionAndCopiesFollowOriginals)
{
  const int N = 20000;
  const double pd = 0.3;
  ne::ChannelSettings s = base(404);
  s.duplicate = pd;
  const Trace t = drive(s, N);
  long copies = 0, flagged = 0;
  for (std::size_t i = 0; i < t.deliveries.size(); ++i)
  {
    const ne::Delivery& d = t.deliveries[i];
    if (!d.duplicate)
      continue;
    ++copies;
    ASSERT_GT(i, 0u);
    const ne::Delivery& prev = t.deliveries[i - 1];
    ASSERT_FALSE(prev.duplicate);
    ASSERT_EQ(prev.seq, d.seq);
    ASSERT_EQ(prev.due, d.due);
    ASSERT_TRUE(t.events[d.seq].duplicated);
  }
  for (const ne::ChannelRecord& ev : t.events)
    flagged += ev.duplicated;
  EXPECT_EQ(copies, flagged);
  EXPECT_EQ(t.deliveries.size(), static_cast<std::size_t>(N + copies));
  // Independent Bernoulli(pd) per offer: se = sqrt(pd (1 - pd) / N).
  const double frac = static_cast<double>(copies) / N;
  EXPECT_NEAR(frac, pd, 5.0 * std::sqrt(pd * (1.0 - pd) / N));
  std::cout << "[ stats    ] duplicate fraction " << frac << " (0.3, se " << std::sqrt(pd * (1.0 - pd) / N) << ")\n";
}

TEST(LossyChannel, DuplicateNeedsRoomInTheQueue)
{
  ne::ChannelSettings s = base();
  s.duplicate = 1.0;
  s.delay = 1.0;
  s.queue_limit = 1;
  ne::LossyChannel one(s);
  ne::ChannelRecord ev = one.offer(0, 0.0);
  EXPECT_EQ(ev.outcome, ne::ChannelOutcome::DELIVERED);
  EXPECT_FALSE(ev.duplicated);
  EXPECT_EQ(one.counters().duplicated, 0u);
  EXPECT_EQ(one.counters().in_flight, 1u);
  EXPECT_TRUE(balanced(one.counters()));

  s.queue_limit = 3;
  ne::LossyChannel three(s);
  ev = three.offer(0, 0.0);
  EXPECT_TRUE(ev.duplicated);
  ev = three.offer(1, 0.0);  // room for the original only
  EXPECT_EQ(ev.outcome, ne::ChannelOutcome::DELIVERED);
  EXPECT_FALSE(ev.duplicated);
  EXPECT_EQ(three.offer(2, 0.0).outcome, ne::ChannelOutcome::DROPPED_QUEUE);
  EXPECT_EQ(three.counters().duplicated, 1u);
  EXPECT_EQ(three.counters().in_flight, 3u);
  EXPECT_TRUE(balanced(three.counters()));
  std::vector<ne::Delivery> out;
  ASSERT_EQ(three.popDue(1.0, out), 3u);
  EXPECT_EQ(out[0].seq, 0u);
  EXPECT_FALSE(out[0].duplicate);
  EXPECT_EQ(out[1].seq, 0u);
  EXPECT_TRUE(out[1].duplicate);
  EXPECT_EQ(out[2].seq, 1u);
  EXPECT_TRUE(balanced(three.counters()));
}

TEST(LossyChannel, QueueLimitDropsAndCounts)
{
  ne::ChannelSettings s = base();
  s.delay = 10.0;
  s.queue_limit = 10;
  ne::LossyChannel ch(s);
  for (int i = 0; i < 100; ++i)
  {
    const ne::ChannelRecord ev = ch.offer(i, 0.01 * i);
    ASSERT_EQ(ev.outcome, i < 10 ? ne::ChannelOutcome::DELIVERED : ne::ChannelOutcome::DROPPED_QUEUE);
    ASSERT_EQ(ev.delay, i < 10 ? 10.0 : 0.0);
    ASSERT_TRUE(balanced(ch.counters()));
  }
  EXPECT_EQ(ch.counters().in_flight, 10u);
  EXPECT_EQ(ch.counters().dropped_queue, 90u);
  EXPECT_EQ(ch.counters().dropped_model, 0u);
  EXPECT_DOUBLE_EQ(ch.lossRate(), 0.9);
  EXPECT_DOUBLE_EQ(ch.meanBurstLength(), 90.0);  // one run of 90
  std::vector<ne::Delivery> out;
  EXPECT_EQ(ch.popDue(5.0, out), 0u);
  EXPECT_EQ(ch.popDue(11.0, out), 10u);
  for (int i = 0; i < 10; ++i)
    EXPECT_EQ(out[i].seq, static_cast<std::uint64_t>(i));
  EXPECT_TRUE(balanced(ch.counters()));
  // Room again.
  EXPECT_EQ(ch.offer(100, 11.0).outcome, ne::ChannelOutcome::DELIVERED);
  EXPECT_TRUE(balanced(ch.counters()));
}

// ------------------------------------------------------------------------------------------------
// Loss through the channel

TEST(LossyChannel, GilbertElliottLossRateAndBurstLength)
{
  // Same reasoning as test_loss_model.cpp: with loss_bad = 1, loss_good = 0 the loss indicator is
  // the stationary two-state chain (second eigenvalue lam = 1 - p - r), so
  // Var(sample mean) ~= pi (1 - pi) / N (1 + lam) / (1 - lam), and bursts are geometric(r):
  // mean 1/r, sd sqrt(1 - r) / r, se = sd / sqrt(#bursts).
  const int N = 20000;
  const double p = 0.05, r = 0.4;
  ne::ChannelSettings s = base(505);
  s.model = ne::LossModelKind::GILBERT_ELLIOTT;
  s.p = p;
  s.r = r;
  s.loss_bad = 1.0;
  s.loss_good = 0.0;
  ne::LossyChannel ch(s);
  std::vector<ne::Delivery> out;
  long lost = 0, bursts = 0;
  bool prev = false;
  for (int i = 0; i < N; ++i)
  {
    const ne::ChannelRecord ev = ch.offer(i, 0.001 * i);
    const bool l = ev.outcome == ne::ChannelOutcome::DROPPED_MODEL;
    ASSERT_NE(ev.outcome, ne::ChannelOutcome::DROPPED_QUEUE);
    ASSERT_EQ(ev.state, l ? 1 : 0);
    lost += l;
    bursts += l && !prev;
    prev = l;
    ch.popDue(0.001 * i, out);
    ASSERT_EQ(out.size(), l ? 0u : 1u);
    ASSERT_TRUE(balanced(ch.counters()));
  }
  const double pi = p / (p + r), lam = 1.0 - p - r;
  const double se_rate = std::sqrt(pi * (1.0 - pi) / N * (1.0 + lam) / (1.0 - lam));
  EXPECT_DOUBLE_EQ(ch.lossRate(), static_cast<double>(lost) / N);
  EXPECT_NEAR(ch.lossRate(), pi, 5.0 * se_rate);
  ASSERT_GT(bursts, 500);
  EXPECT_DOUBLE_EQ(ch.meanBurstLength(), static_cast<double>(lost) / bursts);
  const double se_burst = std::sqrt(1.0 - r) / r / std::sqrt(static_cast<double>(bursts));
  EXPECT_NEAR(ch.meanBurstLength(), 1.0 / r, 5.0 * se_burst);
  std::cout << "[ stats    ] gilbert-elliott: loss rate " << ch.lossRate() << " (" << pi << ", se " << se_rate
            << "), mean burst " << ch.meanBurstLength() << " (" << 1.0 / r << ", se " << se_burst << ")\n";
}

TEST(LossyChannel, BernoulliLossRateAndBurstLength)
{
  // Independent Bernoulli(l): se = sqrt(l (1 - l) / N); bursts geometric(1 - l).
  const int N = 20000;
  const double l = 0.2;
  ne::ChannelSettings s = base(606);
  s.loss = l;
  const Trace t = drive(s, N);
  ne::LossyChannel ch(s);
  for (int i = 0; i < N; ++i)
    ASSERT_TRUE(sameEvent(ch.offer(i, t.events[i].arrival), t.events[i]));
  EXPECT_NEAR(ch.lossRate(), l, 5.0 * std::sqrt(l * (1.0 - l) / N));
  const double bursts = ch.counters().dropped_model / ch.meanBurstLength();
  EXPECT_NEAR(ch.meanBurstLength(), 1.0 / (1.0 - l), 5.0 * std::sqrt(l) / (1.0 - l) / std::sqrt(bursts));
}

// ------------------------------------------------------------------------------------------------
// Reproducibility and reconfiguration

namespace
{

ne::ChannelSettings busy(std::uint64_t seed)
{
  ne::ChannelSettings s = base(seed);
  s.model = ne::LossModelKind::GILBERT_ELLIOTT;
  s.p = 0.1;
  s.r = 0.3;
  s.loss_bad = 0.9;
  s.loss_good = 0.05;
  s.delay = 0.02;
  s.jitter = 0.03;
  s.distribution = ne::DelayDistribution::NORMAL;
  s.reorder = true;
  s.duplicate = 0.2;
  s.queue_limit = 12;  // some queue drops, too
  return s;
}

}  // namespace

TEST(LossyChannel, SameSeedSameTraceDifferentSeedDifferent)
{
  const Trace a = drive(busy(9), 3000), b = drive(busy(9), 3000), c = drive(busy(10), 3000);
  int queue_drops = 0;
  for (const ne::ChannelRecord& ev : a.events)
    queue_drops += ev.outcome == ne::ChannelOutcome::DROPPED_QUEUE;
  EXPECT_GT(queue_drops, 0);
  EXPECT_TRUE(sameEvents(a.events, b.events));
  EXPECT_TRUE(sameDeliveries(a.deliveries, b.deliveries));
  EXPECT_FALSE(sameEvents(a.events, c.events));
  EXPECT_FALSE(sameDeliveries(a.deliveries, c.deliveries));
  int outcome_differs = 0;
  for (std::size_t i = 0; i < a.events.size(); ++i)
    outcome_differs += a.events[i].outcome != c.events[i].outcome;
  EXPECT_GT(outcome_differs, 100);
}

TEST(LossyChannel, ReconfiguringJitterKeepsLossAndDuplicateSequences)
{
  ne::ChannelSettings s = busy(9);
  s.queue_limit = 1000000;  // no queue drops: those would depend on the delays
  ne::ChannelSettings s2 = s;
  s2.jitter = 0.2;
  s2.distribution = ne::DelayDistribution::PARETO;
  const Trace plain = drive(s, 3000);
  const Trace changed = drive(s, 3000, 1000, &s2);
  const Trace same = drive(s, 3000, 1000, &s);  // a no-op reconfigure changes nothing at all
  EXPECT_TRUE(sameEvents(plain.events, same.events));
  EXPECT_TRUE(sameDeliveries(plain.deliveries, same.deliveries));
  int delay_differs = 0;
  for (std::size_t i = 0; i < plain.events.size(); ++i)
  {
    const ne::ChannelRecord &a = plain.events[i], &b = changed.events[i];
    ASSERT_EQ(a.outcome, b.outcome) << i;
    ASSERT_EQ(a.state, b.state) << i;
    ASSERT_EQ(a.duplicated, b.duplicated) << i;
    if (i < 1000)
      ASSERT_EQ(a.delay, b.delay) << i;
    else
      delay_differs += a.outcome == ne::ChannelOutcome::DELIVERED && a.delay != b.delay;
  }
  EXPECT_GT(delay_differs, 1000);
}

TEST(LossyChannel, ReconfiguringTheSeedRestartsEveryStream)
{
  ne::ChannelSettings s = busy(9), s2 = busy(77);
  s.queue_limit = s2.queue_limit = 1000000;
  const Trace switched = drive(s, 2000, 700, &s2);
  // A fresh channel with seed 77 offered the same messages (same seqs and times) from 700 on.
  ne::LossyChannel fresh(s2);
  for (std::size_t i = 700; i < switched.events.size(); ++i)
  {
    const ne::ChannelRecord ev = fresh.offer(i, switched.events[i].arrival);
    ASSERT_TRUE(sameEvent(ev, switched.events[i])) << i;
  }
  // Changing the loss parameters without a new seed: a fresh but deterministic loss stream.
  ne::ChannelSettings s3 = s;
  s3.p = 0.2;
  const Trace a = drive(s, 2000, 700, &s3), b = drive(s, 2000, 700, &s3);
  EXPECT_TRUE(sameEvents(a.events, b.events));
  // ... and not a replay of the seed's first loss draws (a fresh channel with s3).
  ne::LossyChannel replay(s3);
  int differs = 0;
  for (std::size_t i = 700; i < a.events.size(); ++i)
    differs += replay.offer(i, a.events[i].arrival).outcome != a.events[i].outcome;
  EXPECT_GT(differs, 100);
}

TEST(LossyChannel, ReconfigureAppliesFromTheNextOffer)
{
  ne::ChannelSettings s = base(3);
  s.delay = 1.0;
  ne::LossyChannel ch(s);
  for (int i = 0; i < 100; ++i)
    ASSERT_EQ(ch.offer(i, 0.001 * i).outcome, ne::ChannelOutcome::DELIVERED);
  ne::ChannelSettings lossy = s;
  lossy.loss = 1.0;
  lossy.queue_limit = 5;  // below in_flight: the schedule is kept as it is
  ch.reconfigure(lossy);
  EXPECT_EQ(ch.counters().in_flight, 100u);
  EXPECT_EQ(ch.counters().received, 100u);
  for (int i = 100; i < 200; ++i)
  {
    ASSERT_EQ(ch.offer(i, 0.001 * i).outcome, ne::ChannelOutcome::DROPPED_MODEL);
    ASSERT_TRUE(balanced(ch.counters()));
  }
  EXPECT_DOUBLE_EQ(ch.lossRate(), 0.5);
  std::vector<ne::Delivery> out;
  ASSERT_EQ(ch.popDue(1.1, out), 100u);
  for (int i = 0; i < 100; ++i)
    ASSERT_EQ(out[i].seq, static_cast<std::uint64_t>(i));
  EXPECT_TRUE(balanced(ch.counters()));

  // Delay 1 -> 0 without reorder: the next message waits behind those still in flight;
  // with reorder it overtakes them.
  ne::LossyChannel d(s);
  d.offer(0, 0.0);  // due 1.0
  ne::ChannelSettings fast = s;
  fast.delay = 0.0;
  d.reconfigure(fast);
  ne::ChannelRecord ev = d.offer(1, 0.25);
  EXPECT_EQ(ev.delay, 0.75);
  EXPECT_EQ(d.popDue(0.5, out), 0u);
  fast.reorder = true;
  d.reconfigure(fast);
  ev = d.offer(2, 0.5);
  EXPECT_EQ(ev.delay, 0.0);
  ASSERT_EQ(d.popDue(0.5, out), 1u);
  EXPECT_EQ(out[0].seq, 2u);
  ASSERT_EQ(d.popDue(1.0, out), 2u);
  EXPECT_EQ(out[0].seq, 0u);
  EXPECT_EQ(out[1].seq, 1u);
  EXPECT_TRUE(balanced(d.counters()));
}

// ------------------------------------------------------------------------------------------------
// Statistics by hand

TEST(LossyChannel, StatisticsOnAHandMadeCase)
{
  // Pattern R(0.4) D D R(0.1) D R(0.3) R(0.2) D D D, made with reconfigure (loss 0 / 1, delay).
  ne::ChannelSettings s = base(1);
  s.reorder = true;
  ne::LossyChannel ch(s);
  EXPECT_TRUE(std::isnan(ch.lossRate()));
  EXPECT_TRUE(std::isnan(ch.meanBurstLength()));
  EXPECT_TRUE(std::isnan(ch.delayQuantile(0.5)));
  const double pattern[] = {0.4, -1, -1, 0.1, -1, 0.3, 0.2, -1, -1, -1};  // -1 = drop
  for (int i = 0; i < 10; ++i)
  {
    ne::ChannelSettings k = s;
    k.loss = pattern[i] < 0 ? 1.0 : 0.0;
    k.delay = pattern[i] < 0 ? 0.0 : pattern[i];
    ch.reconfigure(k);
    const ne::ChannelRecord ev = ch.offer(i, 0.0);
    ASSERT_EQ(ev.outcome, pattern[i] < 0 ? ne::ChannelOutcome::DROPPED_MODEL : ne::ChannelOutcome::DELIVERED);
    if (pattern[i] >= 0)
    {
      ASSERT_EQ(ev.delay, pattern[i]);
    }
    if (i == 2)
    {
      EXPECT_DOUBLE_EQ(ch.meanBurstLength(), 2.0);  // the run in progress counts
    }
    if (i == 4)
    {
      EXPECT_DOUBLE_EQ(ch.meanBurstLength(), 1.5);
    }
  }
  EXPECT_DOUBLE_EQ(ch.lossRate(), 0.6);
  EXPECT_DOUBLE_EQ(ch.meanBurstLength(), 2.0);  // runs 2, 1, 3
  ASSERT_EQ(ch.delaySamples(), 4u);
  // Sorted 0.1 0.2 0.3 0.4; h = 3 q.
  EXPECT_DOUBLE_EQ(ch.delayQuantile(0.0), 0.1);
  EXPECT_DOUBLE_EQ(ch.delayQuantile(1.0), 0.4);
  EXPECT_DOUBLE_EQ(ch.delayQuantile(0.5), 0.25);
  EXPECT_DOUBLE_EQ(ch.delayQuantile(1.0 / 3.0), 0.2);
  EXPECT_DOUBLE_EQ(ch.delayQuantile(0.25), 0.175);
  EXPECT_THROW(ch.delayQuantile(1.5), std::invalid_argument);
  EXPECT_THROW(ch.delayQuantile(std::nan("")), std::invalid_argument);

  const ne::ChannelCounters before = ch.counters();
  ch.clearStatistics();
  EXPECT_TRUE(std::isnan(ch.lossRate()));
  EXPECT_TRUE(std::isnan(ch.meanBurstLength()));
  EXPECT_TRUE(std::isnan(ch.delayQuantile(0.5)));
  EXPECT_EQ(ch.delaySamples(), 0u);
  EXPECT_EQ(ch.counters().received, before.received);
  EXPECT_EQ(ch.counters().dropped_model, before.dropped_model);
  EXPECT_EQ(ch.counters().in_flight, before.in_flight);
  // The run in progress was forgotten: one more drop is a new run of length 1.
  ch.offer(10, 0.0);
  EXPECT_EQ(ch.lossRate(), 1.0);
  EXPECT_EQ(ch.meanBurstLength(), 1.0);
  std::vector<ne::Delivery> out;
  EXPECT_EQ(ch.popAll(out), 4u);
  EXPECT_EQ(out[0].seq, 3u);  // by due: 0.1 (seq 3), 0.2 (6), 0.3 (5), 0.4 (0)
  EXPECT_EQ(out[1].seq, 6u);
  EXPECT_EQ(out[2].seq, 5u);
  EXPECT_EQ(out[3].seq, 0u);
  EXPECT_TRUE(balanced(ch.counters()));
}

TEST(LossyChannel, DelayWindowKeepsTheLast10000)
{
  ne::ChannelSettings s = base();
  s.reorder = true;
  s.delay = 1.0;
  ne::LossyChannel ch(s);
  std::uint64_t seq = 0;
  for (int i = 0; i < 10000; ++i)
    ch.offer(seq++, 0.0);
  s.delay = 2.0;
  ch.reconfigure(s);
  for (int i = 0; i < 5000; ++i)
    ch.offer(seq++, 0.0);
  EXPECT_EQ(ch.delaySamples(), ne::LossyChannel::kDelayWindow);
  EXPECT_EQ(ch.delayQuantile(0.25), 1.0);
  EXPECT_EQ(ch.delayQuantile(0.75), 2.0);
  s.delay = 3.0;
  ch.reconfigure(s);
  for (int i = 0; i < 10000; ++i)
    ch.offer(seq++, 0.0);
  EXPECT_EQ(ch.delayQuantile(0.0), 3.0);
  EXPECT_EQ(ch.delaySamples(), ne::LossyChannel::kDelayWindow);
}

TEST(LossyChannel, RejectsInvalidInput)
{
  ne::ChannelSettings s = base();
  s.jitter = -0.1;
  EXPECT_THROW(ne::LossyChannel{s}, ne::ConfigError);
  s = base();
  s.duplicate = 1.5;
  EXPECT_THROW(ne::LossyChannel{s}, ne::ConfigError);
  s = base();
  s.queue_limit = 0;
  EXPECT_THROW(ne::LossyChannel{s}, ne::ConfigError);
  s = base();
  s.delay = std::numeric_limits<double>::infinity();
  EXPECT_THROW(ne::LossyChannel{s}, ne::ConfigError);

  ne::LossyChannel ch(base());
  ne::ChannelSettings bad = base();
  bad.loss = -0.5;
  EXPECT_THROW(ch.reconfigure(bad), ne::ConfigError);
  EXPECT_EQ(ch.settings().loss, 0.0);  // unchanged
  EXPECT_THROW(ch.offer(0, std::nan("")), ne::InputError);
  EXPECT_EQ(ch.counters().received, 0u);
  EXPECT_EQ(ne::toString(ne::ChannelOutcome::DROPPED_QUEUE), "dropped_queue");
}

// ChannelDeliveries: the payloads come out as the engine's deliveries, in its order, a duplicate's
// twice, a lost message's never, and none is held after its last delivery.
TEST(ChannelDeliveries, PayloadsFollowTheEnginesDeliveries)
{
  ne::ChannelSettings s = base(808);
  s.loss = 0.3;
  s.duplicate = 0.2;
  s.delay = 0.05;
  s.jitter = 0.04;
  s.reorder = true;
  ne::LossyChannel engine(s), reference(s);
  ne::ChannelDeliveries<int> deliveries(engine);
  std::vector<int> out;
  std::vector<std::uint64_t> expected;
  std::vector<ne::Delivery> due;
  long dropped = 0, duplicated = 0;
  for (int i = 0; i < 2000; ++i)
  {
    const double t = 0.01 * i;
    const ne::ChannelRecord rec = deliveries.offer(t, 1000 + i);  // payload: 1000 + seq
    EXPECT_EQ(rec.seq, static_cast<std::uint64_t>(i));
    reference.offer(static_cast<std::uint64_t>(i), t);
    dropped += rec.outcome != ne::ChannelOutcome::DELIVERED;
    duplicated += rec.duplicated;
    deliveries.popDue(t, out);
    reference.popDue(t, due);
    for (const ne::Delivery& d : due)
      expected.push_back(d.seq);
  }
  EXPECT_GT(deliveries.held(), 0u);  // delayed ones still in flight
  deliveries.popDue(1e9, out);
  reference.popDue(1e9, due);
  for (const ne::Delivery& d : due)
    expected.push_back(d.seq);
  EXPECT_EQ(deliveries.held(), 0u);
  ASSERT_EQ(out.size(), expected.size());
  for (std::size_t k = 0; k < out.size(); ++k)
    ASSERT_EQ(out[k], 1000 + static_cast<int>(expected[k])) << k;
  EXPECT_EQ(static_cast<long>(out.size()), 2000 - dropped + duplicated);
  EXPECT_GT(dropped, 0);
  EXPECT_GT(duplicated, 0);
}
