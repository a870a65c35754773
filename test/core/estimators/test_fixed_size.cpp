// The fixed-size forms of the estimators (src/core/estimators/estimator_sizes.hpp) against the
// dynamic form of the same algorithm on the same model: the same estimate at every step (within
// 1e-12 relative) through arrivals, whole and per-sensor losses, inputs, reset() and clone(); and
// which form makeEstimator picks for which sizes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "estimators/estimator_factory.hpp"  // private header: makeEstimator with the choice of form
#include "estimators/rseio_estimator.hpp"    // private header: which form an rseio arrival step used
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "test_support.hpp"

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kTolerance = 1e-12;

const std::vector<Algorithm> kAlgorithms = {Algorithm::KF,    Algorithm::KFIO, Algorithm::ACK_KF,
                                            Algorithm::RSEIO, Algorithm::AOE,  Algorithm::OE};

EstimatorSettings settingsFor(Algorithm a, double mu = 0.7)
{
  EstimatorSettings s;
  s.algorithm = a;
  s.mu = mu;
  s.has_control_link = true;
  s.recovery = 0.6;
  s.failure = 0.3;
  s.max_components = 8;
  return s;
}

std::unique_ptr<Estimator> make(const Model& m, Algorithm a, detail::SizeChoice choice)
{
  return detail::makeEstimator(m, settingsFor(a), choice);
}

/// max |a - b| relative to max |b| (normwise; exact zeros compare exactly).
double relDiff(const MatrixXd& a, const MatrixXd& b)
{
  if (a.rows() != b.rows() || a.cols() != b.cols())
    return std::numeric_limits<double>::infinity();
  const double scale = b.cwiseAbs().maxCoeff();
  const double diff = (a - b).cwiseAbs().maxCoeff();
  return diff == 0.0 ? 0.0 : diff / scale;
}

/// A model of the given shape (test_support's randomModel) with A scaled to spectral radius `rho`.
struct Shape
{
  int n, nw;
  std::vector<int> sensors;
  int ne, p;
};

Model shapedModel(Rng& rng, const Shape& sh, double rho)
{
  Model m = randomModel(rng, sh.n, sh.nw, sh.sensors, sh.ne, sh.p);
  const double r = Eigen::EigenSolver<MatrixXd>(m.A, false).eigenvalues().cwiseAbs().maxCoeff();
  if (r > 0.0)
    m.A *= rho / r;
  validateModel(m, "shaped");
  return m;
}

/// A random sample for m: gamma ~ 0.75; each sensor of an arrived sample missing (NaN) with
/// probability 0.25; u random, sometimes empty (zero input); nu random.
Sample randomSample(Rng& rng, const Model& m)
{
  Sample s;
  s.gamma = rng.uniform() < 0.75;
  s.y = 2.0 * randomMatrix(rng, m.m(), 1);
  if (m.sensors.size() > 1)
    for (const Sensor& sensor : m.sensors)
      if (rng.uniform() < 0.25)
        s.y.segment(sensor.offset, sensor.size).setConstant(kNaN);
  if (m.p() > 0 && rng.uniform() < 0.85)
    s.u = randomMatrix(rng, m.p(), 1, 1.5);
  s.nu = rng.uniform() < 0.6 ? 1 : 0;
  return s;
}

/// Largest relative difference of everything the interface shows; fails the test at once when
/// the two disagree beyond kTolerance.
double compare(const Estimator& fixed, const Estimator& dyn, const std::string& what)
{
  const double dx = relDiff(fixed.state(), dyn.state());
  const double dP = relDiff(fixed.covariance(), dyn.covariance());
  EXPECT_LE(dx, kTolerance) << what << " state";
  EXPECT_LE(dP, kTolerance) << what << " covariance";
  EXPECT_TRUE(fixed.covariance() == fixed.covariance().transpose()) << what;
  EXPECT_EQ(fixed.steps(), dyn.steps()) << what;
  EXPECT_EQ(fixed.lastUpdated(), dyn.lastUpdated()) << what;
  EXPECT_EQ(fixed.components(), dyn.components()) << what;
  const double pf = fixed.commandArrivalProbability(), pd = dyn.commandArrivalProbability();
  double dp = 0.0;
  if (std::isnan(pd))
    EXPECT_TRUE(std::isnan(pf)) << what;
  else
    dp = std::abs(pf - pd);
  EXPECT_LE(dp, kTolerance) << what << " command arrival probability";
  return std::max({dx, dP, dp});
}

