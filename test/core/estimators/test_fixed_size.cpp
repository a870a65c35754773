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
    {1, 1, {1}, 1, 1},    {1, 1, {1}, 2, 1},    {1, 1, {1, 1}, 1, 0}, {2, 2, {1}, 1, 1}, {2, 2, {1}, 2, 0},
    {2, 2, {1, 1}, 2, 1}, {2, 2, {2}, 1, 0},    {2, 2, {2}, 2, 1},    {2, 1, {1}, 1, 1}, {4, 4, {1, 1}, 1, 1},
    {4, 4, {2}, 2, 1},    {4, 4, {2, 2}, 2, 1}, {4, 2, {2, 2}, 1, 1},
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
  auto formOf = [&](int n, int nw, std::vector<int> sensors, Algorithm a)
  {
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

namespace
{

/// Whether a and b show the same estimate, bit for bit (state, covariance, steps, lastUpdated,
/// command arrival probability, components).
void expectIdentical(const Estimator& a, const Estimator& b, const std::string& what)
{
  ASSERT_TRUE(a.state() == b.state()) << what << "\n" << a.state().transpose() << "\n" << b.state().transpose();
  ASSERT_TRUE(a.covariance() == b.covariance()) << what;
  ASSERT_EQ(a.steps(), b.steps()) << what;
  ASSERT_EQ(a.lastUpdated(), b.lastUpdated()) << what;
  ASSERT_EQ(a.components(), b.components()) << what;
  const double pa = a.commandArrivalProbability(), pb = b.commandArrivalProbability();
  ASSERT_TRUE(pa == pb || (std::isnan(pa) && std::isnan(pb))) << what;
}

/// The sample with one of its arrived sensors (chosen by rng) removed, as a gate refuses it.
Sample withoutOneSensor(Rng& rng, const Model& m, const Sample& s)
{
  Sample g = s;
  std::vector<std::size_t> arrived;
  for (std::size_t i = 0; i < m.sensors.size(); ++i)
    if (s.y.size() == m.m() && std::isfinite(s.y[m.sensors[i].offset]))
      arrived.push_back(i);
  if (arrived.empty())
    return g;
  const Sensor& sn = m.sensors[arrived[static_cast<std::size_t>(rng.uniform() * arrived.size()) % arrived.size()]];
  g.y.segment(sn.offset, sn.size).setConstant(kNaN);
  g.gamma = arrived.size() > 1 && s.gamma;
  return g;
}

const std::vector<Algorithm> kEveryAlgorithm = {Algorithm::KF,  Algorithm::KFIO, Algorithm::ACK_KF, Algorithm::RSEIO,
                                                Algorithm::AOE, Algorithm::OE,   Algorithm::EKFIO};

}  // namespace

// step(s) is predict(s) then update(s), bit for bit, for every algorithm in both forms over every
// shape; and predict(s) then update(s') with a sensor of s refused (what the rejection threshold
// does) equals step(s'): rseio, whose prediction depends on the sensors in hand, predicts again.
// (New API: does not compile on the code before Estimator::predict.)
TEST(PredictUpdate, EqualsStepBitForBitInBothForms)
{
  Rng rng(20261207);
  int refused = 0;
  for (std::size_t c = 0; c < kShapes.size(); ++c)
  {
    const Model m = shapedModel(rng, kShapes[c], c % 2 ? 1.05 : 0.9);
    for (Algorithm a : kEveryAlgorithm)
      for (detail::SizeChoice choice : {detail::SizeChoice::AUTOMATIC, detail::SizeChoice::DYNAMIC})
      {
        auto whole = make(m, a, choice);
        auto split = make(m, a, choice);
        const std::string what = toString(a) + " " + whole->implementation() + " shape " + std::to_string(c);
        Rng data(deriveSeed(91, c));
        for (int k = 0; k < 300; ++k)
        {
          const Sample s = randomSample(data, m);
          const bool refuse = data.uniform() < 0.3;
          const Sample t = refuse ? withoutOneSensor(data, m, s) : s;
          refused += (t.y.array() == t.y.array()).count() < (s.y.array() == s.y.array()).count() ? 1 : 0;
          whole->step(t);
          const VectorXd before = split->state();
          const MatrixXd before_P = split->covariance();
          const Prior& prior = split->predict(s);
          ASSERT_EQ(prior.mean().size(), m.n()) << what;
          // the estimate is not touched by the prediction
          ASSERT_EQ(split->steps(), k) << what;
          ASSERT_TRUE(split->state() == before && split->covariance() == before_P) << what;
          split->update(t);
          expectIdentical(*whole, *split, what + " k " + std::to_string(k));
        }
      }
  }
  EXPECT_GT(refused, 1000);
}

// update() without a pending prediction is refused, naming the cause; step() and reset() end a
// prediction. (New API.)
TEST(PredictUpdate, UpdateNeedsAPendingPrediction)
{
  Rng rng(4);
  const Model m = shapedModel(rng, {2, 2, {1}, 1, 1}, 0.9);
  for (Algorithm a : kEveryAlgorithm)
  {
    auto est = make(m, a, detail::SizeChoice::AUTOMATIC);
    const Sample s = randomSample(rng, m);
    try
    {
      est->update(s);
      ADD_FAILURE() << toString(a) << ": update without predict was accepted";
    }
    catch (const InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find("call predict(sample) first"), std::string::npos) << e.what();
    }
    est->predict(s);
    est->step(s);
    EXPECT_THROW(est->update(s), InputError) << toString(a);
    est->predict(s);
    est->reset();
    EXPECT_THROW(est->update(s), InputError) << toString(a);
    EXPECT_EQ(est->steps(), 0) << toString(a);
  }
}

