// AOE, OE and ACK-KF against self-checks T1-T6 (each stated below) and Lin et al.'s Theorems 1 and 3.
#include <gtest/gtest.h>

#include <cmath>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "test_support.hpp"
#include "estimators/aoe_estimators.hpp"  // private header: the OE's shared component covariance

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

EstimatorSettings settings(Algorithm a, double q1 = 0.3, double q2 = 0.4, std::size_t cap = 1 << 20)
{
  EstimatorSettings s;
  s.algorithm = a;
  s.has_control_link = true;
  s.recovery = q1;
  s.failure = q2;
  s.max_components = cap;
  return s;
}

VectorXd paperInput(int k)
{
  return VectorXd::Constant(1, 1.0 + std::exp(-k / 10.0));
}

// The setup of the self-checks (Lin et al.'s example): rho_A = 1.2910, xbar_0 = 0, P_0 = I, nuhat_0 = pi_nu.
struct Trio
{
  Model model = aoeModel(1.2910);
  std::unique_ptr<Estimator> oe, aoe, ack;
  Trio(double q1, double q2)
  {
    oe = makeEstimator(model, settings(Algorithm::OE, q1, q2));
    aoe = makeEstimator(model, settings(Algorithm::AOE, q1, q2));
    ack = makeEstimator(model, settings(Algorithm::ACK_KF, q1, q2));
  }
};

}  // namespace

// T5: all gamma = 0, q1 = 0.3, q2 = 0.4: the means coincide, traces as listed (6 decimals).
TEST(AoeSelfCheck, T5NoMeasurementsMarkovLink)
{
  Trio r(0.3, 0.4);
  const double oe_tr[] = {44.453884, 102.499511, 185.252682, 308.760916, 500.028422, 804.135694};
  const double aoe_tr[] = {44.453884, 101.330726, 182.181225, 302.912378, 490.026557, 787.686468};
  for (int k = 1; k <= 6; ++k)
  {
    Sample s;
    s.gamma = false;
    s.u = paperInput(k);
    r.oe->step(s);
    r.aoe->step(s);
    EXPECT_NEAR(r.oe->covariance().trace(), oe_tr[k - 1], 1e-6) << "k = " << k;
    EXPECT_NEAR(r.aoe->covariance().trace(), aoe_tr[k - 1], 1e-6) << "k = " << k;
    EXPECT_LT(maxAbsDiff(r.oe->state(), r.aoe->state()), 1e-9) << "k = " << k;
    if (k == 1)
    {
      EXPECT_NEAR(r.oe->state()[0], -0.816359, 1e-6);
      EXPECT_NEAR(r.oe->state()[1], 0.816359, 1e-6);
    }
    if (k == 6)
    {
      EXPECT_NEAR(r.oe->state()[0], -9.443837, 1e-6);
      EXPECT_NEAR(r.oe->state()[1], 4.468207, 1e-6);
    }
  }
}

// T5's closed form for the OE: A^k P0 A'^k + sum A^{k-j} Q A'^{k-j}
//   + sum_{j,l} pi0 pi1 (1-q1-q2)^{|j-l|} A^{k-j} B u_j u_l B' A'^{k-l}.
TEST(AoeSelfCheck, T5OeMatchesClosedForm)
{
  const double q1 = 0.3, q2 = 0.4;
  Trio r(q1, q2);
  const MatrixXd& A = r.model.A;
  const double pi1 = q1 / (q1 + q2), pi0 = 1 - pi1;
  for (int k = 1; k <= 8; ++k)
  {
    Sample s;
    s.gamma = false;
    s.u = paperInput(k);
    r.oe->step(s);
    MatrixXd Ak = MatrixXd::Identity(2, 2);
    for (int i = 0; i < k; ++i)
      Ak = A * Ak;
    MatrixXd P = Ak * r.model.P0 * Ak.transpose();
    std::vector<VectorXd> g(k + 1);  // A^{k-j} B u_j
    for (int j = 1; j <= k; ++j)
    {
      MatrixXd Akj = MatrixXd::Identity(2, 2);
      for (int i = 0; i < k - j; ++i)
        Akj = A * Akj;
      P += Akj * r.model.Q * Akj.transpose();
      g[j] = Akj * r.model.Bu * paperInput(j);
    }
    for (int j = 1; j <= k; ++j)
      for (int l = 1; l <= k; ++l)
        P += pi0 * pi1 * std::pow(1 - q1 - q2, std::abs(j - l)) * g[j] * g[l].transpose();
    EXPECT_LT(maxAbsDiff(r.oe->covariance(), P), 1e-9 * P.norm()) << "k = " << k;
  }
}

