// kf / kfio / ack_kf and the shared machinery: textbook equivalence, multi-sensor stacked versus
// sequential updates, per-sensor loss, long runs on unstable plants, divergence and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/index_select.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "test_support.hpp"

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

const double kNaN = std::numeric_limits<double>::quiet_NaN();

std::unique_ptr<Estimator> make(const Model& m, Algorithm a, double mu = 0.8)
{
  EstimatorSettings s;
  s.algorithm = a;
  s.mu = mu;
  s.has_control_link = true;
  s.recovery = 0.3;
  s.failure = 0.4;
  return makeEstimator(m, s);
}

// Textbook Kalman update in Joseph form with an explicit gain.
void josephUpdate(VectorXd& x, MatrixXd& P, const MatrixXd& C, const MatrixXd& R, const VectorXd& y)
{
  const MatrixXd S = C * P * C.transpose() + R;
  const MatrixXd K = P * C.transpose() * S.inverse();
  x = x + K * (y - C * x);
  const MatrixXd IKC = MatrixXd::Identity(P.rows(), P.cols()) - K * C;
  P = IKC * P * IKC.transpose() + K * R * K.transpose();
}

}  // namespace

TEST(Kfio, MatchesTextbookJosephFilter)
{
  Rng rng(1);
  Model m = randomModel(rng, 4, 3, {2}, 0, 1);
  auto est = make(m, Algorithm::KFIO);
  VectorXd x = m.x0;
  MatrixXd P = m.P0;
  for (int k = 0; k < 200; ++k)
  {
    Sample s;
    s.gamma = rng.bernoulli(0.6);
    s.y = randomMatrix(rng, 2, 1, 2.0);
    s.u = randomMatrix(rng, 1, 1);
    est->step(s);
    x = m.A * x + m.Bu * s.u;
    P = m.A * P * m.A.transpose() + m.B * m.Q * m.B.transpose();
    if (s.gamma)
      josephUpdate(x, P, m.C, m.R, s.y);
    ASSERT_LT(maxAbsDiff(est->state(), x), 1e-9 * (1 + x.norm())) << "k " << k;
    ASSERT_LT(maxAbsDiff(est->covariance(), P), 1e-9 * P.norm()) << "k " << k;
    ASSERT_EQ(est->lastUpdated(), s.gamma);
  }
  EXPECT_EQ(est->steps(), 200);
}

// docs/algorithms.md 2.3: with block-diagonal R the stacked update equals sequential updates.
TEST(MultiSensor, StackedUpdateEqualsSequentialUpdates)
{
  Rng rng(2);
  Model m = randomModel(rng, 4, 4, {1, 2, 1}, 0, 0);
  auto est = make(m, Algorithm::KFIO);
  VectorXd x = m.x0;
  MatrixXd P = m.P0;
  for (int k = 0; k < 100; ++k)
  {
    Sample s;
    s.y = randomMatrix(rng, m.m(), 1, 2.0);
    est->step(s);
    x = m.A * x;
    P = m.A * P * m.A.transpose() + m.B * m.Q * m.B.transpose();
    for (const Sensor& sen : m.sensors)  // one sensor at a time, last to first
    {
      const Sensor& z = m.sensors[m.sensors.size() - 1 - (&sen - &m.sensors[0])];
      josephUpdate(x, P, m.C.middleRows(z.offset, z.size), m.R.block(z.offset, z.offset, z.size, z.size),
                   s.y.segment(z.offset, z.size));
    }
    ASSERT_LT(maxAbsDiff(est->state(), x), 1e-9 * (1 + x.norm())) << "k " << k;
    ASSERT_LT(maxAbsDiff(est->covariance(), P), 1e-9 * P.norm()) << "k " << k;
  }
}

