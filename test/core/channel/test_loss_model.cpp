// Tests of the packet loss models (loss_model.hpp). Every statistical tolerance is a multiple (5)
// of a standard error derived from the sample size; all seeds are fixed, so the tests are
// deterministic, and a 5-sigma bound is loose enough not to be tuned to the seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/config/channel_settings.hpp"

namespace ne = networked_estimation;

namespace
{

/// Summary of a run of n messages.
struct RunStats
{
  long n = 0;
  long lost = 0;
  long bursts = 0;  ///< maximal runs of consecutive losses
  double lossRate() const { return static_cast<double>(lost) / static_cast<double>(n); }
  double meanBurst() const { return static_cast<double>(lost) / static_cast<double>(bursts); }
};

RunStats run(ne::LossModel& model, long n)
{
  RunStats s;
  s.n = n;
  bool prev_lost = false;
  for (long i = 0; i < n; ++i)
  {
    const bool lost = model.nextLost();
    if (lost)
    {
      ++s.lost;
      if (!prev_lost)
        ++s.bursts;
    }
    prev_lost = lost;
  }
  return s;
}

std::vector<bool> sequence(ne::LossModel& model, long n)
{
  std::vector<bool> out(static_cast<std::size_t>(n));
  for (long i = 0; i < n; ++i)
    out[static_cast<std::size_t>(i)] = model.nextLost();
  return out;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// Bernoulli

TEST(BernoulliLoss, EmpiricalRateAndBurstLength)
{
  const long N = 200000;
  for (const double loss : {0.05, 0.2, 0.5})
  {
    ne::BernoulliLoss model(loss, 1234);
    const RunStats s = run(model, N);
    // Independent Bernoulli(loss) draws: se of the sample mean = sqrt(loss (1 - loss) / N).
    const double se_rate = std::sqrt(loss * (1.0 - loss) / N);
    EXPECT_NEAR(s.lossRate(), loss, 5.0 * se_rate) << "loss " << loss;
    EXPECT_DOUBLE_EQ(model.stationaryLossRate(), loss);
    // Bursts are iid geometric on {1, 2, ...} with success probability 1 - loss:
    // mean 1 / (1 - loss), std sqrt(loss) / (1 - loss); se = std / sqrt(#bursts).
    const double mean_burst = 1.0 / (1.0 - loss);
    EXPECT_DOUBLE_EQ(model.stationaryMeanBurstLength(), mean_burst);
    ASSERT_GT(s.bursts, 1000);
    const double se_burst = std::sqrt(loss) / (1.0 - loss) / std::sqrt(static_cast<double>(s.bursts));
    EXPECT_NEAR(s.meanBurst(), mean_burst, 5.0 * se_burst) << "loss " << loss;
  }
}

TEST(BernoulliLoss, EdgeCases)
{
  ne::BernoulliLoss never(0.0, 5);
  ne::BernoulliLoss always(1.0, 5);
  for (int i = 0; i < 10000; ++i)
  {
    ASSERT_FALSE(never.nextLost());
    ASSERT_TRUE(always.nextLost());
    ASSERT_EQ(always.state(), 0);
  }
  EXPECT_EQ(never.stationaryLossRate(), 0.0);
  EXPECT_TRUE(std::isnan(never.stationaryMeanBurstLength()));
  EXPECT_EQ(always.stationaryLossRate(), 1.0);
  EXPECT_TRUE(std::isinf(always.stationaryMeanBurstLength()));
  EXPECT_GT(always.stationaryMeanBurstLength(), 0.0);
}

TEST(BernoulliLoss, Reproducibility)
{
  ne::BernoulliLoss a(0.3, 99), b(0.3, 99), c(0.3, 100);
  const std::vector<bool> sa = sequence(a, 10000);
  EXPECT_EQ(sa, sequence(b, 10000));
  EXPECT_NE(sa, sequence(c, 10000));
  a.reseed(99);
  EXPECT_EQ(sa, sequence(a, 10000));
}

// ------------------------------------------------------------------------------------------------
// Gilbert-Elliott

TEST(GilbertElliottLoss, PureMarkovRateAndBurstLength)
{
  const long N = 200000;
  struct Case
  {
    double p, r;
  };
  for (const Case c : {Case{0.05, 0.4}, Case{0.3, 0.1}})
  {
    ne::GilbertElliottLoss model(c.p, c.r, 1.0, 0.0, 777);
    const double pi = c.p / (c.p + c.r);
    EXPECT_DOUBLE_EQ(model.stationaryBadProbability(), pi);
    EXPECT_DOUBLE_EQ(model.stationaryLossRate(), pi);
    EXPECT_NEAR(model.stationaryMeanBurstLength(), 1.0 / c.r, 1e-12);

    RunStats s;
    s.n = N;
    bool prev = false;
    for (long i = 0; i < N; ++i)
    {
      const bool lost = model.nextLost();
      // With loss_bad = 1 and loss_good = 0 the loss indicator is the state itself.
      ASSERT_EQ(model.state(), lost ? 1 : 0);
      s.lost += lost;
      s.bursts += lost && !prev;
      prev = lost;
    }
    // Sample mean of a stationary two-state chain with second eigenvalue lam = 1 - p - r:
    // Var ~= pi (1 - pi) / N * (1 + lam) / (1 - lam) (lag-h autocorrelation lam^h summed).
    const double lam = 1.0 - c.p - c.r;
    const double se_rate = std::sqrt(pi * (1.0 - pi) / N * (1.0 + lam) / (1.0 - lam));
    EXPECT_NEAR(s.lossRate(), pi, 5.0 * se_rate) << "p " << c.p << " r " << c.r;
    // Each burst ends independently with probability r per message: geometric(r), mean 1/r,
    // std sqrt(1 - r) / r; se = std / sqrt(#bursts).
    ASSERT_GT(s.bursts, 1000);
    const double se_burst = std::sqrt(1.0 - c.r) / c.r / std::sqrt(static_cast<double>(s.bursts));
    EXPECT_NEAR(s.meanBurst(), 1.0 / c.r, 5.0 * se_burst) << "p " << c.p << " r " << c.r;
  }
}

TEST(GilbertElliottLoss, GeneralCaseRateAndBurstFormula)
{
  const double p = 0.05, r = 0.4, lb = 0.8, lg = 0.02;
  ne::GilbertElliottLoss model(p, r, lb, lg, 4242);
  const double pi = p / (p + r);
  const double rho = pi * lb + (1.0 - pi) * lg;
  EXPECT_NEAR(model.stationaryLossRate(), rho, 1e-15);
  // Exact value by hand: P(recv, then lost) = sum_s,s' pi_s (1 - l_s) T(s, s') l_s'.
  const double start =
      (1.0 - pi) * (1.0 - lg) * ((1.0 - p) * lg + p * lb) + pi * (1.0 - lb) * (r * lg + (1.0 - r) * lb);
  EXPECT_NEAR(model.stationaryMeanBurstLength(), rho / start, 1e-12);
  EXPECT_NEAR(model.stationaryMeanBurstLength(), 1.7137, 1e-3);  // 0.10667 / 0.06224

  // Batches: the chain forgets its state in a few messages (lam = 0.55), so batches of 10000
  // messages are practically independent and give data-driven standard errors.
  const int batches = 40;
  const long per_batch = 10000;
  std::vector<double> lost_b(batches, 0.0), bursts_b(batches, 0.0);
  bool prev = false;
  for (int b = 0; b < batches; ++b)
    for (long i = 0; i < per_batch; ++i)
    {
      const bool lost = model.nextLost();
      lost_b[b] += lost;
      bursts_b[b] += lost && !prev;
      prev = lost;
    }
  double lost = 0.0, bursts = 0.0;
  for (int b = 0; b < batches; ++b)
  {
    lost += lost_b[b];
    bursts += bursts_b[b];
  }
  const double N = static_cast<double>(batches * per_batch);

  // Loss rate. L_k = Bernoulli(l(S_k)) given the state, so Cov(L_0, L_h) = (lb - lg)^2 *
  // pi (1 - pi) lam^h for h >= 1 and Var(L) = rho (1 - rho): the exact asymptotic variance of the
  // sample mean is [rho (1 - rho) + 2 (lb - lg)^2 pi (1 - pi) lam / (1 - lam)] / N.
  const double lam = 1.0 - p - r;
  const double excess = 2.0 * (lb - lg) * (lb - lg) * pi * (1.0 - pi) * lam / (1.0 - lam);
  const double se_rate = std::sqrt((rho * (1.0 - rho) + excess) / N);
  EXPECT_NEAR(lost / N, rho, 5.0 * se_rate);

  // Mean burst = ratio estimator lost / bursts; its se from the batch residuals
  // d_b = lost_b - R bursts_b (delta method): se = sqrt(B / (B - 1) * sum d_b^2) / bursts.
  const double R = lost / bursts;
  double ss = 0.0;
  for (int b = 0; b < batches; ++b)
  {
    const double d = lost_b[b] - R * bursts_b[b];
    ss += d * d;
  }
  const double se_burst = std::sqrt(ss * batches / (batches - 1.0)) / bursts;
  EXPECT_NEAR(R, model.stationaryMeanBurstLength(), 5.0 * se_burst);
  // The naive geometric formula 1 / (1 - P(lost | bad)) = 5 would be far off: the formula matters.
  EXPECT_GT(std::abs(R - 1.0 / (1.0 - lb)), 50.0 * se_burst);
}

TEST(GilbertElliottLoss, EqualLossProbabilitiesIsBernoulli)
{
  // loss_bad = loss_good = l: the state is irrelevant, the stream is Bernoulli(l).
  ne::GilbertElliottLoss model(0.2, 0.3, 0.4, 0.4, 1);
  EXPECT_NEAR(model.stationaryLossRate(), 0.4, 1e-15);
  EXPECT_NEAR(model.stationaryMeanBurstLength(), 1.0 / 0.6, 1e-12);
}

TEST(GilbertElliottLoss, StartsInStationaryLaw)
{
  // Over M independently seeded models the first outcome is Bernoulli(rho) if the chain starts in
  // its stationary law: se = sqrt(rho (1 - rho) / M). Starting always in "good" would give 0 or
  // loss_good, many se away.
  const int M = 20000;
  struct Case
  {
    double p, r, lb, lg;
  };
  for (const Case c : {Case{0.3, 0.1, 1.0, 0.0}, Case{0.05, 0.4, 0.8, 0.02}})
  {
    int first_lost = 0, first_bad = 0;
    for (int s = 0; s < M; ++s)
    {
      ne::GilbertElliottLoss model(c.p, c.r, c.lb, c.lg, static_cast<std::uint64_t>(s) * 7919 + 3);
      first_lost += model.nextLost();
      first_bad += model.state();
    }
    const double rho = c.p / (c.p + c.r) * c.lb + c.r / (c.p + c.r) * c.lg;
    const double pi = c.p / (c.p + c.r);
    EXPECT_NEAR(static_cast<double>(first_lost) / M, rho, 5.0 * std::sqrt(rho * (1.0 - rho) / M));
    EXPECT_NEAR(static_cast<double>(first_bad) / M, pi, 5.0 * std::sqrt(pi * (1.0 - pi) / M));
  }
}

TEST(GilbertElliottLoss, Reproducibility)
{
  ne::GilbertElliottLoss a(0.1, 0.3, 0.9, 0.05, 11), b(0.1, 0.3, 0.9, 0.05, 11), c(0.1, 0.3, 0.9, 0.05, 12);
  const std::vector<bool> sa = sequence(a, 10000);
  EXPECT_EQ(sa, sequence(b, 10000));
  EXPECT_NE(sa, sequence(c, 10000));
  a.reseed(11);
  EXPECT_EQ(sa, sequence(a, 10000));
  // Reseeding mid-sequence restarts, too (including the initial state draw).
  ne::GilbertElliottLoss d(0.1, 0.3, 0.9, 0.05, 11);
  sequence(d, 123);
  d.reseed(11);
  EXPECT_EQ(sa, sequence(d, 10000));
}

TEST(GilbertElliottLoss, EdgeCases)
{
  // p = 0: stays good forever (pi_bad = 0, start good).
  ne::GilbertElliottLoss stay_good(0.0, 0.5, 1.0, 0.0, 3);
  // p = r = 0: p + r = 0 -> start good, stay good.
  ne::GilbertElliottLoss frozen(0.0, 0.0, 1.0, 0.0, 3);
  // r = 0, p > 0: pi_bad = 1 -> starts bad and stays bad; every message lost.
  ne::GilbertElliottLoss stay_bad(0.2, 0.0, 1.0, 0.0, 3);
  for (int i = 0; i < 10000; ++i)
  {
    ASSERT_FALSE(stay_good.nextLost());
    ASSERT_EQ(stay_good.state(), 0);
    ASSERT_FALSE(frozen.nextLost());
    ASSERT_EQ(frozen.state(), 0);
    ASSERT_TRUE(stay_bad.nextLost());
    ASSERT_EQ(stay_bad.state(), 1);
  }
  EXPECT_EQ(stay_good.stationaryBadProbability(), 0.0);
  EXPECT_EQ(stay_good.stationaryLossRate(), 0.0);
  EXPECT_TRUE(std::isnan(stay_good.stationaryMeanBurstLength()));
  EXPECT_EQ(frozen.stationaryBadProbability(), 0.0);
  EXPECT_TRUE(std::isnan(frozen.stationaryMeanBurstLength()));
  EXPECT_EQ(stay_bad.stationaryBadProbability(), 1.0);
  EXPECT_EQ(stay_bad.stationaryLossRate(), 1.0);
  EXPECT_TRUE(std::isinf(stay_bad.stationaryMeanBurstLength()));

  // Always lost in both states: infinite bursts.
  ne::GilbertElliottLoss all(0.3, 0.3, 1.0, 1.0, 3);
  for (int i = 0; i < 1000; ++i)
    ASSERT_TRUE(all.nextLost());
  EXPECT_EQ(all.stationaryLossRate(), 1.0);
  EXPECT_TRUE(std::isinf(all.stationaryMeanBurstLength()));
}

// ------------------------------------------------------------------------------------------------
// makeLossModel

TEST(MakeLossModel, BuildsTheConfiguredModelWithTheGivenSeed)
{
  ne::ChannelSettings bs;
  bs.model = ne::LossModelKind::BERNOULLI;
  bs.loss = 0.25;
  bs.seed = 1;  // ignored: the caller's seed is used
  std::unique_ptr<ne::LossModel> b = ne::makeLossModel(bs, 55);
  ASSERT_NE(dynamic_cast<ne::BernoulliLoss*>(b.get()), nullptr);
  EXPECT_DOUBLE_EQ(b->stationaryLossRate(), 0.25);
  ne::BernoulliLoss b_ref(0.25, 55);
  EXPECT_EQ(sequence(*b, 5000), sequence(b_ref, 5000));

  ne::ChannelSettings gs;
  gs.model = ne::LossModelKind::GILBERT_ELLIOTT;
  gs.p = 0.05;
  gs.r = 0.4;
  gs.loss_bad = 0.8;
  gs.loss_good = 0.02;
  gs.loss = 0.9;  // bernoulli key: ignored
  gs.seed = 1;
  std::unique_ptr<ne::LossModel> g = ne::makeLossModel(gs, 66);
  auto* ge = dynamic_cast<ne::GilbertElliottLoss*>(g.get());
  ASSERT_NE(ge, nullptr);
  EXPECT_DOUBLE_EQ(ge->stationaryBadProbability(), 0.05 / 0.45);
  ne::GilbertElliottLoss g_ref(0.05, 0.4, 0.8, 0.02, 66);
  EXPECT_EQ(g->stationaryLossRate(), g_ref.stationaryLossRate());
  EXPECT_EQ(sequence(*g, 5000), sequence(g_ref, 5000));
  ne::GilbertElliottLoss g_other(0.05, 0.4, 0.8, 0.02, 1);
  g->reseed(66);
  EXPECT_NE(sequence(*g, 5000), sequence(g_other, 5000));
}