// T6: i.i.d. link (q1 + q2 = 1): OE = AOE exactly.
TEST(AoeSelfCheck, T6IidLinkOeEqualsAoe)
{
  Trio r(0.3, 0.7);
  const double tr[] = {44.200636, 100.760921, 181.179813, 301.279445, 487.421918, 783.537140};
  for (int k = 1; k <= 6; ++k)
  {
    Sample s;
    s.gamma = false;
    s.u = paperInput(k);
    r.oe->step(s);
    r.aoe->step(s);
    EXPECT_NEAR(r.oe->covariance().trace(), tr[k - 1], 1e-6) << "k = " << k;
    EXPECT_NEAR(r.aoe->covariance().trace(), tr[k - 1], 1e-6) << "k = " << k;
    EXPECT_LT(maxAbsDiff(r.oe->covariance(), r.aoe->covariance()), 1e-9);
  }
}

// T1: OE = AOE at k = 1, for gamma_1 = 0 and 1.
TEST(AoeSelfCheck, T1OeEqualsAoeAtFirstStep)
{
  for (int gamma = 0; gamma <= 1; ++gamma)
  {
    Trio r(0.3, 0.4);
    Sample s;
    s.gamma = gamma == 1;
    s.y = Eigen::Vector2d(-1.5, 2.0);
    s.u = paperInput(1);
    r.oe->step(s);
    r.aoe->step(s);
    EXPECT_LT(maxAbsDiff(r.oe->state(), r.aoe->state()), 1e-12) << "gamma " << gamma;
    EXPECT_LT(maxAbsDiff(r.oe->covariance(), r.aoe->covariance()), 1e-10) << "gamma " << gamma;
    EXPECT_NEAR(r.oe->commandArrivalProbability(), r.aoe->commandArrivalProbability(), 1e-12);
  }
}

// T2, T3 and Theorem 1 along simulated realisations: Mhat_k = P_k^ACK; P_k - P^ACK >= 0 and
// P^e_k - P^ACK >= 0; on a loss P^e_k = A P^e A' + Q + nubar0 nubar1 U_k exactly.
TEST(AoeSelfCheck, T2T3CovarianceOrderingOnRealisations)
{
  Rng rng(4242);
  for (int run = 0; run < 5; ++run)
  {
    Trio r(0.3, 0.4);
    const double q1 = 0.3, q2 = 0.4;
    VectorXd x = VectorXd::Zero(2);
    bool nu = rng.bernoulli(q1 / (q1 + q2));
    bool gamma = rng.bernoulli(0.7);
    for (int k = 1; k <= 14; ++k)
    {
      if (k > 1)
      {
        nu = nu ? !rng.bernoulli(q2) : rng.bernoulli(q1);
        gamma = gamma ? !rng.bernoulli(0.3) : rng.bernoulli(0.6);
      }
      const VectorXd u = paperInput(k);
      x = r.model.A * x + (nu ? VectorXd(r.model.Bu * u) : VectorXd::Zero(2)) +
          std::sqrt(20.0) * Eigen::Vector2d(rng.normal(), rng.normal());
      Sample s;
      s.gamma = gamma;
      s.y = r.model.C * x + std::sqrt(20.0) * Eigen::Vector2d(rng.normal(), rng.normal());
      s.u = u;
      s.nu = nu ? 1 : 0;
      const MatrixXd Pe_prev = r.aoe->covariance();
      const double nubar1 =
          (1 - q2) * r.aoe->commandArrivalProbability() + q1 * (1 - r.aoe->commandArrivalProbability());
      r.oe->step(s);
      r.aoe->step(s);
      r.ack->step(s);
      EXPECT_EQ(r.oe->components(), std::size_t(1) << k);
      // Theorem 1 (T2): the OE's shared component covariance is the ACK filter's.
      const auto& oe = dynamic_cast<const detail::OptimalEstimator&>(*r.oe);
      EXPECT_LT(maxAbsDiff(oe.componentCovariance(), r.ack->covariance()), 1e-9 * r.ack->covariance().norm())
          << "run " << run << " k " << k;
      // OE output covariance minus the ACK covariance is the (PSD) spread of the means.
      EXPECT_GE(minEig(r.oe->covariance() - r.ack->covariance()), -1e-9) << "run " << run << " k " << k;
      EXPECT_GE(minEig(r.aoe->covariance() - r.ack->covariance()), -1e-9) << "run " << run << " k " << k;
      if (!gamma)
      {
        const VectorXd bu = r.model.Bu * u;
        const MatrixXd expect =
            r.model.A * Pe_prev * r.model.A.transpose() + r.model.Q + nubar1 * (1 - nubar1) * bu * bu.transpose();
        EXPECT_LT(maxAbsDiff(r.aoe->covariance(), expect), 1e-9 * expect.norm()) << "T3, k " << k;
      }
    }
  }
}