// Per-sensor loss: a sensor whose block is NaN is left out; the others are fused.
TEST(MultiSensor, PerSensorLossFusesOnlyArrivedSensors)
{
  Rng rng(3);
  Model m = randomModel(rng, 3, 3, {1, 2, 1}, 0, 0);
  for (Algorithm a : {Algorithm::KFIO, Algorithm::KF, Algorithm::AOE, Algorithm::OE, Algorithm::RSEIO})
  {
    auto est = make(m, a, 1.0);
    VectorXd x = m.x0;
    MatrixXd P = m.P0;
    for (int k = 0; k < 60; ++k)
    {
      Sample s;
      s.y = randomMatrix(rng, m.m(), 1, 2.0);
      x = m.A * x;
      P = m.A * P * m.A.transpose() + m.B * m.Q * m.B.transpose();
      std::vector<int> rows;
      for (const Sensor& sen : m.sensors)
      {
        if (rng.bernoulli(0.5))
          s.y.segment(sen.offset, sen.size).setConstant(kNaN);
        else
          for (int i = 0; i < sen.size; ++i)
            rows.push_back(sen.offset + i);
      }
      est->step(s);
      if (!rows.empty())
        josephUpdate(x, P, selectRows(m.C, rows), selectBlock(m.R, rows, rows), selectEntries(s.y, rows));
      ASSERT_EQ(est->lastUpdated(), !rows.empty());
      ASSERT_LT(maxAbsDiff(est->state(), x), 1e-9 * (1 + x.norm())) << toString(a) << " k " << k;
      ASSERT_LT(maxAbsDiff(est->covariance(), P), 1e-9 * P.norm()) << toString(a) << " k " << k;
    }
  }
}

// kf cannot tell a loss: it fuses whatever finite sample it is given; kfio only predicts.
TEST(Kf, UsesNoiseSamplesThatKfioIgnores)
{
  const Model m = zhouModel();
  auto kf = make(m, Algorithm::KF);
  auto kfio = make(m, Algorithm::KFIO);
  Sample s;
  s.gamma = false;
  s.y = VectorXd::Constant(1, 0.3);  // the papers' model: pure noise v_k on a loss
  kf->step(s);
  kfio->step(s);
  EXPECT_TRUE(kf->lastUpdated());
  EXPECT_FALSE(kfio->lastUpdated());
  EXPECT_LT(kf->covariance().trace(), kfio->covariance().trace());
  EXPECT_LT(maxAbsDiff(kfio->state(), m.A * m.x0), 1e-15);
  // a loss with no data at all: kf only predicts too
  Sample empty;
  empty.gamma = false;
  auto kf2 = make(m, Algorithm::KF);
  kf2->step(empty);
  EXPECT_FALSE(kf2->lastUpdated());
  EXPECT_LT(maxAbsDiff(kf2->covariance(), kfio->covariance()), 1e-15);
}

namespace
{
// Observable and unstable (spectral radius 1.15). With arrival rate g, E[P] is unbounded when
// 1.15^2 (1 - g) > 1 (docs/stability.md 3.1), i.e. for g < 0.244: P sweeps through many decades.
Model unstableModel()
{
  Rng rng(5);
  Model m = randomModel(rng, 3, 3, {1}, 1, 1);
  m.A << 1.15, 0.3, 0.0, 0.0, 0.9, 0.0, 0.0, 0.0, 0.5;
  m.C << 1.0, 0.5, 0.2;
  return m;
}
}  // namespace

// 10^5 steps with 10 % arrivals (longest gap about 110 steps, P up to about 1e13): P stays
// exactly symmetric, finite and positive semidefinite for every algorithm.
TEST(Robustness, LongRunUnstablePlantRareArrivals)
{
  const Model m = unstableModel();
  for (Algorithm a : {Algorithm::KFIO, Algorithm::RSEIO, Algorithm::AOE, Algorithm::KF})
  {
    auto est = make(m, a, 0.7);
    Rng data(6);
    double max_trace = 0.0;
    for (long k = 0; k < 100000; ++k)
    {
      Sample s;
      s.gamma = data.bernoulli(0.10);
      s.y = VectorXd::Constant(1, data.normal());
      if (a == Algorithm::KF && !s.gamma)
        s.y.resize(0);
      s.u = VectorXd::Constant(1, 1.0);
      ASSERT_NO_THROW(est->step(s)) << toString(a) << " k " << k;
      const MatrixXd& P = est->covariance();
      ASSERT_TRUE(P.allFinite()) << toString(a) << " k " << k;
      ASSERT_TRUE(est->state().allFinite()) << toString(a) << " k " << k;
      ASSERT_TRUE(P == P.transpose()) << toString(a) << " k " << k;
      max_trace = std::max(max_trace, P.trace());
      if (k % 997 == 0)
      {
        ASSERT_GE(minEig(P), -1e-9 * P.norm()) << toString(a) << " k " << k;
      }
    }
    EXPECT_EQ(est->steps(), 100000);
    EXPECT_GT(max_trace, 1e6) << toString(a);  // the gaps were long enough to matter
  }
}

