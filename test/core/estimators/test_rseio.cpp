// RSEIO against its definition: the minimiser of the cost (2), checked by brute force
// (docs/algorithms.md 6.4, extended by 4.6 for a known input), the reductions (4.7) and the
// Theorem 2 analysis form (4.9).
#include <gtest/gtest.h>

#include <map>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/index_select.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/estimators/rseio.hpp"
#include "test_support.hpp"
#include "estimators/rseio_estimator.hpp"  // private header: which form an arrival step used

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

EstimatorSettings rseioSettings(double mu)
{
  EstimatorSettings s;
  s.algorithm = Algorithm::RSEIO;
  s.mu = mu;
  return s;
}

// S, T, Sc written out from docs/algorithms.md 4.3 / 4.6, independently of rseioSensitivity().
void sensitivity(const Model& m, MatrixXd& S, MatrixXd& T, MatrixXd& Sc)
{
  const int r = 2 * m.ne() * m.m();
  S.setZero(r, m.n());
  T.setZero(r, m.nw());
  Sc.setZero(r, m.n());
  for (int k = 0; k < m.ne(); ++k)
  {
    const Uncertainty& u = m.uncertainty[k];
    S.block(2 * k * m.m(), 0, m.m(), m.n()) = m.C * u.dA;
    S.block((2 * k + 1) * m.m(), 0, m.m(), m.n()) = u.dC * m.A;
    T.block(2 * k * m.m(), 0, m.m(), m.nw()) = m.C * u.dB;
    T.block((2 * k + 1) * m.m(), 0, m.m(), m.nw()) = u.dC * m.B;
    Sc.block((2 * k + 1) * m.m(), 0, m.m(), m.n()) = u.dC;
  }
}

// Direct minimisation of (a.8): returns (x+, P+) for one arrival step from (xhat, P).
void bruteForce(const Model& m, double mu, const VectorXd& xhat, const MatrixXd& P, const VectorXd& y,
                const VectorXd& u, VectorXd& xplus, MatrixXd& Pplus)
{
  const double lam = (1.0 - mu) / mu;
  MatrixXd S, T, Sc;
  sensitivity(m, S, T, Sc);
  const int n = m.n(), nw = m.nw();
  MatrixXd AB(n, n + nw);
  AB << m.A, m.B;
  MatrixXd ST(S.rows(), n + nw);
  ST << S, T;
  MatrixXd D = MatrixXd::Zero(n + nw, n + nw);
  D.topLeftCorner(n, n) = P.inverse();
  D.bottomRightCorner(nw, nw) = m.Q.inverse();
  const MatrixXd Rinv = m.R.inverse();
  const MatrixXd M = D + lam * ST.transpose() * ST + AB.transpose() * m.C.transpose() * Rinv * m.C * AB;
  VectorXd z = VectorXd::Zero(n + nw);
  z.head(n) = xhat;
  VectorXd bu = VectorXd::Zero(n);
  if (u.size() > 0)
    bu = m.Bu * u;
  const VectorXd c = Sc * bu;
  const VectorXd rhs = D * z + AB.transpose() * m.C.transpose() * Rinv * (y - m.C * bu) - lam * ST.transpose() * c;
  const MatrixXd Minv = M.inverse();
  xplus = AB * (Minv * rhs) + bu;
  Pplus = AB * Minv * AB.transpose();
}

double relErr(const MatrixXd& a, const MatrixXd& b)
{
  return (a - b).norm() / std::max(1.0, b.norm());
}

}  // namespace

// docs/algorithms.md 6.1: with non-zero dA, dB and dC (T != 0) the printed Qhat and Ahat of the OCR text are
// off by about 0.5; the corrected Theorem 1 must equal the brute-force minimiser to rounding.
TEST(Rseio, EqualsBruteForceMinimiserOnRandomCases)
{
  Rng rng(2024);
  std::map<std::string, int> forms;
  for (int trial = 0; trial < 40; ++trial)
  {
    const int n = 2 + trial % 4, nw = 1 + trial % 3, ne = 1 + trial % 2;
    const std::vector<int> sizes = {1 + trial % 2};
    Model m = randomModel(rng, n, nw, sizes, ne, 0);
    const double mu = rng.uniform(0.2, 0.98);
    const VectorXd y = randomMatrix(rng, m.m(), 1);
    VectorXd xb;
    MatrixXd Pb;
    bruteForce(m, mu, m.x0, m.P0, y, VectorXd(), xb, Pb);
    auto est = makeEstimator(m, rseioSettings(mu));
    Sample s;
    s.gamma = true;
    s.y = y;
    est->step(s);
    EXPECT_LT(relErr(est->covariance(), Pb), 1e-10) << "trial " << trial << " mu " << mu;
    EXPECT_LT(relErr(est->state(), xb), 1e-10) << "trial " << trial;
    ++forms[dynamic_cast<const detail::Rseio&>(*est).lastForm()];
  }
  // both the rank form (rank [S T] <= n) and the Gram form of Theorem 1 were checked
  EXPECT_GE(forms["rank"], 5);
  EXPECT_GE(forms["gram"], 5);
}