/// Whether one of the sizes S... is (n, m, nw).
template <class... S>
bool listed(detail::SizeList<S...> /*list*/, int n, int m, int nw)
{
  return ((S::N == n && S::M == m && (S::NW == detail::kDynamic || S::NW == nw)) || ...);
}

/// Whether makeEstimator should give algorithm a its fixed-size form for these sizes.
bool hasFixedForm(Algorithm a, int n, int m, int nw)
{
  return a == Algorithm::RSEIO ? listed(detail::RseioSizes(), n, m, nw) : listed(detail::KalmanSizes(), n, m, nw);
}

// Shapes of the instantiated sizes: one or two sensors, inputs or none, one or two uncertain
// parameters (rseio's rank form when rank [S T] <= n, its Gram form otherwise); some sizes have a
// fixed form for the Kalman filters, aoe and oe but not for rseio (n = 1 with m = 2, n = 4 with m = 4,
// nw != n).
const std::vector<Shape> kShapes = {
    {1, 1, {1}, 1, 1}, {1, 1, {1}, 2, 1},    {1, 1, {1, 1}, 1, 0}, {2, 2, {1}, 1, 1},
    {2, 2, {1}, 2, 0}, {2, 2, {1, 1}, 2, 1}, {2, 2, {2}, 1, 0},    {2, 2, {2}, 2, 1},
    {2, 1, {1}, 1, 1}, {4, 4, {1, 1}, 1, 1}, {4, 4, {2}, 2, 1},    {4, 4, {2, 2}, 2, 1},
    {4, 2, {2, 2}, 1, 1},
};

}  // namespace

// Every algorithm, every shape, two models each (one stable, one with an unstable mode), 600
// steps with arrivals and losses, reset() twice and a clone() that takes over: the fixed form
// follows the dynamic one.
TEST(FixedSize, EqualsDynamicOverManySteps)
{
  Rng rng(20251201);
  double worst = 0.0;
  std::map<std::string, int> forms;
  std::map<Algorithm, int> compared;  // models on which the fixed form ran
  for (std::size_t c = 0; c < kShapes.size(); ++c)
  {
    for (double rho : {0.9, 1.05})
    {
      const Model m = shapedModel(rng, kShapes[c], rho);
      for (Algorithm a : kAlgorithms)
      {
        const std::string what = toString(a) + " shape " + std::to_string(c) + " rho " + std::to_string(rho);
        std::unique_ptr<Estimator> fixed = make(m, a, detail::SizeChoice::AUTOMATIC);
        std::unique_ptr<Estimator> dyn = make(m, a, detail::SizeChoice::DYNAMIC);
        ASSERT_EQ(dyn->implementation(), "dynamic") << what;
        if (!hasFixedForm(a, m.n(), m.m(), m.nw()))
        {
          EXPECT_EQ(fixed->implementation(), "dynamic") << what;
          continue;
        }
        ASSERT_EQ(fixed->implementation().rfind("fixed", 0), 0u) << what << ": " << fixed->implementation();
        ++compared[a];
        Rng data(deriveSeed(77, c));
        for (int k = 0; k < 600; ++k)
        {
          if (k == 200 || k == 450)
          {
            fixed->reset();
            dyn->reset();
            worst = std::max(worst, compare(*fixed, *dyn, what + " after reset at " + std::to_string(k)));
            EXPECT_EQ(fixed->steps(), 0) << what;
          }
          if (k == 300)
          {
            // the copies take over: a clone keeps the form and the state
            fixed = fixed->clone();
            dyn = dyn->clone();
            EXPECT_EQ(fixed->implementation().rfind("fixed", 0), 0u) << what;
          }
          const Sample s = randomSample(data, m);
          fixed->step(s);
          dyn->step(s);
          worst = std::max(worst, compare(*fixed, *dyn, what + " k " + std::to_string(k)));
          if (a == Algorithm::RSEIO && fixed->lastUpdated())
            ++forms[dynamic_cast<const detail::Rseio&>(*fixed).lastForm()];
          if (::testing::Test::HasFailure())
            return;
        }
      }
    }
  }
  // every algorithm compared on several models (two per shape), both forms of rseio's arrival
  // step on the fixed-size path
  for (Algorithm a : kAlgorithms)
    EXPECT_EQ(compared[a], a == Algorithm::RSEIO ? 18 : 26) << toString(a);
  EXPECT_GT(forms["rank"], 100);
  EXPECT_GT(forms["gram"], 100);
  RecordProperty("worst_relative_difference", std::to_string(worst));
  std::printf("largest relative difference fixed vs dynamic: %.3g\n", worst);
}