// 10^5 steps with 5 % arrivals: gaps of 200 steps push P's condition number past 1/eps. Each step
// either leaves a finite symmetric P or reports a DivergenceError that says so; never NaN.
TEST(Robustness, BeyondDoublePrecisionReportsDivergenceNotNaN)
{
  const Model m = unstableModel();
  for (Algorithm a : {Algorithm::KFIO, Algorithm::RSEIO, Algorithm::AOE, Algorithm::KF})
  {
    auto est = make(m, a, 0.7);
    Rng data(6);
    for (long k = 0; k < 100000; ++k)
    {
      Sample s;
      s.gamma = data.bernoulli(0.05);
      s.y = VectorXd::Constant(1, data.normal());
      s.u = VectorXd::Constant(1, 1.0);
      try
      {
        est->step(s);
      }
      catch (const DivergenceError& e)
      {
        EXPECT_NE(std::string(e.what()).find("unbounded"), std::string::npos) << e.what();
        EXPECT_THROW(est->step(s), DivergenceError);
        break;
      }
      ASSERT_TRUE(est->covariance().allFinite()) << toString(a) << " k " << k;
      ASSERT_TRUE(est->state().allFinite()) << toString(a) << " k " << k;
      ASSERT_TRUE(est->covariance() == est->covariance().transpose()) << toString(a) << " k " << k;
    }
  }
}