// docs/algorithms.md 4.6: with a known input and non-zero dC the estimate carries a correction term.
TEST(Rseio, EqualsBruteForceMinimiserWithKnownInput)
{
  Rng rng(77);
  std::map<std::string, int> forms;
  for (int trial = 0; trial < 30; ++trial)
  {
    const int n = 2 + trial % 3;
    // odd trials: two sensors and two parameters (rank [S T] > n: Gram form); even: one of each
    const bool big = trial % 2 == 1;
    Model m =
        randomModel(rng, n, 2, big ? std::vector<int>{1, 1} : std::vector<int>{1}, big ? 2 : 1, 1 + trial % 3 / 2);
    const double mu = rng.uniform(0.3, 0.95);
    const VectorXd y = randomMatrix(rng, m.m(), 1);
    const VectorXd u = randomMatrix(rng, m.p(), 1, 2.0);
    VectorXd xb;
    MatrixXd Pb;
    bruteForce(m, mu, m.x0, m.P0, y, u, xb, Pb);
    auto est = makeEstimator(m, rseioSettings(mu));
    Sample s;
    s.y = y;
    s.u = u;
    est->step(s);
    EXPECT_LT(relErr(est->covariance(), Pb), 1e-10) << "trial " << trial;
    EXPECT_LT(relErr(est->state(), xb), 1e-10) << "trial " << trial;
    ++forms[dynamic_cast<const detail::Rseio&>(*est).lastForm()];
  }
  EXPECT_GE(forms["rank"], 5);
  EXPECT_GE(forms["gram"], 5);
}

// Dropped samples are the nominal prediction: x = A x + Bu u, P = A P A' + B Q B'.
TEST(Rseio, DroppedSampleIsNominalPrediction)
{
  Rng rng(5);
  Model m = randomModel(rng, 3, 2, {2}, 1, 1);
  auto est = makeEstimator(m, rseioSettings(0.5));
  Sample s;
  s.gamma = false;
  s.u = VectorXd::Constant(1, 0.7);
  est->step(s);
  const VectorXd x = m.A * m.x0 + m.Bu * s.u;
  const MatrixXd P = m.A * m.P0 * m.A.transpose() + m.B * m.Q * m.B.transpose();
  EXPECT_LT(maxAbsDiff(est->state(), x), 1e-12);
  EXPECT_LT(maxAbsDiff(est->covariance(), P), 1e-12);
}

// Section 3: mu = 1 is exactly KFIO (the same sequence of floating point operations), and mu just
// below 1 goes through the full Theorem 1 path and must agree to rounding (continuity at lambda=0).
TEST(Rseio, MuOneIsExactlyKfioAndContinuous)
{
  Rng rng(11);
  Model m = randomModel(rng, 4, 3, {1, 2}, 2, 1);
  EstimatorSettings kfio;
  kfio.algorithm = Algorithm::KFIO;
  auto a = makeEstimator(m, rseioSettings(1.0));
  auto b = makeEstimator(m, kfio);
  auto c = makeEstimator(m, rseioSettings(1.0 - 1e-13));
  Rng data(12);
  for (int k = 0; k < 300; ++k)
  {
    Sample s;
    s.gamma = data.bernoulli(0.7);
    s.y = randomMatrix(data, m.m(), 1, 3.0);
    s.u = randomMatrix(data, 1, 1);
    a->step(s);
    b->step(s);
    c->step(s);
    ASSERT_EQ(a->state(), b->state()) << "step " << k;
    ASSERT_EQ(a->covariance(), b->covariance()) << "step " << k;
    ASSERT_LT(relErr(c->covariance(), b->covariance()), 1e-9) << "step " << k;
    ASSERT_LT(relErr(c->state(), b->state()), 1e-9) << "step " << k;
  }
}

