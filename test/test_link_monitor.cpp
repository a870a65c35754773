// LinkMonitor (link_monitor.hpp): windowed counts, Wilson intervals and the classification.
#include <gtest/gtest.h>

#include <cmath>

#include "networked_estimation/stability/link_monitor.hpp"
#include "networked_estimation/common/random.hpp"

using namespace networked_estimation;

TEST(LinkMonitor, CountsMatchBruteForceOverTheWindow)
{
  Rng rng(5);
  const std::size_t w = 37;
  LinkMonitor mon(w);
  std::vector<bool> all;
  for (int k = 0; k < 500; ++k)
  {
    const bool a = rng.bernoulli(0.6);
    all.push_back(a);
    mon.add(a);
    const std::size_t n = std::min<std::size_t>(all.size(), w);
    std::size_t arr = 0, lost = 0, rec = 0;
    for (std::size_t i = all.size() - n; i < all.size(); ++i)
    {
      arr += all[i] ? 1 : 0;
      if (i > all.size() - n && !all[i - 1])
      {
        ++lost;
        rec += all[i] ? 1 : 0;
      }
    }
    ASSERT_EQ(mon.samples(), n);
    ASSERT_EQ(mon.arrivals(), arr) << k;
    ASSERT_EQ(mon.lossTransitions(), lost) << k;
    ASSERT_EQ(mon.recoveries(), rec) << k;
  }
  EXPECT_EQ(mon.total(), 500u);
  mon.clear();
  EXPECT_EQ(mon.samples(), 0u);
  EXPECT_THROW(LinkMonitor(1), std::invalid_argument);
}

TEST(LinkMonitor, WilsonInterval)
{
  // Textbook value: 8 of 10, z = 1.96 -> [0.4902, 0.9433].
  const RateEstimate e = wilsonInterval(8, 10, 1.96);
  EXPECT_NEAR(e.lower, 0.4902, 1e-4);
  EXPECT_NEAR(e.upper, 0.9433, 1e-4);
  EXPECT_TRUE(std::isnan(wilsonInterval(0, 0).value));
  EXPECT_EQ(wilsonInterval(0, 50).lower, 0.0);
}

TEST(LinkMonitor, CoverageOnMarkovChain)
{
  // Gilbert chain with recovery r = 0.4, failure p = 0.1: the stationary arrival rate is 0.8 and the
  // recovery rate 0.4. Over 200 disjoint windows of 2000 samples, a 95 % interval should miss the
  // true value in about 5 % of the windows; the arrival count is positively correlated (bursts), so
  // the nominal interval under-covers: the lag-1 correlation is 1 - p - r = 0.5, which inflates the
  // variance of the mean by (1 + 0.5) / (1 - 0.5) = 3, so the interval spans +-1.96 / sqrt(3) = +-1.13
  // true standard deviations: coverage about 74 %. We require >= 120 of 200 windows (the binomial
  // standard deviation is 6.2, so 120 is 5.8 sd below). The recovery transitions are i.i.d. given that
  // the previous sample was lost (Markov property): nominal 95 % coverage; we require >= 170 (85 %,
  // 6.5 binomial sd below 190).
  Rng rng(11);
  bool arrived = true;
  int cover_a = 0, cover_r = 0;
  for (int win = 0; win < 200; ++win)
  {
    LinkMonitor mon(2000);
    for (int k = 0; k < 2000; ++k)
    {
      arrived = arrived ? !rng.bernoulli(0.1) : rng.bernoulli(0.4);
      mon.add(arrived);
    }
    const RateEstimate a = mon.arrivalRate(), r = mon.recoveryRate();
    cover_a += (a.lower <= 0.8 && 0.8 <= a.upper) ? 1 : 0;
    cover_r += (r.lower <= 0.4 && 0.4 <= r.upper) ? 1 : 0;
  }
  EXPECT_GE(cover_a, 120);
  EXPECT_GE(cover_r, 170);
}

TEST(LinkMonitor, Classification)
{
  LinkThresholds t;
  t.necessary = 0.36;
  t.sufficient = 0.5;
  t.min_samples = 100;
  RateEstimate e = wilsonInterval(310, 1000);  // [0.282, 0.339] < 0.36
  LinkStatus s = classifyLink(e, t);
  EXPECT_EQ(s.level, LinkStatus::Level::ERROR);
  EXPECT_NE(s.message.find("unbounded"), std::string::npos);
  EXPECT_NE(s.message.find("0.31 < critical 0.36"), std::string::npos) << s.message;
  EXPECT_EQ(classifyLink(wilsonInterval(700, 1000), t).level, LinkStatus::Level::OK);
  const LinkStatus band = classifyLink(wilsonInterval(430, 1000), t);  // [0.399, 0.461]
  EXPECT_EQ(band.level, LinkStatus::Level::WARN);
  EXPECT_NE(band.message.find("undecided"), std::string::npos);
  const LinkStatus straddle = classifyLink(wilsonInterval(36, 100), t);
  EXPECT_EQ(straddle.level, LinkStatus::Level::WARN);
  EXPECT_NE(straddle.message.find("close"), std::string::npos);
  const LinkStatus few = classifyLink(wilsonInterval(1, 10), t);
  EXPECT_EQ(few.level, LinkStatus::Level::WARN);
  EXPECT_NE(few.message.find("not enough samples"), std::string::npos);
}
