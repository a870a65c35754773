// LatencyBudget: the budget follows the delays the sensors show (within its bounds), a fixed one
// does not, and the losses to lateness are counted per sensor over the last 10 s.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "networked_estimation/common/random.hpp"
#include "networked_estimation/online/latency_budget.hpp"

namespace ne = networked_estimation;

namespace
{

ne::LatencyOptions adaptive(double min, double max, double period)
{
  ne::LatencyOptions o;
  o.adaptive = true;
  o.min = min;
  o.max = max;
  o.period = period;
  return o;
}

/// A delay of 5 ms plus an exponential tail of mean 8 ms (a loaded machine's scheduling).
double delay(ne::Rng& rng)
{
  return 0.005 - 0.008 * std::log(1.0 - rng.uniform());
}

}  // namespace

// Adaptive: after a window of delays the budget covers them: of 100000 further delays from the
// same distribution fewer than 1 % reach it. (Its quantile is the 99th of 256 samples plus a margin
// of half a period and half the quantile; the exponential tail beyond q99 + 0.5 q99 + 10 ms holds
// about e^{-(0.5 q99 + 10 ms) / 8 ms} x 1 % < 0.03 %, so < 1 % holds with a wide margin even
// for an unlucky window.)
TEST(LatencyBudget, AdaptiveCoversTheDelaysSeen)
{
  ne::Rng rng(17);
  ne::LatencyBudget b(2, adaptive(0.01, 1.0, 0.02));
  EXPECT_DOUBLE_EQ(b.budget(), 0.01);  // no delays yet: the minimum
  EXPECT_TRUE(std::isnan(b.delay(0)));
  for (int i = 0; i < 1000; ++i)
    b.arrived(0, delay(rng), 100.0 + 0.02 * i);
  const double budget = b.budget();
  EXPECT_GT(budget, 0.04);  // well above the minimum: the delays' 99th percentile is about 42 ms
  EXPECT_LT(budget, 0.2);
  long late = 0;
  for (int i = 0; i < 100000; ++i)
    late += delay(rng) >= budget ? 1 : 0;
  EXPECT_LT(late, 1000) << "budget " << budget;
  // The other sensor, which shows nothing, does not change it; a slower one raises it.
  for (int i = 0; i < 300; ++i)
    b.arrived(1, 0.2 + 0.001 * (i % 7), 130.0 + 0.02 * i);
  EXPECT_NEAR(b.delay(1), 0.206, 1e-12);
  EXPECT_NEAR(b.budget(), 0.206 + 0.01 + 0.5 * 0.206, 1e-12);
}

// The window's quantile is its nearest-rank 99th percentile, never its largest of two or more: at
// every arrival, from the first to well past the 256 the window holds, the value of a full sort.
TEST(LatencyBudget, TheQuantileIsTheWindowsNearestRank)
{
  ne::Rng rng(5);
  ne::LatencyBudget b(1, adaptive(0.01, 1.0, 0.02));
  std::vector<double> all;
  for (int i = 0; i < 700; ++i)
  {
    all.push_back(delay(rng));
    b.arrived(0, all.back(), 100.0 + 0.02 * i);
    std::vector<double> window(all.end() - std::min<std::ptrdiff_t>(all.size(), ne::LatencyBudget::kWindow), all.end());
    std::sort(window.begin(), window.end());
    const std::size_t n = window.size();
    const std::size_t rank =
        n < 2 ? 0 : std::min(n - 2, static_cast<std::size_t>(std::ceil(ne::LatencyBudget::kQuantile * n)) - 1);
    ASSERT_EQ(b.delay(0), window[rank]) << "after " << n << " delays";
  }
}

// The bounds hold, and a fixed budget ignores the delays.
TEST(LatencyBudget, BoundsAndFixed)
{
  ne::LatencyBudget b(1, adaptive(0.05, 0.3, 0.02));
  b.arrived(0, 0.001, 1.0);
  EXPECT_DOUBLE_EQ(b.budget(), 0.05);
  for (int i = 0; i < 10; ++i)
    b.arrived(0, 2.0, 1.0);
  EXPECT_DOUBLE_EQ(b.budget(), 0.3);
  ne::LatencyOptions fixed;
  fixed.adaptive = false;
  fixed.fixed = 0.123;
  b.setOptions(fixed);
  EXPECT_DOUBLE_EQ(b.budget(), 0.123);
  b.arrived(0, 5.0, 2.0);
  EXPECT_DOUBLE_EQ(b.budget(), 0.123);
  b.setOptions(adaptive(0.0, 10.0, 0.02));  // the delays seen so far count again, but not the single 5 s
  EXPECT_DOUBLE_EQ(b.budget(), 2.0 + 0.01 + 1.0);
  b.clear();
  EXPECT_DOUBLE_EQ(b.budget(), 0.0);
}

// The window: messages and losses per sensor over the last 10 s of ROS time, older ones forgotten.
TEST(LatencyBudget, LossesOverTheLastTenSeconds)
{
  ne::LatencyBudget b(2, adaptive(0.01, 1.0, 0.02));
  for (int i = 0; i < 500; ++i)  // 50 Hz over 10 s: 2 % lost
  {
    const double now = 1000.0 + 0.02 * i;
    b.arrived(0, 0.001, now);
    if (i % 50 == 0)
      b.lost(0, now);
  }
  b.refused(1, 1005.0);
  ne::LatencyBudget::Window w = b.window(0, 1009.99);
  EXPECT_EQ(w.received, 500u);
  EXPECT_EQ(w.lost, 10u);
  EXPECT_DOUBLE_EQ(w.fraction(), 0.02);
  w = b.window(1, 1009.99);
  EXPECT_EQ(w.received, 1u);
  EXPECT_EQ(w.lost, 1u);
  // 5 s later half of them have left the window; 10 s later all.
  w = b.window(0, 1014.99);
  EXPECT_EQ(w.received, 250u);
  EXPECT_EQ(w.lost, 5u);
  EXPECT_EQ(b.window(0, 1020.5).received, 0u);
  EXPECT_EQ(b.window(1, 1020.5).received, 0u);
}

// One stray delay does not move the budget (the quantile never takes a window's largest), and at
// the start a sensor not heard from yet counts with the maximum for 2 s.
TEST(LatencyBudget, OneStrayDelayAndTheStartUp)
{
  ne::LatencyBudget b(2, adaptive(0.01, 1.0, 0.02));
  b.arrived(0, 0.002, 10.0);
  b.arrived(0, 2.5, 10.02);  // a stray message
  b.arrived(0, 0.003, 10.04);
  EXPECT_DOUBLE_EQ(b.delay(0), 0.003);
  EXPECT_DOUBLE_EQ(b.budget(), 0.003 + 0.01 + 0.5 * 0.003);
  b.start(20.0);
  EXPECT_DOUBLE_EQ(b.budget(), 1.0);  // sensor 1 not heard from
  b.at(21.9);
  EXPECT_DOUBLE_EQ(b.budget(), 1.0);
  b.arrived(1, 0.03, 21.95);
  EXPECT_DOUBLE_EQ(b.budget(), 0.03 + 0.01 + 0.015);
  b.start(30.0);
  b.clear();
  b.start(30.0);
  b.arrived(0, 0.001, 30.0);
  EXPECT_DOUBLE_EQ(b.budget(), 1.0);
  b.at(32.0);  // the start-up is over: sensor 1, still silent, no longer counts
  EXPECT_DOUBLE_EQ(b.budget(), 0.001 + 0.01 + 0.5 * 0.001);
}