// Without uncertainty (S = T = 0) RSEIO is KFIO for any mu.
TEST(Rseio, NoUncertaintyIsKfioForAnyMu)
{
  Rng rng(13);
  Model m = randomModel(rng, 3, 2, {2}, 0, 0);
  EstimatorSettings kfio;
  kfio.algorithm = Algorithm::KFIO;
  auto a = makeEstimator(m, rseioSettings(0.3));
  auto b = makeEstimator(m, kfio);
  for (int k = 0; k < 50; ++k)
  {
    Sample s;
    s.gamma = k % 3 != 0;
    s.y = randomMatrix(rng, m.m(), 1);
    a->step(s);
    b->step(s);
  }
  EXPECT_LT(maxAbsDiff(a->covariance(), b->covariance()), 1e-12);
  EXPECT_LT(maxAbsDiff(a->state(), b->state()), 1e-12);
}

// Theorem 2 (docs/algorithms.md 4.9): the analysis form gives the same P+ as Theorem 1 on arrival steps.
TEST(Rseio, TheoremTwoFormAgreesWithTheoremOne)
{
  Rng rng(31);
  int checked = 0;
  for (int trial = 0; trial < 30; ++trial)
  {
    Model m = randomModel(rng, 2 + trial % 3, 1 + trial % 2, {1 + trial % 2}, 1 + trial % 2, 0);
    const double mu = rng.uniform(0.3, 0.95);
    RseioAnalysisForm f;
    try
    {
      f = rseioAnalysisForm(m, mu);
    }
    catch (const ConfigError&)
    {
      continue;  // Acheck singular: Theorem 2 does not apply
    }
    auto est = makeEstimator(m, rseioSettings(mu));
    Sample s;
    s.y = randomMatrix(rng, m.m(), 1);
    const MatrixXd P = est->covariance();
    est->step(s);
    EXPECT_LT(relErr(f.arrivalCovariance(P, m.B), est->covariance()), 1e-9) << "trial " << trial;
    ++checked;
  }
  EXPECT_GE(checked, 25);
}

// Zhou's example: its derived quantities for mu = 0.8 (docs/algorithms.md 6.1, Z6).
TEST(Rseio, ZhouExampleAnalysisValues)
{
  const Model m = zhouModel();
  const RseioAnalysisForm f = rseioAnalysisForm(m, 0.8);
  MatrixXd Atil(2, 2), Qtil(2, 2), W1(2, 2);
  Atil << 0.9802, 0.019648745, 0, 0.985100750;
  Qtil << 1.960800970, 0.019597495, 0.019597495, 1.970302000;
  W1 << 1, -1, -1, 1.002537553;
  EXPECT_LT(maxAbsDiff(f.Atil, Atil), 1e-8);
  EXPECT_LT(maxAbsDiff(f.Qtil, Qtil), 1e-8);
  EXPECT_LT(maxAbsDiff(f.Ctil.transpose() * f.Rtil.inverse() * f.Ctil, W1), 1e-8);
}

TEST(Rseio, RejectsMuOutsideUnitInterval)
{
  const Model m = zhouModel();
  EXPECT_THROW(makeEstimator(m, rseioSettings(0.0)), ConfigError);
  EXPECT_THROW(makeEstimator(m, rseioSettings(1.5)), ConfigError);
  try
  {
    makeEstimator(m, rseioSettings(-0.1));
    FAIL();
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("mu"), std::string::npos);
  }
}

// Per-sensor loss: with one of two sensors missing, the arrival step equals the brute-force
// minimiser of the model restricted to the received sensor.
TEST(Rseio, PartialArrivalUsesReceivedSensorsOnly)
{
  Rng rng(99);
  Model m = randomModel(rng, 3, 2, {1, 2}, 2, 0);
  Model sub = m;
  const std::vector<int> rows = {1, 2};
  sub.C = selectRows(m.C, rows);
  sub.R = selectBlock(m.R, rows, rows);
  for (auto& u : sub.uncertainty)
    u.dC = selectRows(u.dC, rows);
  singleSensor(sub);
  const VectorXd y2 = randomMatrix(rng, 2, 1);
  VectorXd xb;
  MatrixXd Pb;
  bruteForce(sub, 0.6, m.x0, m.P0, y2, VectorXd(), xb, Pb);
  auto est = makeEstimator(m, rseioSettings(0.6));
  Sample s;
  s.y.resize(3);
  s.y << std::numeric_limits<double>::quiet_NaN(), y2[0], y2[1];
  est->step(s);
  EXPECT_LT(relErr(est->covariance(), Pb), 1e-10);
  EXPECT_LT(relErr(est->state(), xb), 1e-10);
}