// snapshot() is the whole state: an estimator restored from it (a fresh one, or one that ran
// elsewhere, of either form) steps exactly as the original, bit for bit in the same form and
// within 1e-12 across forms; a snapshot of another algorithm or size is refused. (New API.)
TEST(Snapshot, RestoreThenStepEqualsTheOriginal)
{
  Rng rng(77);
  for (std::size_t c = 0; c < kShapes.size(); ++c)
  {
    const Model m = shapedModel(rng, kShapes[c], 1.05);
    for (Algorithm a : kEveryAlgorithm)
    {
      auto original = make(m, a, detail::SizeChoice::AUTOMATIC);
      auto same = make(m, a, detail::SizeChoice::AUTOMATIC);
      auto other = make(m, a, detail::SizeChoice::DYNAMIC);
      const std::string what = toString(a) + " " + original->implementation() + " shape " + std::to_string(c);
      Rng data(deriveSeed(5, c));
      for (int k = 0; k < 60; ++k)
      {
        const Sample s = randomSample(data, m);
        original->step(s);
        if (k < 20)
          same->step(randomSample(data, m));  // elsewhere: another history
      }
      const EstimatorState state = original->snapshot();
      EXPECT_EQ(state.steps, 60) << what;
      same->predict(randomSample(data, m));  // a pending prediction is dropped by restore
      same->restore(state);
      other->restore(state);
      expectIdentical(*original, *same, what + " restored");
      EXPECT_THROW(same->update(randomSample(data, m)), InputError) << what;
      for (int k = 0; k < 60; ++k)
      {
        const Sample s = randomSample(data, m);
        original->step(s);
        same->step(s);
        other->step(s);
        expectIdentical(*original, *same, what + " k " + std::to_string(k));
        compare(*other, *original, what + " other form k " + std::to_string(k));
        if (::testing::Test::HasFailure())
          return;
      }
    }
  }
  Rng r2(8);
  const Model m = shapedModel(r2, {2, 2, {1}, 1, 1}, 0.9);
  auto kfio = make(m, Algorithm::KFIO, detail::SizeChoice::AUTOMATIC);
  auto oe = make(m, Algorithm::OE, detail::SizeChoice::AUTOMATIC);
  EXPECT_THROW(kfio->restore(oe->snapshot()), InputError);
  EstimatorState wrong = kfio->snapshot();
  wrong.P = MatrixXd::Identity(3, 3);
  EXPECT_THROW(kfio->restore(wrong), InputError);
  EstimatorState no_mixture = oe->snapshot();
  no_mixture.means.resize(2, 0);
  EXPECT_THROW(oe->restore(no_mixture), InputError);
}

// kfio's Prior: the mean A x + Bu u, the covariance A P A' + B Q B', and each sensor's S_i =
// C_i Pp C_i' + R_i, with the model's R or the sample's own; in both forms. (New API.)
TEST(PredictUpdate, KfioPriorIsItsPrediction)
{
  Rng rng(12);
  const Model m = shapedModel(rng, {4, 4, {2, 2}, 1, 1}, 0.95);
  for (detail::SizeChoice choice : {detail::SizeChoice::AUTOMATIC, detail::SizeChoice::DYNAMIC})
  {
    auto est = make(m, Algorithm::KFIO, choice);
    Rng data(3);
    for (int k = 0; k < 30; ++k)
    {
      Sample s = randomSample(data, m);
      if (k % 3 == 0)
      {
        s.R = m.R;
        s.R.block(2, 2, 2, 2) = randomSpd(data, 2);
      }
      const VectorXd x = est->state();
      const MatrixXd P = est->covariance();
      const Prior& prior = est->predict(s);
      VectorXd xp = m.A * x;
      if (s.u.size())
        xp += m.Bu * s.u;
      const MatrixXd Pp = m.A * P * m.A.transpose() + m.B * m.Q * m.B.transpose();
      EXPECT_LE(relDiff(prior.mean(), xp), 1e-13) << k;
      EXPECT_LE(relDiff(prior.covariance(), Pp), 1e-13) << k;
      ASSERT_EQ(prior.sensors(), 2u);
      const MatrixXd& R = s.R.size() ? s.R : m.R;
      for (std::size_t i = 0; i < 2; ++i)
      {
        const Sensor& sn = m.sensors[i];
        const MatrixXd Ci = m.C.middleRows(sn.offset, sn.size);
        const MatrixXd Si = Ci * Pp * Ci.transpose() + R.block(sn.offset, sn.offset, sn.size, sn.size);
        EXPECT_LE(relDiff(prior.innovationCovariance(i), Si), 1e-13) << est->implementation() << " k " << k;
      }
      EXPECT_THROW(prior.innovationCovariance(2), InputError);
      est->update(s);
    }
  }
}