// Theorem 1: the OE's shared covariance equals the ACK Kalman filter covariance (checked through
// the zero-input case, where the mixture spread vanishes, and directly through OE = ACK when u = 0).
// T4: with u = 0, OE = AOE = ACK KF.
TEST(AoeSelfCheck, T4ZeroInputAllEqual)
{
  Trio r(0.3, 0.4);
  Rng rng(8);
  for (int k = 1; k <= 40; ++k)
  {
    Sample s;
    s.gamma = rng.bernoulli(0.6);
    s.y = 10.0 * Eigen::Vector2d(rng.normal(), rng.normal());
    s.u = VectorXd::Zero(1);
    s.nu = rng.bernoulli(0.5) ? 1 : 0;
    r.oe->step(s);
    r.aoe->step(s);
    r.ack->step(s);
    ASSERT_LT(maxAbsDiff(r.oe->covariance(), r.ack->covariance()), 1e-9 * r.ack->covariance().norm());
    ASSERT_LT(maxAbsDiff(r.aoe->covariance(), r.ack->covariance()), 1e-9 * r.ack->covariance().norm());
    ASSERT_LT(maxAbsDiff(r.oe->state(), r.ack->state()), 1e-9 * (1 + r.ack->state().norm()));
    ASSERT_LT(maxAbsDiff(r.aoe->state(), r.ack->state()), 1e-9 * (1 + r.ack->state().norm()));
  }
  EXPECT_EQ(r.oe->components(), 1u);
}

// The OE's posterior P(nu_k = 1) moves towards the truth when the measurements are informative.
TEST(Oe, CommandPosteriorFollowsTruthWithInformativeMeasurements)
{
  Model m = aoeModel(1.2910);
  m.R = 1e-4 * MatrixXd::Identity(2, 2);
  m.Q = 1e-4 * MatrixXd::Identity(2, 2);
  auto oe = makeEstimator(m, settings(Algorithm::OE, 0.5, 0.5, 64));
  auto aoe = makeEstimator(m, settings(Algorithm::AOE, 0.5, 0.5));
  Rng rng(3);
  VectorXd x = VectorXd::Zero(2);
  int right_oe = 0, right_aoe = 0;
  for (int k = 1; k <= 60; ++k)
  {
    const bool nu = rng.bernoulli(0.5);
    const VectorXd u = paperInput(k);
    x = m.A * x + (nu ? VectorXd(m.Bu * u) : VectorXd::Zero(2));
    Sample s;
    s.y = m.C * x + 0.01 * Eigen::Vector2d(rng.normal(), rng.normal());
    s.u = u;
    oe->step(s);
    aoe->step(s);
    right_oe += (oe->commandArrivalProbability() > 0.5) == nu;
    right_aoe += (aoe->commandArrivalProbability() > 0.5) == nu;
  }
  EXPECT_GE(right_oe, 58);
  EXPECT_GE(right_aoe, 58);
  EXPECT_LE(oe->components(), 64u);
}

// The cap keeps the largest weights: exact while 2^k <= cap, bounded afterwards.
TEST(Oe, CapIsExactUntilReachedThenBounded)
{
  Trio exact(0.3, 0.4);
  const Model m = aoeModel(1.2910);
  auto capped = makeEstimator(m, settings(Algorithm::OE, 0.3, 0.4, 16));
  Rng rng(21);
  for (int k = 1; k <= 10; ++k)
  {
    Sample s;
    s.gamma = rng.bernoulli(0.7);
    s.y = 5.0 * Eigen::Vector2d(rng.normal(), rng.normal());
    s.u = paperInput(k);
    exact.oe->step(s);
    capped->step(s);
    if (k <= 4)
    {
      EXPECT_EQ(capped->state(), exact.oe->state()) << "k " << k;
      EXPECT_EQ(capped->covariance(), exact.oe->covariance()) << "k " << k;
    }
    EXPECT_LE(capped->components(), 16u);
    EXPECT_TRUE(capped->covariance().allFinite());
  }
  EXPECT_EQ(exact.oe->components(), 1024u);
  EXPECT_EQ(capped->components(), 16u);
}

TEST(AckKf, RequiresNuWhenThereIsAnInput)
{
  const Model m = aoeModel();
  auto ack = makeEstimator(m, settings(Algorithm::ACK_KF));
  Sample s;
  s.gamma = false;
  s.u = paperInput(1);
  s.nu = -1;
  EXPECT_THROW(ack->step(s), InputError);
  EXPECT_EQ(ack->steps(), 0);
  s.nu = 0;
  ack->step(s);
  EXPECT_LT(maxAbsDiff(ack->state(), m.A * m.x0), 1e-15);  // lost command: no input applied
  s.nu = 1;
  ack->step(s);
  EXPECT_LT(maxAbsDiff(ack->state(), m.A * m.A * m.x0 + m.Bu * s.u), 1e-12);
}

TEST(AoeFactory, ControlModelNeedsControlLink)
{
  const Model m = aoeModel();
  EstimatorSettings s;
  s.algorithm = Algorithm::AOE;
  try
  {
    makeEstimator(m, s);
    FAIL() << "expected ConfigError";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("control_link"), std::string::npos) << e.what();
  }
  s.algorithm = Algorithm::OE;
  EXPECT_THROW(makeEstimator(m, s), ConfigError);
}
