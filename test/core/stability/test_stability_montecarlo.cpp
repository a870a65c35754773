// Monte Carlo cross-checks of the stability verdicts (stability.hpp) with the core's loss models and
// estimator: E[trace P_k] bounded on the stable side of a computed boundary and growing on the other,
// for one common rate, for one sensor's rate with the other sensor's link fixed, and for the ends of
// a stable interval of recovery rates (where the growth is too slow for the mean of trace P, the
// decay rate Phi of "the received rows do not determine the state" is estimated instead).
// Fixed seeds; every bound is derived in the comment above its test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <memory>
#include <vector>

#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"
#include "stability_test_support.hpp"

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;

namespace
{

/// Sample mean over `runs` runs of trace P_k, k = 1..steps, of KFIO when sensor j's packets cross
/// links[j] (the core's loss model, one independent stream per sensor and run, as the simulator
/// draws them). P_k depends on the arrivals only, so no measurement values are needed.
std::vector<double> meanTrace(const Model& m, const std::vector<ChannelSettings>& links, int runs, int steps,
                              std::uint64_t seed)
{
  EstimatorSettings s;
  s.algorithm = Algorithm::KFIO;
  auto est = makeEstimator(m, s);
  std::vector<std::unique_ptr<LossModel>> loss;
  for (const ChannelSettings& c : links)
    loss.push_back(makeLossModel(c, 0));
  Sample sample;
  sample.y = Eigen::VectorXd::Zero(m.m());
  std::vector<double> mean(steps, 0.0);
  for (int r = 0; r < runs; ++r)
  {
    for (std::size_t j = 0; j < loss.size(); ++j)
      loss[j]->reseed(deriveSeed(deriveSeed(seed, static_cast<std::uint64_t>(r)), j));
    est->reset();
    for (int k = 0; k < steps; ++k)
    {
      bool any = false;
      for (std::size_t j = 0; j < m.sensors.size(); ++j)
      {
        const bool arrived = !loss[j]->nextLost();
        any = any || arrived;
        const Sensor& sn = m.sensors[j];
        sample.y.segment(sn.offset, sn.size).setConstant(arrived ? 0.0 : std::numeric_limits<double>::quiet_NaN());
      }
      sample.gamma = any;
      est->step(sample);
      mean[k] += est->covariance().trace() / runs;
    }
  }
  return mean;
}

std::vector<ChannelSettings> iidChannels(const std::vector<double>& arrival)
{
  std::vector<ChannelSettings> out;
  for (double a : arrival)
    out.push_back(bernoulli(1.0 - a));
  return out;
}

/// The growth ratio E[tr P_k2] / E[tr P_k1] when E[tr P_k] = a + b sum_{j <= k} g^j (see the tests):
/// (g^{k2+1} - 1) / (g^{k1+1} - 1), and (k2 + 1) / (k1 + 1) at g = 1, increasing in g.
double burstRatio(double g, int k1, int k2)
{
  if (std::abs(g - 1.0) < 1e-12)
    return (k2 + 1.0) / (k1 + 1.0);
  return (std::pow(g, k2 + 1) - 1.0) / (std::pow(g, k1 + 1) - 1.0);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// One common rate: E[trace P] bounded at 1.1x the critical rate, growing at 0.9x

TEST(StabilityMonteCarlo, CriticalRate)
{
  // E[P_k] is driven by loss bursts: a burst of length j has probability ~ (1 - lambda)^j and
  // inflates P by ~ rho^2j, so E[P_k] ~ sum_{j <= k} g^j with g = rho^2 (1 - lambda): it grows like
  // g^k below the critical rate (g > 1) and stays bounded above it (g < 1). A sample of N runs only
  // contains bursts up to about ln N / ln(1 / (1 - lambda)) steps, so the growth is visible only over
  // that horizon; we compare k = 5 and k = 8 with N = 40000 (bursts of 8 steps are seen about
  // N (1 - lambda)^8 >= 10 times for the rates below). Below (g = 0.9 + 0.1 rho^2 >= 1.3) the expected
  // ratio is about g^3 >= 2.2, we require > 1.6. Above (g = 1.1 - 0.1 rho^2 <= 0.7) the ratio is
  // 1 + O(g^6) <= 1.15, we require < 1.3.
  struct Case
  {
    MatrixXd A, C;
  };
  const std::vector<Case> cases = {{mat(1, 1, {2.0}), mat(1, 1, {1})}, {mat(2, 2, {2, 0, 0, 3}), mat(1, 2, {1, 1})}};
  for (const Case& c : cases)
  {
    const Model m = simpleModel(c.A, c.C);
    const double crit = analyzeStability(m, nullptr).model.exact_rate;
    ASSERT_TRUE(std::isfinite(crit));
    // Normalised by the no-loss trace to remove the start-up transient from P0.
    const std::vector<double> full = meanTrace(m, iidChannels({1.0}), 1, 8, 77);
    const std::vector<double> above = meanTrace(m, iidChannels({std::min(0.999, 1.1 * crit)}), 40000, 8, 77);
    const std::vector<double> below = meanTrace(m, iidChannels({0.9 * crit}), 40000, 8, 77);
    const double ra = (above[7] / full[7]) / (above[4] / full[4]);
    const double rb = (below[7] / full[7]) / (below[4] / full[4]);
    EXPECT_LT(ra, 1.3) << c.A;
    EXPECT_GT(rb, 1.6) << c.A;
    std::printf("critical %.6f: growth ratio k=8/k=5 above %.3f below %.3f\n", crit, ra, rb);
  }
}

// ---------------------------------------------------------------------------------------------
// One sensor's rate, the other sensor's link fixed: two 2-sensor systems

// The boundary is the rate sensor 2 needs as analyze computes it (its per-sensor margin), with
// sensor 1's rate fixed. Both systems have |alpha| close to 1, so that the rare events that drive
// E[P] near the boundary (a probability |alpha|^-2 per step) are common enough to be sampled.
//   A: A = diag(1.2, 0.5), c_1 = [1 1], c_2 = [1 0], lambda_1 = 0.05: the mode 1.2 is a 1-D block seen by both
//      sensors, Phi = (1 - lambda_1)(1 - lambda_2), boundary 1.44 (1 - lambda_1)(1 - lambda_2) = 1.
//   B: A = diag(1.15, -1.15), c_1 = c_2 = [1 1]: one block of order 2, each lattice element seen at
//      one phase of two, Phi = ((1 - lambda_1)(1 - lambda_2))^{1/2}, lambda_1 = 0.05.
// Sensor 2 is put at 1 - lambda_2 = f (1 - lambda_2*) with f = 1.3 (below the boundary) and f = 0.7
// (above), so the growth per step g = |alpha|^2 Phi is 1.3 and 0.7 for A, 1.3^{1/2} = 1.140 and
// 0.7^{1/2} = 0.837 for B.
// Statistic: a burst of j steps in which the mode is not seen has probability ~ Phi^j and inflates
// P by ~ |alpha|^{2j}, so E[tr P_k] ~ a + b sum_{j <= k} g^j and the ratio E[tr P_20] / E[tr P_10]
// is burstRatio(g) (above): 1.909 at g = 1, >= 4.5 below the boundary here and <= 1.14 above. With
// N = 20000 runs the longest bursts that matter (20 steps, probability Phi^20 >= 0.05 below the
// boundary) are seen >= 1000 times, so the sample mean of that tail is within ~ 3 % (1/sqrt(1000)),
// far inside the gap to 1.909; we require > 1.909 below and < 1.909 above, and the ratio within a
// factor 1.5 of burstRatio(g) (the model's prefactors, not the noise, limit its accuracy).
TEST(StabilityMonteCarlo, PerSensorBoundaryTwoSystems)
{
  struct System
  {
    const char* name;
    Model model;
    double lambda1;
    bool lattice;  // Phi = ((1 - l1)(1 - l2))^{1/2} instead of (1 - l1)(1 - l2)
  };
  const std::vector<System> systems = {
      {"A", multiModel(mat(2, 2, {1.2, 0, 0, 0.5}), {mat(1, 2, {1, 1}), mat(1, 2, {1, 0})}), 0.05, false},
      {"B", multiModel(mat(2, 2, {1.15, 0, 0, -1.15}), {mat(1, 2, {1, 1}), mat(1, 2, {1, 1})}), 0.05, true}};
  const int k1 = 10, k2 = 20, runs = 20000;
  const double at_one = burstRatio(1.0, k1, k2);
  for (const System& s : systems)
  {
    const StabilityReport rep = analyzeStability(s.model, iidLinks({s.lambda1, 0.5}));
    const SensorMargin& mg = rep.links[1].margin;
    ASSERT_TRUE(mg.half_line) << s.name;
    const double need = mg.band.converges_at;
    ASSERT_TRUE(std::isfinite(need) && need > 0.0 && need < 1.0) << s.name << ": " << mg.note;
    for (double f : {1.3, 0.7})
    {
      const double lambda2 = 1.0 - f * (1.0 - need);
      ASSERT_GE(lambda2, 0.0) << s.name;
      // The joint verdict at this rate pair agrees with the side of the boundary.
      const Verdict v = analyzeStability(s.model, iidLinks({s.lambda1, lambda2})).model.verdict;
      EXPECT_EQ(v.kind, f > 1.0 ? Verdict::Kind::UNSTABLE : Verdict::Kind::STABLE) << s.name << " " << v.reason;
      const std::vector<double> mean = meanTrace(s.model, iidChannels({s.lambda1, lambda2}), runs, k2, 2024);
      const double ratio = mean[k2 - 1] / mean[k1 - 1];
      const double g = s.lattice ? std::sqrt(f) : f;
      const double model_ratio = burstRatio(g, k1, k2);
      std::printf(
          "system %s: sensor 2 needs %.6f; at %.4f (f = %.1f) E[tr P_%d]/E[tr P_%d] = %.3f (burst model %.3f, "
          "g = 1: %.3f)\n",
          s.name, need, lambda2, f, k2, k1, ratio, model_ratio, at_one);
      if (f > 1.0)
        EXPECT_GT(ratio, at_one) << s.name << " below the boundary: E[tr P] should grow";
      else
        EXPECT_LT(ratio, at_one) << s.name << " above the boundary: E[tr P] should stay bounded";
      EXPECT_LT(std::abs(std::log(ratio / model_ratio)), std::log(1.5)) << s.name << " f = " << f;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The rotation's stable interval of recovery rates: both sides of both ends

namespace
{

/// U_t: the length of the longest window of steps ending at t over which the rows received from a
/// sensor c (on x_s, s in the window) do not have full column rank, i.e. the window is in the event
/// N^T of Theorem 14 for every T <= U_t. Rows are kept relative to the current step (c A^{s-t},
/// normalised) and tested by Gram-Schmidt, so nothing about the lattice is used. Two states (fixed
/// size: this runs 10^7 steps per rate).
class UnresolvedWindow
{
public:
  UnresolvedWindow(const Eigen::Matrix2d& A, const Eigen::RowVector2d& c) : Ainv_(A.inverse()), c_(c.normalized()) {}

  long update(bool received)
  {
    ++t_;
    for (Eigen::RowVector2d& r : rows_)
      r = (r * Ainv_).normalized();
    if (received)
    {
      rows_.push_front(c_);
      times_.push_front(t_);
    }
    // The newest row spans one dimension; the first older row independent of it resolves the window.
    for (std::size_t i = 1; i < rows_.size(); ++i)
    {
      const Eigen::RowVector2d v = rows_[i] - rows_[i].dot(rows_[0]) * rows_[0];
      if (v.norm() > 1e-9)
      {
        // Older rows can never be needed again: the window [times_[i], t] is already resolved.
        const long s = times_[i];
        rows_.resize(i + 1);
        times_.resize(i + 1);
        return t_ - s;
      }
    }
    return t_ + 1;  // never resolved since the start
  }

private:
  Eigen::Matrix2d Ainv_;
  Eigen::RowVector2d c_;
  std::deque<Eigen::RowVector2d> rows_;
  std::deque<long> times_;
  long t_ = -1;
};

struct PhiEstimate
{
  double phi, sigma_log;  // estimate of Phi and the standard error of ln(phi)
  long n1, n2;            // windows that reached T1 and T2 steps
};

/// Phi from one stationary run of `steps` steps: n_T = number of excursions of U that reach T
/// (U grows by exactly 1 per step during an excursion, so each reaches T at most once), and
/// Phi = (n_T2 / n_T1)^{1/(T2 - T1)}. Given n_T1, n_T2 is about Binomial(n_T1, q) with
/// q = P(reach T2 | reach T1) ~ Phi^{T2 - T1}, so var ln(n_T2 / n_T1) ~ 1/n_T2 - 1/n_T1.
PhiEstimate estimatePhi(const Eigen::Matrix2d& A, const Eigen::RowVector2d& c, const ChannelSettings& link, long steps,
                        int T1, int T2, std::uint64_t seed)
{
  auto loss = makeLossModel(link, seed);
  UnresolvedWindow w(A, c);
  long n1 = 0, n2 = 0;
  const long burn = 1000;
  for (long t = 0; t < steps + burn; ++t)
  {
    const long u = w.update(!loss->nextLost());
    if (t < burn)
      continue;
    n1 += (u == T1);
    n2 += (u == T2);
  }
  PhiEstimate e;
  e.n1 = n1;
  e.n2 = n2;
  e.phi = std::pow(static_cast<double>(n2) / static_cast<double>(n1), 1.0 / (T2 - T1));
  e.sigma_log = std::sqrt(std::max(0.0, 1.0 / n2 - 1.0 / n1)) / (T2 - T1);
  return e;
}

}  // namespace

// A = [[0, -1.2], [1.2, 0]], c = [1 0], on/off Gilbert-Elliott link with p = 0.5: analyze reports
// the stable recovery rates as one interval (about 0.538 < r < 0.962, test_stability.cpp derives it).
// We take the interval from analyze and test r at each end +- delta (0.06 at the lower end, 0.03 at
// the upper end, where the stable side is narrower).
// 1. Phi (the decay rate of P(N^T), which Theorem 14 compares with 1/|alpha|^2) estimated from one
//    run of 10^7 steps of the core's Gilbert-Elliott model, with the generic rank test above: the
//    verdict's side is the sign of ln(|alpha|^2 Phi). Near the ends |alpha|^2 Phi is 0.987 / 1.013
//    (upper) and 0.977 / 1.029 (lower), |ln| >= 0.013; with T1 = 6, T2 = 22 about 1000 excursions
//    reach T2, so sigma(ln Phi) ~ 1/sqrt(1000)/16 = 0.002: we require the sign to match with
//    |ln(|alpha|^2 Phi)| > 4 sigma, and the estimate to agree with the Phi the library computes
//    (blockPhi) within 4 sigma + bias. The bias: P(N^T) = a Phi^T + b psi^T + ..., where the second
//    term counts the windows with no arrival at all (psi = 1 - r, the loss persistence), so
//    ln(n_T2 / n_T1) / 16 is off by about (b/a)(psi/Phi)^T1 / 16, with b/a <= 1: up to 0.0095 at the
//    lower end, 1e-7 at the upper end.
// 2. E[tr P] itself at the lower end, where the growth per step (1.029 vs 0.977) shows over 30
//    steps: ratio E[tr P_30] / E[tr P_10] vs burstRatio at g = 1 (2.818); the burst model gives
//    3.8 below and 2.3 above. N = 60000 runs see the 30-step unresolved windows
//    (probability ~ Phi^30 >= 4e-5 times the excursion rate) often enough that the sample ratio is
//    within ~ 12 % (measured spread over seeds in development: +- 8 %), inside the 25 % gap.
//    At the upper end the growth (1.013 vs 0.987 per step) is masked by the start-up transient at
//    every horizon the rare events can be sampled at, so only the Phi check is made there.
TEST(StabilityMonteCarlo, RotationIntervalEnds)
{
  const Eigen::Matrix2d A = mat(2, 2, {0, -1.2, 1.2, 0});
  const Eigen::RowVector2d c = mat(1, 2, {1, 0});
  const Model m = simpleModel(A, c);
  const ChannelSettings ge = gilbert(0.5, 0.75);
  const StabilityReport rep = analyzeStability(m, &ge);
  ASSERT_EQ(rep.links.size(), 1u);
  ASSERT_EQ(rep.links[0].margin.stable.size(), 1u);
  const RateInterval in = rep.links[0].margin.stable[0];
  const double alpha2 = 1.44;
  const std::vector<BlockStructure> blocks = analyseBlocks(m.A, {m.C});
  ASSERT_EQ(blocks.size(), 1u);
  const BlockStructure& block = blocks.front();
  struct Point
  {
    double r;
    bool stable;
  };
  const std::vector<Point> points = {
      {in.lower - 0.06, false}, {in.lower + 0.06, true}, {in.upper - 0.03, true}, {in.upper + 0.03, false}};
  std::uint64_t seed = 11;
  for (const Point& pt : points)
  {
    ASSERT_GT(pt.r, 0.0);
    ASSERT_LE(pt.r, 1.0);
    const ChannelSettings link = gilbert(0.5, pt.r);
    EXPECT_EQ(analyzeStability(m, &link).model.verdict.kind,
              pt.stable ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE);
    const PhiEstimate e = estimatePhi(A, c, link, 10000000, 6, 22, seed++);
    const double lg = std::log(alpha2 * e.phi);
    const double computed = blockPhi(block, {LinkModel::gilbertElliott(0.5, pt.r)});
    std::printf("r = %.4f: Phi estimate %.5f (computed %.5f), |alpha|^2 Phi = %.4f, sigma(ln) = %.4f, n = %ld / %ld\n",
                pt.r, e.phi, computed, alpha2 * e.phi, e.sigma_log, e.n1, e.n2);
    EXPECT_GT(e.n2, 300) << pt.r;
    if (pt.stable)
      EXPECT_LT(lg, -4.0 * e.sigma_log) << pt.r;
    else
      EXPECT_GT(lg, 4.0 * e.sigma_log) << pt.r;
    const double bias = std::pow(LinkModel::gilbertElliott(0.5, pt.r).lossPersistence() / computed, 6) / 16.0;
    EXPECT_LT(std::abs(std::log(e.phi / computed)), 4.0 * e.sigma_log + bias) << pt.r;
  }
  // E[tr P] at the lower end.
  const int k1 = 10, k2 = 30;
  const double at_one = burstRatio(1.0, k1, k2);
  for (const Point& pt : {points[0], points[1]})
  {
    const std::vector<double> mean = meanTrace(m, {gilbert(0.5, pt.r)}, 60000, k2, 99);
    const double ratio = mean[k2 - 1] / mean[k1 - 1];
    std::printf("r = %.4f: E[tr P_%d]/E[tr P_%d] = %.3f (g = 1: %.3f)\n", pt.r, k2, k1, ratio, at_one);
    if (pt.stable)
      EXPECT_LT(ratio, at_one) << pt.r;
    else
      EXPECT_GT(ratio, at_one) << pt.r;
  }
}

// ---------------------------------------------------------------------------------------------
// A sensor schedule (Marelli et al. section 7.3), through the simulator itself

namespace
{

/// As meanTrace, but the arrivals come from LossyRun: the plant, the model's schedule and one
/// independent link per sensor, exactly what simulate and montecarlo custom use.
std::vector<double> meanTraceSimulated(const Model& m, const std::vector<ChannelSettings>& links, int runs, int steps,
                                       std::uint64_t seed)
{
  EstimatorSettings s;
  s.algorithm = Algorithm::KFIO;
  auto est = makeEstimator(m, s);
  LossyRunOptions o;
  for (const ChannelSettings& c : links)
    o.sensor_links.push_back(c);
  o.noise_on_loss = false;
  std::vector<double> mean(steps, 0.0);
  for (int r = 0; r < runs; ++r)
  {
    LossyRun run(m, deriveSeed(seed, static_cast<std::uint64_t>(r)), o);
    est->reset();
    for (int k = 0; k < steps; ++k)
    {
      run.step();
      est->step(run.received());
      mean[k] += est->covariance().trace() / runs;
    }
  }
  return mean;
}

/// sum_{j <= k2} j^d g^j / sum_{j <= k1} j^d g^j: the burst model with a polynomial prefactor j^d
/// (a Jordan block of size d/2 + 1 inflates P by ~ j^d |alpha|^{2j} over a burst of j steps).
double burstRatioPoly(double g, int d, int k1, int k2)
{
  double s1 = 0.0, s2 = 0.0;
  for (int j = 1; j <= k2; ++j)
  {
    const double t = std::pow(j, d) * std::pow(g, j);
    s2 += t;
    if (j <= k1)
      s1 += t;
  }
  return s2 / s1;
}

}  // namespace

// The Jordan block (alpha_1 = 1.2) is seen by sensor 1 only, at every second step: with loss eps on
// its link, a burst of j steps without information has probability ~ eps^{j/2} and inflates P by
// ~ j^2 alpha_1^{2j}, so E[tr P_k] ~ a + b sum_{j <= k} j^2 g^j with g = alpha_1^2 eps^{1/2}. At the
// boundary eps* = 1/alpha_1^4 that analyze computes, we put eps = 1.3 eps* (g = 1.140) and
// 0.5 eps* (g = 0.707). The ratio E[tr P_20] / E[tr P_10] is then about burstRatioPoly(g, 2): 7.45
// at g = 1, 19.4 below the boundary and 1.0 above. N = 20000 runs see the 20-step bursts below the
// boundary (probability (1.3 eps*)^10 = 0.0095) about 190 times: the tail's sample mean is within
// ~ 7 %, far inside the gap to 7.45; we require > 7.45 below and < 7.45 above.
TEST(StabilityMonteCarlo, ScheduledExampleThroughTheSimulator)
{
  Model m = multiModel(mat(3, 3, {1.2, 1, 0, 0, 1.2, 0, 0, 0, 1.1}),
                       {mat(2, 3, {2, 1, 0, 0, 1, 0}), mat(2, 3, {0, 0, 1, 0, 0, 2})});
  m.schedule.kind = Schedule::Kind::PERIODIC;
  m.schedule.pattern = {{true, false}, {false, true}};
  validateModel(m, "scheduled");
  const StabilityReport rep = analyzeStability(m, iidLinks({0.7, 0.7}));
  const double eps_star = 1.0 - rep.model.exact_rate;
  ASSERT_NEAR(eps_star, 1.0 / std::pow(1.2, 4), 1e-6);
  const int k1 = 10, k2 = 20;
  const double at_one = burstRatioPoly(1.0, 2, k1, k2);
  for (double f : {1.3, 0.5})
  {
    const double eps = f * eps_star;
    EXPECT_EQ(analyzeStability(m, iidLinks({1 - eps, 1 - eps})).model.verdict.kind,
              f > 1 ? Verdict::Kind::UNSTABLE : Verdict::Kind::STABLE);
    const std::vector<double> mean = meanTraceSimulated(m, iidChannels({1 - eps, 1 - eps}), 20000, k2, 31);
    const double ratio = mean[k2 - 1] / mean[k1 - 1];
    std::printf(
        "scheduled example: eps = %.4f (f = %.1f): E[tr P_%d]/E[tr P_%d] = %.3f (burst model %.3f, g = 1: %.3f)\n", eps,
        f, k2, k1, ratio, burstRatioPoly(1.2 * 1.2 * std::sqrt(eps), 2, k1, k2), at_one);
    if (f > 1)
      EXPECT_GT(ratio, at_one);
    else
      EXPECT_LT(ratio, at_one);
  }
}

// ---------------------------------------------------------------------------------------------
// Modes on the unit circle and Jordan structure (docs/stability.md 3.5c, 3.5d)

// A constant-velocity model (x = [position, velocity], T = 0.1, Q = I), a position sensor on a
// slow link and a velocity sensor that always arrives. Theorem 14 on the unit circle: bounded at
// every positive position rate, unbounded at rate 0 (the position is then dead-reckoned from the
// velocity, whose error keeps adding up).
//  - At rate 0.05 the position error is reset on average every 20 steps and the covariance's
//    dependence on the start decays like 0.95^k: by k = 400 E[tr P_k] is at its stationary value,
//    so E[tr P_800] / E[tr P_400] = 1 up to sampling noise. tr P_k over the runs has a standard
//    deviation of the order of its mean (it grows with the time since the last fix, a geometric
//    variable); with 4000 runs the relative standard error of each mean is about 1/sqrt(4000) =
//    1.6 %, so the ratio is within 5 % of 1 (more than 2 standard errors of the ratio) and we
//    require < 1.1.
//  - At rate 0 P_k is deterministic (the velocity always arrives, the position never) and its
//    position variance grows linearly: the integrated velocity error plus the position noise of Q,
//    at least 1 per step. So tr P_800 - tr P_400 >= 400, and the ratio is about 2; we require > 1.8.
TEST(StabilityMonteCarlo, ConstantVelocityNeedsAnyPositivePositionRate)
{
  const Model m = multiModel(mat(2, 2, {1, 0.1, 0, 1}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  EXPECT_EQ(stabilityVerdict(m, {0, 1}, {LinkModel::iid(0.05), LinkModel::iid(1.0)}).kind, Verdict::Kind::STABLE);
  EXPECT_EQ(stabilityVerdict(m, {0, 1}, {LinkModel::iid(0.0), LinkModel::iid(1.0)}).kind, Verdict::Kind::UNSTABLE);
  EXPECT_TRUE(sensorMargins(m, {LinkModel::iid(0.05), LinkModel::iid(1.0)})[0].any_positive);
  const std::vector<double> slow = meanTrace(m, iidChannels({0.05, 1.0}), 4000, 800, 31);
  const std::vector<double> none = meanTrace(m, iidChannels({0.0, 1.0}), 1, 800, 31);
  const double r_slow = slow[799] / slow[399], r_none = none[799] / none[399];
  std::printf(
      "constant velocity: E[tr P_800] / E[tr P_400] = %.4f at position rate 0.05, %.4f at rate 0 (tr P_800 "
      "= %.1f)\n",
      r_slow, r_none, none[799]);
  EXPECT_LT(r_slow, 1.1);
  EXPECT_GT(r_none, 1.8);
  EXPECT_GE(none[799] - none[399], 400.0);
}

// A Jordan block at 1.2 with sensor 1 c = [1 0] (observes the block from two packets) and sensor 2
// c = [0 1] (sees the block but not its eigenvector: it never bounds the first coordinate). The
// kernel lattice holds span(e1), which only sensor 1 informs on, so Phi = 1 - lambda_1 whatever
// sensor 2 does, and sensor 1 needs 1 - 1/1.44 = 0.305556 (before, "neither Proposition 24 nor
// Corollary 26 applies" left this undecided). Sensor 1 is put at 1 - lambda_1 = f / 1.44 with
// f = 1.3 (below) and 0.7 (above), sensor 2 at 0.9. The burst model of PerSensorBoundaryTwoSystems
// with g = f, plus the Jordan block's polynomial factor (a burst of j steps inflates P by about
// j^2 1.44^j): above the boundary the partial sums of j^2 0.7^j are 31.8 at j = 10 and 43.0 at
// j = 20 (a factor 1.35, and they converge), so E[tr P_20] / E[tr P_10] stays below 1.909 (its
// value for g = 1 without the factor); below it the terms grow like j^2 1.3^j and the ratio
// exceeds it (the partial sums grow by a factor of about 25). With 20000 runs the bursts
// that matter are seen >= 1000 times (probability (1.3/1.44)^20 >= 0.12 at f = 1.3).
TEST(StabilityMonteCarlo, JordanBlockSeenWithoutItsEigenvector)
{
  const Model m = multiModel(mat(2, 2, {1.2, 1, 0, 1.2}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  const StabilityReport rep = analyzeStability(m, iidLinks({0.5, 0.9}));
  const SensorMargin& mg = rep.links[0].margin;
  ASSERT_TRUE(mg.half_line);
  EXPECT_NEAR(mg.band.converges_at, 1.0 - 1.0 / 1.44, 1e-6) << mg.note;
  const int k1 = 10, k2 = 20, runs = 20000;
  for (double f : {1.3, 0.7})
  {
    const double lambda1 = 1.0 - f / 1.44;
    const Verdict v = stabilityVerdict(m, {0, 1}, {LinkModel::iid(lambda1), LinkModel::iid(0.9)});
    EXPECT_EQ(v.kind, f > 1.0 ? Verdict::Kind::UNSTABLE : Verdict::Kind::STABLE) << v.reason;
    const std::vector<double> mean = meanTrace(m, iidChannels({lambda1, 0.9}), runs, k2, 4242);
    const double ratio = mean[k2 - 1] / mean[k1 - 1];
    std::printf("Jordan block, sensor 1 at %.4f (f = %.1f): E[tr P_%d] / E[tr P_%d] = %.3f\n", lambda1, f, k2, k1,
                ratio);
    if (f > 1.0)
      EXPECT_GT(ratio, burstRatio(1.0, k1, k2));
    else
      EXPECT_LT(ratio, burstRatio(1.0, k1, k2));
  }
}