// A plant that only diverges (no measurement ever arrives): both forms report the divergence at
// the same step, refuse to step on, and start over alike after reset().
TEST(FixedSize, DivergesAtTheSameStep)
{
  Rng rng(3);
  Model m = shapedModel(rng, {2, 2, {1}, 1, 1}, 40.0);
  for (Algorithm a : kAlgorithms)
  {
    auto fixed = make(m, a, detail::SizeChoice::AUTOMATIC);
    auto dyn = make(m, a, detail::SizeChoice::DYNAMIC);
    ASSERT_NE(fixed->implementation(), "dynamic");
    Sample s;
    s.gamma = false;
    s.u = VectorXd::Ones(1);
    s.nu = 1;
    long fixed_at = -1, dyn_at = -1;
    for (long k = 0; k < 2000 && (fixed_at < 0 || dyn_at < 0); ++k)
    {
      if (fixed_at < 0)
        try
        {
          fixed->step(s);
        }
        catch (const DivergenceError&)
        {
          fixed_at = k;
        }
      if (dyn_at < 0)
        try
        {
          dyn->step(s);
        }
        catch (const DivergenceError&)
        {
          dyn_at = k;
        }
    }
    EXPECT_GT(fixed_at, 10) << toString(a);
    EXPECT_EQ(fixed_at, dyn_at) << toString(a);
    EXPECT_THROW(fixed->step(s), DivergenceError) << toString(a);
    fixed->reset();
    dyn->reset();
    s.gamma = true;
    s.y = VectorXd::Ones(1);
    fixed->step(s);
    dyn->step(s);
    compare(*fixed, *dyn, toString(a) + " after reset");
  }
}

// Malformed input is refused by the fixed form as by the dynamic one, leaving the estimate as it was.
TEST(FixedSize, RejectsBadInputLikeTheDynamicForm)
{
  Rng rng(8);
  const Model m = shapedModel(rng, {2, 2, {1, 1}, 1, 1}, 0.9);
  for (Algorithm a : kAlgorithms)
  {
    auto fixed = make(m, a, detail::SizeChoice::AUTOMATIC);
    ASSERT_NE(fixed->implementation(), "dynamic");
    Sample good;
    good.y = VectorXd::Ones(2);
    good.u = VectorXd::Ones(1);
    good.nu = 1;
    fixed->step(good);
    const VectorXd x = fixed->state();
    const MatrixXd P = fixed->covariance();
    Sample wrong_y = good;
    wrong_y.y = VectorXd::Ones(3);
    Sample wrong_u = good;
    wrong_u.u = VectorXd::Ones(2);
    Sample infinite = good;
    infinite.y[1] = std::numeric_limits<double>::infinity();
    for (const Sample* bad : {&wrong_y, &wrong_u, &infinite})
    {
      EXPECT_THROW(fixed->step(*bad), InputError) << toString(a);
      EXPECT_EQ(fixed->state(), x) << toString(a);
      EXPECT_EQ(fixed->covariance(), P) << toString(a);
      EXPECT_EQ(fixed->steps(), 1) << toString(a);
    }
  }
}