// A plant so unstable that the covariance overflows: a DivergenceError, never NaN; stepping again
// is refused until reset().
TEST(Robustness, OverflowIsReportedAsDivergence)
{
  Model m = zhouModel();
  m.A = 40.0 * MatrixXd::Identity(2, 2);
  for (Algorithm a : {Algorithm::KFIO, Algorithm::RSEIO, Algorithm::AOE, Algorithm::OE})
  {
    auto est = make(m, a, 0.8);
    Sample lost;
    lost.gamma = false;
    long thrown_at = -1;
    for (long k = 0; k < 1000 && thrown_at < 0; ++k)
    {
      try
      {
        est->step(lost);
        ASSERT_TRUE(est->covariance().allFinite());
      }
      catch (const DivergenceError& e)
      {
        thrown_at = k;
        EXPECT_NE(std::string(e.what()).find("diverged"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("unbounded"), std::string::npos) << e.what();
      }
    }
    ASSERT_GT(thrown_at, 50) << toString(a);  // 40^(2k) overflows doubles after about 190 steps
    EXPECT_THROW(est->step(lost), DivergenceError);
    est->reset();
    EXPECT_EQ(est->steps(), 0);
    EXPECT_NO_THROW(est->step(lost));
    EXPECT_TRUE(est->covariance().allFinite());
  }
}

// Malformed input is refused with InputError and leaves the estimate untouched.
TEST(BadInput, RejectedWithoutTouchingTheEstimate)
{
  Rng rng(7);
  Model m = randomModel(rng, 3, 3, {1, 2}, 1, 1);
  for (Algorithm a : {Algorithm::KF, Algorithm::KFIO, Algorithm::RSEIO, Algorithm::AOE, Algorithm::OE})
  {
    auto est = make(m, a, 0.8);
    Sample good;
    good.y = VectorXd::Ones(3);
    good.u = VectorXd::Ones(1);
    est->step(good);
    const VectorXd x = est->state();
    const MatrixXd P = est->covariance();
    auto expectRejected = [&](const Sample& s, const std::string& fragment)
    {
      try
      {
        est->step(s);
        ADD_FAILURE() << toString(a) << ": accepted bad input (" << fragment << ")";
      }
      catch (const InputError& e)
      {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      }
      EXPECT_EQ(est->state(), x);
      EXPECT_EQ(est->covariance(), P);
      EXPECT_EQ(est->steps(), 1);
    };
    Sample s = good;
    s.y = VectorXd::Ones(2);
    expectRejected(s, "expected 3 values, found 2");
    s = good;
    s.y[1] = kNaN;  // sensor s1 has 2 rows: only one missing
    expectRejected(s, "partly missing");
    s = good;
    s.y[0] = std::numeric_limits<double>::infinity();
    expectRejected(s, "infinite");
    s = good;
    s.u = VectorXd::Ones(2);
    expectRejected(s, "expected 1 values, found 2");
    s = good;
    s.u[0] = kNaN;
    expectRejected(s, "not finite");
    s = good;
    s.y.resize(0);
    expectRejected(s, "gamma = 1 but no values");
  }
}

// Sample::R, a per-step R_k (issue: message covariances), for every algorithm and both compiled
// forms (n = 2 with two scalar sensors runs fixed-size, n = 3 dynamic):
//  - R_k equal to the model's R gives bit-identical results;
//  - a constant R_k equals the estimator built on a model with that R (bit for bit);
//  - a wrong size or a non-finite R_k is an InputError that leaves the estimate untouched.
TEST(StepR, EqualsTheModelsRAndReplacesIt)
{
  for (int n : {2, 3})
    for (Algorithm a :
         {Algorithm::KF, Algorithm::KFIO, Algorithm::ACK_KF, Algorithm::RSEIO, Algorithm::AOE, Algorithm::OE})
    {
      Rng rng(40 + n);
      const Model m = randomModel(rng, n, n, {1, 1}, 0, 1);
      Model other = m;
      other.R = randomSpd(rng, 2, 0.3, 2.0);
      auto plain = make(m, a), same = make(m, a), own = make(m, a), built = make(other, a);
      for (int k = 0; k < 150; ++k)
      {
        Sample s;
        s.gamma = rng.bernoulli(0.7);
        s.y = randomMatrix(rng, 2, 1, 2.0);
        if (rng.bernoulli(0.3))
          s.y(rng.bernoulli(0.5) ? 0 : 1) = kNaN;  // one sensor lost
        s.u = randomMatrix(rng, 1, 1);
        s.nu = rng.bernoulli(0.5) ? 1 : 0;
        plain->step(s);
        built->step(s);
        s.R = m.R;
        same->step(s);
        s.R = other.R;
        own->step(s);
        ASSERT_EQ(same->state(), plain->state()) << toString(a) << " n " << n << " k " << k;
        ASSERT_EQ(same->covariance(), plain->covariance()) << toString(a) << " n " << n << " k " << k;
        ASSERT_EQ(own->state(), built->state()) << toString(a) << " n " << n << " k " << k;
        ASSERT_EQ(own->covariance(), built->covariance()) << toString(a) << " n " << n << " k " << k;
      }
      const VectorXd x = own->state();
      Sample bad;
      bad.y = VectorXd::Zero(2);
      bad.u = VectorXd::Zero(1);
      bad.nu = 1;
      bad.R = MatrixXd::Identity(3, 3);
      EXPECT_THROW(own->step(bad), InputError) << toString(a);
      bad.R = MatrixXd::Identity(2, 2);
      bad.R(1, 1) = kNaN;
      EXPECT_THROW(own->step(bad), InputError) << toString(a);
      EXPECT_EQ(own->state(), x) << toString(a);
    }
}

// A changing R_k: kfio equals the textbook Joseph filter run with R_k at every step (rows of the
// arrived sensors only).
TEST(StepR, ChangingRkEqualsTheTextbookFilter)
{
  for (int n : {2, 4})
  {
    Rng rng(50 + n);
    const Model m = randomModel(rng, n, n, {1, 1}, 0, 1);
    auto est = make(m, Algorithm::KFIO);
    VectorXd x = m.x0;
    MatrixXd P = m.P0;
    for (int k = 0; k < 200; ++k)
    {
      Sample s;
      s.y = randomMatrix(rng, 2, 1, 2.0);
      const bool lost0 = rng.bernoulli(0.2);
      if (lost0)
        s.y(0) = kNaN;
      s.u = randomMatrix(rng, 1, 1);
      s.R = randomSpd(rng, 2, 0.1, 5.0);
      est->step(s);
      x = m.A * x + m.Bu * s.u;
      P = m.A * P * m.A.transpose() + m.B * m.Q * m.B.transpose();
      if (lost0)
        josephUpdate(x, P, m.C.row(1), s.R.block(1, 1, 1, 1), s.y.tail(1));
      else
        josephUpdate(x, P, m.C, s.R, s.y);
      ASSERT_LT(maxAbsDiff(est->state(), x), 1e-9 * (1 + x.norm())) << "n " << n << " k " << k;
      ASSERT_LT(maxAbsDiff(est->covariance(), P), 1e-9 * P.norm()) << "n " << n << " k " << k;
    }
  }
}
