// SensorLattice: a sensor's phase and rate learnt from jittered stamps with dropouts; warnings only
// for a real mismatch. Seeds are fixed; the jitter is uniform +-20 % of the sensor's period, the
// bound the lattice promises to tolerate.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "networked_estimation/common/random.hpp"
#include "networked_estimation/online/sensor_lattice.hpp"

namespace ne = networked_estimation;

namespace
{

struct Fed
{
  std::vector<long> steps;      ///< the step of each sample that was sent
  std::vector<long> index;      ///< its lattice index j
  std::vector<double> nominal;  ///< its jitter-free position
};

/// Samples j = 0, 1, ... at position phase + j * spacing + jitter (uniform +-`jitter` of the
/// spacing), each lost with probability `loss`; every sent sample is fitted and learnt.
Fed feed(ne::SensorLattice& l, double phase, double spacing, double jitter, double loss, int n, std::uint64_t seed)
{
  ne::Rng rng(seed);
  Fed r;
  for (int j = 0; j < n; ++j)
  {
    const double u = phase + j * spacing + rng.uniform(-jitter, jitter) * spacing;
    if (j > 0 && rng.bernoulli(loss))
      continue;
    const ne::SensorLattice::Fit f = l.fit(u);
    l.learn(u, f);
    r.steps.push_back(f.step);
    r.index.push_back(j);
    r.nominal.push_back(phase + j * spacing);
  }
  return r;
}

}  // namespace

// A 10 Hz sensor in a 30 Hz model (spacing 3), its stamps near the middle between two steps
// (phase 0.47 step), +-20 % jitter (+-0.6 step) and 30 % dropouts: every sample fits, the sent
// samples land exactly 3 steps per lattice index apart (no step doubled, none skipped), within
// 1.1 step of their jitter-free time, the sensor is due exactly at those steps, and nothing warns.
TEST(SensorLattice, JitterAndDropoutsKeepTheSensorOnItsSteps)
{
  ne::SensorLattice l(3.0);
  EXPECT_FALSE(l.due(5));  // before its first sample a slower sensor is not due
  const Fed r = feed(l, 100.47, 3.0, 0.2, 0.3, 3000, 7);
  ASSERT_GT(r.steps.size(), 2000u);
  EXPECT_EQ(l.offLattice(), 0u);
  EXPECT_EQ(l.relearnt(), 0u);
  for (std::size_t i = 1; i < r.steps.size(); ++i)
  {
    ASSERT_EQ(r.steps[i] - r.steps[0], 3 * (r.index[i] - r.index[0])) << "sample " << i;
    ASSERT_LE(std::fabs(static_cast<double>(r.steps[i]) - r.nominal[i]), 1.1) << "sample " << i;
  }
  const long last = r.steps.back();
  for (long k = last - 30; k <= last + 30; ++k)
    EXPECT_EQ(l.due(k), (k - last) % 3 == 0) << k;
  std::string why;
  EXPECT_FALSE(l.mismatch(1.0 / 30.0, &why)) << why;
  EXPECT_NEAR(l.spacing(), 3.0, 0.05);
}

// At the model's rate, stamps half a step off the grid with +-20 % jitter: the nearest step would
// put two samples into one step and none into the next about every other sample; the lattice
// puts each sample into its own step, one after the other.
TEST(SensorLattice, SameRateNearHalfAStepNeverDoublesAStep)
{
  ne::SensorLattice l(1.0);
  EXPECT_TRUE(l.due(3));  // a sensor at the model's rate is due at every step, from the start
  const Fed r = feed(l, 50.5, 1.0, 0.2, 0.1, 5000, 11);
  std::map<long, int> per_step;
  long nearest_doubles = 0;
  std::map<long, int> nearest;
  for (std::size_t i = 0; i < r.steps.size(); ++i)
  {
    ++per_step[r.steps[i]];
    ASSERT_EQ(r.steps[i] - r.steps[0], r.index[i] - r.index[0]) << "sample " << i;
  }
  for (const auto& kv : per_step)
    EXPECT_EQ(kv.second, 1) << "step " << kv.first;
  // The same stamps by the nearest step (what the lattice replaces) do double steps.
  ne::Rng rng(11);
  for (int j = 0; j < 5000; ++j)
  {
    const double u = 50.5 + j + rng.uniform(-0.2, 0.2);
    if (j > 0 && rng.bernoulli(0.1))
      continue;
    nearest_doubles += ++nearest[std::lround(u)] == 2 ? 1 : 0;
  }
  EXPECT_GT(nearest_doubles, 500);
  EXPECT_EQ(l.offLattice(), 0u);
}