// makeEstimator picks the fixed form for the instantiated sizes (estimator_sizes.hpp), the dynamic
// one for everything else; rseio's fixed forms also need nw = n.
TEST(FixedSize, FactoryPicksTheFormFromTheSizes)
{
  Rng rng(11);
  auto formOf = [&](int n, int nw, std::vector<int> sensors, Algorithm a) {
    const Model m = shapedModel(rng, {n, nw, sensors, 1, 1}, 0.9);
    return makeEstimator(m, settingsFor(a))->implementation();
  };
  int fixed_forms = 0;
  for (int n = 1; n <= 6; ++n)
    for (int rows = 1; rows <= 4; ++rows)
    {
      const std::string sizes = "n=" + std::to_string(n) + " m=" + std::to_string(rows);
      for (Algorithm a : kAlgorithms)
      {
        const bool fixed = hasFixedForm(a, n, rows, n);
        const std::string expected =
            fixed ? "fixed " + sizes + (a == Algorithm::RSEIO ? " nw=" + std::to_string(n) : "") : "dynamic";
        EXPECT_EQ(formOf(n, n, {rows}, a), expected) << toString(a);
        fixed_forms += fixed ? 1 : 0;
        if (a != Algorithm::RSEIO)
          EXPECT_EQ(formOf(n, 1, std::vector<int>(rows, 1), a), expected) << toString(a) << " (nw = 1)";
      }
    }
  EXPECT_EQ(fixed_forms, 5 * 6 + 4);  // the lists of estimator_sizes.hpp
  EXPECT_EQ(formOf(2, 2, {1}, Algorithm::KFIO), "fixed n=2 m=1");
  EXPECT_EQ(formOf(2, 2, {1}, Algorithm::RSEIO), "fixed n=2 m=1 nw=2");
  EXPECT_EQ(formOf(4, 4, {2, 2}, Algorithm::KFIO), "fixed n=4 m=4");
  // beyond the instantiated sizes: dynamic
  for (Algorithm a : kAlgorithms)
  {
    EXPECT_EQ(formOf(7, 7, {1}, a), "dynamic") << toString(a);
    EXPECT_EQ(formOf(8, 8, {4}, a), "dynamic") << toString(a);
    EXPECT_EQ(formOf(20, 20, {10}, a), "dynamic") << toString(a);
    EXPECT_EQ(formOf(2, 2, {2, 2}, a), "dynamic") << toString(a);  // m = 4 > n
    EXPECT_EQ(formOf(5, 5, {1, 1, 1}, a), "dynamic") << toString(a);
    EXPECT_EQ(formOf(3, 3, {1, 1, 1}, a), "dynamic") << toString(a);
  }
  // rseio's step uses nw: a model with nw != n stays dynamic, the Kalman filters do not care
  EXPECT_EQ(formOf(4, 2, {2}, Algorithm::RSEIO), "dynamic");
  EXPECT_EQ(formOf(4, 2, {2}, Algorithm::KFIO), "fixed n=4 m=2");
  // asking for the dynamic form gets it whatever the sizes
  const Model small = shapedModel(rng, {2, 2, {1}, 1, 1}, 0.9);
  for (Algorithm a : kAlgorithms)
    EXPECT_EQ(detail::makeEstimator(small, settingsFor(a), detail::SizeChoice::DYNAMIC)->implementation(), "dynamic");
}
