// LossyRun: a simulated run behind one independent lossy link per sensor and a lossy actuator link.
#include "networked_estimation/simulation/lossy_run.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "networked_estimation/common/error.hpp"
#include "test_support.hpp"

namespace ne = networked_estimation;

namespace
{

ne::Model twoSensors(bool control)
{
  return ne::test::scalarTwoSensorModel(0.9, "gps", "camera", control);
}

ne::ChannelSettings bernoulli(double loss)
{
  ne::ChannelSettings c;
  c.model = ne::LossModelKind::BERNOULLI;
  c.loss = loss;
  return c;
}

}  // namespace

// Each sensor is lost at its own link's rate, independently of the other; a lossless sensor is
// never lost. N = 40000 steps: the standard deviation of an empirical rate is at most
// sqrt(0.25 / N) = 0.0025, so |rate - expected| < 0.0125 (5 sd) fails by chance with p < 1e-6;
// independence: P(both lost) = 0.3 * 0.6 = 0.18 within the same bound.
TEST(LossyRun, EverySensorItsOwnIndependentLink)
{
  const ne::Model m = twoSensors(false);
  ne::LossyRunOptions o;
  o.sensor_links = {bernoulli(0.3), bernoulli(0.6)};
  ne::LossyRun run(m, 7, o);
  const long N = 40000;
  long lost0 = 0, lost1 = 0, both = 0, no_gamma = 0;
  for (long k = 1; k <= N; ++k)
  {
    const ne::SimulatedSample& s = run.step();
    const ne::Sample& r = run.received();
    const bool l0 = std::isnan(r.y(0)), l1 = std::isnan(r.y(1));
    ASSERT_FALSE(l0 && l1);  // with noise_on_loss, a step where nothing arrived carries v_k
    if (!r.gamma)
    {
      // nothing arrived: gamma = 0 and the cells carry the measurement noise (the papers' model)
      ASSERT_EQ(r.y, s.v);
      ++both;
      continue;
    }
    lost0 += l0;
    lost1 += l1;
    if (!l0)
      ASSERT_EQ(r.y(0), s.y(0));
    if (!l1)
      ASSERT_EQ(r.y(1), s.y(1));
  }
  no_gamma = both;
  lost0 += both;
  lost1 += both;
  EXPECT_NEAR(static_cast<double>(lost0) / N, 0.3, 0.0125);
  EXPECT_NEAR(static_cast<double>(lost1) / N, 0.6, 0.0125);
  EXPECT_NEAR(static_cast<double>(no_gamma) / N, 0.18, 0.0125);

  // a sensor without a link is never lost, so every step has gamma = 1
  o.sensor_links = {bernoulli(0.9), std::nullopt};
  ne::LossyRun half(m, 7, o);
  for (long k = 1; k <= 2000; ++k)
  {
    half.step();
    ASSERT_TRUE(half.received().gamma);
    ASSERT_TRUE(std::isfinite(half.received().y(1)));
  }
}

TEST(LossyRun, SameSeedSameRunAndEmptyLossOutput)
{
  const ne::Model m = twoSensors(false);
  ne::LossyRunOptions o;
  o.sensor_links = {bernoulli(0.5), bernoulli(0.5)};
  o.noise_on_loss = false;
  ne::LossyRun a(m, 11, o), b(m, 11, o), c(m, 12, o);
  int differ = 0;
  for (long k = 1; k <= 500; ++k)
  {
    const Eigen::VectorXd xa = a.step().x;
    const Eigen::VectorXd xb = b.step().x;
    c.step();
    ASSERT_EQ(xa, xb);
    for (int i = 0; i < 2; ++i)
      ASSERT_EQ(std::isnan(a.received().y(i)), std::isnan(b.received().y(i)));
    if (!a.received().gamma)
      ASSERT_TRUE(a.received().y.array().isNaN().all());  // empty: nothing, not the noise
    differ += a.received().gamma != c.received().gamma;
  }
  EXPECT_GT(differ, 50);  // another seed, another loss pattern
}

// The actuator link drops commands at its rate; a lost command is applied as zero input (nu = 0).
// N = 20000: sd <= 0.0036, bound 0.018 (5 sd).
TEST(LossyRun, ActuatorLinkAndItsErrors)
{
  const ne::Model m = twoSensors(true);
  ne::LossyRunOptions o;
  o.actuator_link = bernoulli(0.25);
  ne::LossyRun run(m, 3, o);
  long delivered = 0;
  const long N = 20000;
  for (long k = 1; k <= N; ++k)
  {
    const ne::SimulatedSample& s = run.step();
    delivered += s.nu;
    ASSERT_EQ(run.received().u, s.u);  // the estimator knows the commanded u_k, not whether it arrived
    ASSERT_EQ(run.received().nu, -1);
  }
  EXPECT_NEAR(static_cast<double>(delivered) / N, 0.75, 0.018);

  const ne::Model plain = twoSensors(false);
  EXPECT_THROW(ne::LossyRun(plain, 1, o), ne::ConfigError);  // no control: no actuator link
  ne::LossyRunOptions wrong;
  wrong.sensor_links = {bernoulli(0.1)};  // one link for two sensors
  try
  {
    ne::LossyRun r(plain, 1, wrong);
    FAIL() << "expected a ConfigError";
  }
  catch (const ne::ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("1 given for the 2 sensors"), std::string::npos) << e.what();
  }
}

// restart(seed) (no allocation, for Monte Carlo runs) is exactly a LossyRun constructed with that seed:
// the plant, every sensor link (Gilbert-Elliott and Bernoulli) and the actuator link.
TEST(LossyRun, RestartEqualsAFreshRun)
{
  const ne::Model m = twoSensors(true);
  ne::LossyRunOptions o;
  ne::ChannelSettings ge;
  ge.model = ne::LossModelKind::GILBERT_ELLIOTT;
  ge.p = 0.3;
  ge.r = 0.5;
  o.sensor_links = {ge, bernoulli(0.4)};
  o.actuator_link = bernoulli(0.3);
  ne::LossyRun reused(m, 99, o);
  for (int k = 0; k < 7; ++k)
    reused.step();
  for (std::uint64_t seed : {3u, 4u})
  {
    reused.restart(seed);
    ne::LossyRun fresh(m, seed, o);
    for (int k = 0; k < 30; ++k)
    {
      const ne::SimulatedSample& a = reused.step();
      const ne::SimulatedSample& b = fresh.step();
      ASSERT_EQ(a.x, b.x);
      ASSERT_EQ(a.y, b.y);
      ASSERT_EQ(a.nu, b.nu);
      ASSERT_EQ(reused.received().gamma, fresh.received().gamma);
      ASSERT_TRUE(reused.received().y.array().isNaN().matrix() == fresh.received().y.array().isNaN().matrix());
    }
  }
}