// A sensor slightly slower than its configured rate (9.996 Hz configured as 10 Hz in a 30 Hz model:
// spacing 3.0012): the lattice follows it without a warning, and its steps move by one step only
// where the drift has accumulated (about 0.0012 step per sample: 6 moves in 5000 samples).
TEST(SensorLattice, ASlightlyDifferentRateIsFollowedQuietly)
{
  ne::SensorLattice l(3.0);
  const Fed r = feed(l, 10.2, 3.0012, 0.2, 0.0, 5000, 3);
  EXPECT_EQ(l.offLattice(), 0u);
  long moves = 0;
  for (std::size_t i = 1; i < r.steps.size(); ++i)
  {
    const long gap = r.steps[i] - r.steps[i - 1];
    ASSERT_TRUE(gap == 3 || gap == 4) << "sample " << i << ": gap " << gap;
    moves += gap == 4 ? 1 : 0;
  }
  EXPECT_GE(moves, 5);
  EXPECT_LE(moves, 7);
  // The loop's spacing estimate under this jitter has a standard deviation of 0.0022 (200 seeds,
  // largest 0.0057): within 0.011 is five standard deviations.
  EXPECT_NEAR(l.spacing(), 3.0012, 0.011);
  std::string why;
  EXPECT_FALSE(l.mismatch(1.0 / 30.0, &why)) << why;
}

// A real mismatch: configured 10 Hz in a 30 Hz model, but the sensor sends at 20 Hz (every other
// sample half a spacing off the lattice) or at 13 Hz (off it most of the time). mismatch() says so
// with the numbers; a sensor at 5 Hz looks like one losing every other sample, which the arrival
// rate shows, not a rate warning.
TEST(SensorLattice, ARealMismatchIsReported)
{
  const double period = 1.0 / 30.0;
  std::string why;
  ne::SensorLattice fast(3.0);
  feed(fast, 0.3, 1.5, 0.02, 0.0, 200, 5);
  ASSERT_TRUE(fast.mismatch(period, &why));
  EXPECT_NE(why.find("of its last 20 samples are off its 10 Hz sample times: its stamps say 20"), std::string::npos)
      << why;
  EXPECT_GT(fast.offLattice(), 50u);
  ne::SensorLattice odd(3.0);
  feed(odd, 0.3, 30.0 / 13.0, 0.02, 0.0, 200, 6);
  ASSERT_TRUE(odd.mismatch(period, &why));
  EXPECT_NE(why.find("its stamps say 13"), std::string::npos) << why;
  ne::SensorLattice slow(3.0);
  feed(slow, 0.3, 6.0, 0.1, 0.0, 200, 8);
  EXPECT_FALSE(slow.mismatch(period, &why)) << why;
  EXPECT_EQ(slow.offLattice(), 0u);
  // A rate 10 % off the configured one, without jitter: followed, and named.
  ne::SensorLattice off(3.0);
  feed(off, 0.3, 3.3, 0.0, 0.0, 400, 9);
  ASSERT_TRUE(off.mismatch(period, &why));
  EXPECT_NE(why.find("its stamps say 9.09"), std::string::npos) << why;
  EXPECT_NE(why.find("10 Hz"), std::string::npos) << why;
}

// Messages that name their step (Measurement): the step is theirs, and the lattice learns from it
// (due at the sender's steps 3, 7, 11, ... for a quarter-rate sensor); a sensor that moves its
// phase is followed after three samples off the old lattice.
TEST(SensorLattice, NamedStepsAreKeptAndAPhaseChangeIsRelearnt)
{
  ne::SensorLattice l(4.0);
  for (long k = 3; k <= 39; k += 4)
  {
    const ne::SensorLattice::Fit f = l.fit(static_cast<double>(k), k);
    EXPECT_EQ(f.step, k);
    EXPECT_TRUE(f.fits) << k;
    l.learn(static_cast<double>(k), f);
  }
  for (long k = 36; k <= 48; ++k)
    EXPECT_EQ(l.due(k), k % 4 == 3) << k;
  // Now at 41, 45, 49: two off the lattice, the third re-learns it.
  bool relearnt = false;
  for (long k = 41; k <= 49; k += 4)
  {
    const ne::SensorLattice::Fit f = l.fit(static_cast<double>(k), k);
    EXPECT_FALSE(f.fits) << k;
    relearnt = l.learn(static_cast<double>(k), f);
  }
  EXPECT_TRUE(relearnt);
  EXPECT_EQ(l.relearnt(), 1u);
  EXPECT_TRUE(l.due(53));
  EXPECT_FALSE(l.due(51));
  l.reset();
  EXPECT_FALSE(l.locked());
  EXPECT_FALSE(l.due(53));
}

// A configured rate within 2 % of a whole fraction of the model's counts as that fraction (the
// stability analysis' sensor schedule needs whole ratios): 9.996 Hz in a 30 Hz model is every 3rd
// step; 30 Hz in a 50 Hz model (5/3) is not whole, and stays as it is.
TEST(SensorLattice, NearlyWholeRatiosAreWhole)
{
  EXPECT_EQ(ne::SensorLattice::whole(3.0013), 3.0);
  EXPECT_EQ(ne::SensorLattice::whole(30.0 / 9.996), 3.0);
  EXPECT_EQ(ne::SensorLattice::whole(24.6), 25.0);
  EXPECT_EQ(ne::SensorLattice::whole(5.0 / 3.0), 5.0 / 3.0);
  EXPECT_EQ(ne::SensorLattice::whole(2.5), 2.5);
  EXPECT_EQ(ne::SensorLattice::whole(1.0), 1.0);
}
