// Stability analysis (stability.hpp) against reference cases T1-T8 (each described below), Lin et
// al.'s example, random systems with one-dimensional unstable modes, and per-sensor links (i.i.d.
// and Gilbert-Elliott) against closed forms. The Monte Carlo cross-checks are in
// test_stability_montecarlo.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <optional>

#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/stability/link_design.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "stability_test_support.hpp"

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;

// ---------------------------------------------------------------------------------------------
// T1: Yang et al.'s Example 1 (eight sensors, stable A)

TEST(Stability, T1ReferenceValues)
{
  const Model m = mc::yangExampleModel();
  const std::vector<double>& lam = mc::yangRates();
  const Eigen::VectorXcd ev = eigenvalues(m.A);
  std::vector<double> re = {ev[0].real(), ev[1].real()};
  std::sort(re.begin(), re.end());
  EXPECT_NEAR(re[0], -0.925649, 1e-6);
  EXPECT_NEAR(re[1], 0.885649, 1e-6);
  EXPECT_NEAR(spectralRadius(m.A), 0.925649, 1e-6);
  EXPECT_NEAR(topologicalEntropy(m.A), 0.0, 1e-15);
  std::vector<int> rows;
  for (const Sensor& s : m.sensors)
    rows.push_back(s.size);
  const Capacity c = transmissionCapacity(m.A, lam, rows);
  const std::vector<double> ci = {0.140055, 0.305507, 0.680313, 0.480383, 0.096004, 0.461154, 0.812530, 0.228090};
  for (std::size_t i = 0; i < ci.size(); ++i)
    EXPECT_NEAR(c.individual[i], ci[i], 1e-6) << i;
  EXPECT_NEAR(c.total, 3.204037, 1e-6);
  EXPECT_NEAR(c.lower, -0.077260, 1e-6);
  EXPECT_NEAR(c.loss_product, 1.648197e-3, 1e-9);
  EXPECT_NEAR(c.weighted, 5.107322, 1e-6);
  EXPECT_NEAR(c.log_abs_det, -0.198695, 1e-6);

  const MatrixXd G = lowerBoundLimit(m.A, m.Q, c.loss_product);
  EXPECT_NEAR(G(0, 0), 0.530519, 1e-6);
  EXPECT_NEAR(G(0, 1), 0.209938, 1e-6);
  EXPECT_NEAR(G(1, 1), 0.500787, 1e-6);
  MatrixXd S = MatrixXd::Zero(2, 2);
  for (std::size_t i = 0; i < m.sensors.size(); ++i)
  {
    const MatrixXd Hi = m.C.middleRows(m.sensors[i].offset, m.sensors[i].size);
    S += lam[i] * Hi.transpose() * Hi;
  }
  const MatrixXd F = informationLowerBoundLimit(m.A, m.Q, S);
  EXPECT_NEAR(F(0, 0), 0.641375, 1e-6);
  EXPECT_NEAR(F(0, 1), 0.233959, 1e-6);
  EXPECT_NEAR(F(1, 1), 0.543111, 1e-6);

  std::vector<MatrixXd> H;
  for (const Sensor& s : m.sensors)
    H.push_back(m.C.middleRows(s.offset, s.size));
  const MareResult r = solveMare(Mare(m.A, m.Q, H, lam));
  ASSERT_EQ(r.status, MareResult::Status::CONVERGED);
  EXPECT_NEAR(r.X(0, 0), 0.693771, 1e-6);
  EXPECT_NEAR(r.X(0, 1), 0.234037, 1e-6);
  EXPECT_NEAR(r.X(1, 1), 0.604265, 1e-6);
  EXPECT_LT(r.certificate, 1.0);
  // "converges in about 12 iterations" (to plotting precision): the increment is below 1e-6 by then.
  const Mare mare(m.A, m.Q, H, lam);
  MatrixXd X = MatrixXd::Zero(2, 2);
  for (int k = 0; k < 12; ++k)
    X = mare.step(X);
  EXPECT_LT((mare.step(X) - X).norm(), 1e-5);
  // Ordering of the bounds with the Monte Carlo reference E[P-] (10^5 runs).
  const MatrixXd E = mat(2, 2, {0.6634, 0.2364, 0.2364, 0.5571});
  EXPECT_GT(minEig(E - G), 0.0);
  EXPECT_GT(minEig(E - F), 0.0);
  EXPECT_GT(minEig(r.X - E), 0.0);
}

TEST(Stability, T1ReportIsStable)
{
  const Model m = mc::yangExampleModel();
  const ChannelSettings ch = bernoulli(0.5);
  const StabilityReport rep = analyzeStability(m, &ch);
  EXPECT_EQ(rep.model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_NE(rep.model.verdict.reason.find("A is stable"), std::string::npos);
  EXPECT_EQ(rep.sensors.size(), 8u);
  EXPECT_EQ(rep.model.lower_bound, 0.0);
}

// ---------------------------------------------------------------------------------------------
// T2: the example of Marelli et al.'s Section 7.3, via Corollary 26

TEST(Stability, T2Corollary26)
{
  // i.i.d. loss eps: bad-matrix conditional probabilities eps (even t) and 1 (odd t), tau = 2.
  const double alpha = 1.2;
  auto growth = [&](double eps) { return std::pow(alpha, 2) * corollary26Phi({eps, 1.0}); };
  // Threshold alpha^4 eps = 1: eps* = 1/1.2^4 = 0.482253.
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 60; ++i)
    (growth(0.5 * (lo + hi)) < 1.0 ? lo : hi) = 0.5 * (lo + hi);
  EXPECT_NEAR(lo, 0.482253, 1e-6);
  // Markov loss: lambda = [P^2]_00 for loss persistence a = P(0|0), recovery b.
  const double a = 0.7, b = 0.4;
  const double p00 = a * a + (1 - a) * b;
  EXPECT_NEAR(corollary26Phi({p00, 1.0}), std::sqrt(p00), 1e-15);
  // Block 1 of T2 alone (Jordan, H^(1) of full column rank), one sensor, i.i.d.: Phi = 1 - lambda
  // (the lattice is {C^2, {0}}), so the exact rate is 1 - 1/alpha^2.
  const MatrixXd A1 = mat(2, 2, {1.2, 1, 0, 1.2});
  const MatrixXd H1 = mat(2, 2, {2, 1, 0, 1});
  const auto blocks = analyseBlocks(A1, {H1});
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].method, BlockStructure::Method::SINGLE_EIGENVALUE);
  EXPECT_NEAR(blockPhi(blocks[0], {LinkModel::iid(0.3)}), 0.7, 1e-12);
  EXPECT_NEAR(exactCriticalArrivalRate(blocks), 1.0 - 1.0 / 1.44, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// T3: A = diag(2, -2), T4: A = diag(2, 3) (both with c = [1 1]), T7: a Jordan block with c = [1 0]:
// single sensor, exact rate vs bounds, MARE threshold

TEST(Stability, T3TwoMinusTwo)
{
  const MatrixXd A = mat(2, 2, {2, 0, 0, -2});
  const MatrixXd C = mat(1, 2, {1, 1});
  const auto fmo = fmoBlocks(A);
  ASSERT_EQ(fmo.size(), 1u);
  EXPECT_EQ(fmo[0].order, 2);
  const auto blocks = analyseBlocks(A, {C});
  ASSERT_EQ(blocks[0].method, BlockStructure::Method::LATTICE);
  EXPECT_EQ(blocks[0].seen.size(), 3u);  // C^2, span[1,-1], span[1,1] (the trivial {0} excluded)
  EXPECT_NEAR(blockPhi(blocks[0], {LinkModel::iid(0.5)}), std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(exactCriticalArrivalRate(blocks), 15.0 / 16.0, 1e-12);
  EXPECT_NEAR(sinopoliLowerBound(spectralRadius(A)), 0.75, 1e-12);
  EXPECT_NEAR(mahlerUpperBound(mahlerMeasure(A)), 0.9375, 1e-12);
  EXPECT_EQ(mareAt(A, C, 0.93), MareResult::Status::DIVERGED);
  EXPECT_EQ(mareAt(A, C, 0.94), MareResult::Status::CONVERGED);
  const ChannelSettings below = bernoulli(1 - 0.93), above = bernoulli(1 - 0.94);
  EXPECT_EQ(analyzeStability(simpleModel(A, C), &below).model.verdict.kind, Verdict::Kind::UNSTABLE);
  EXPECT_EQ(analyzeStability(simpleModel(A, C), &above).model.verdict.kind, Verdict::Kind::STABLE);
}

TEST(Stability, T4TwoThree)
{
  const MatrixXd A = mat(2, 2, {2, 0, 0, 3});
  const MatrixXd C = mat(1, 2, {1, 1});
  const StabilityReport rep = analyzeStability(simpleModel(A, C), nullptr);
  EXPECT_NEAR(rep.model.exact_rate, 8.0 / 9.0, 1e-12);
  EXPECT_NEAR(rep.model.lower_bound, 8.0 / 9.0, 1e-12);
  EXPECT_NEAR(rep.model.closed_form_upper, 35.0 / 36.0, 1e-12);
  EXPECT_EQ(mareAt(A, C, 0.97), MareResult::Status::DIVERGED);
  EXPECT_EQ(mareAt(A, C, 0.98), MareResult::Status::CONVERGED);
  // Bisection band brackets 35/36 within its tolerance and undecided band.
  EXPECT_LE(rep.model.mare.diverges_at, 35.0 / 36.0 + 1e-4);
  EXPECT_GE(rep.model.mare.converges_at, 35.0 / 36.0 - 1e-4);
  EXPECT_LT(rep.model.mare.converges_at - rep.model.mare.diverges_at, 0.01);
  // Bounded on (8/9, 35/36) although the MARE diverges there.
  const ChannelSettings mid = bernoulli(1 - 0.93);
  const StabilityReport r2 = analyzeStability(simpleModel(A, C), &mid);
  EXPECT_EQ(r2.model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_NEAR(r2.model.margin, 0.93 - 8.0 / 9.0, 1e-12);
}

TEST(Stability, T7JordanBlock)
{
  const MatrixXd A = mat(2, 2, {1.2, 1, 0, 1.2});
  const MatrixXd C = mat(1, 2, {1, 0});
  EXPECT_FALSE(isDiagonalizable(A));
  const auto blocks = analyseBlocks(A, {C});
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].method, BlockStructure::Method::SINGLE_EIGENVALUE);
  EXPECT_NEAR(exactCriticalArrivalRate(blocks), 0.305556, 1e-6);
  EXPECT_NEAR(mahlerUpperBound(mahlerMeasure(A)), 0.517747, 1e-6);
  EXPECT_EQ(mareAt(A, C, 0.515), MareResult::Status::DIVERGED);
  EXPECT_EQ(mareAt(A, C, 0.52), MareResult::Status::CONVERGED);
  // c = [0 1] sees the block without observing it: its kernel lattice (docs/stability.md 3.5c) holds
  // the whole block and span(e1), the unobservable subspace of (A, c), on which no packet informs:
  // Phi = 1 at every rate, so the block is unbounded at every rate (exact rate inf).
  const auto bad = analyseBlocks(A, {mat(1, 2, {0, 1})});
  EXPECT_EQ(bad[0].method, BlockStructure::Method::LATTICE);
  ASSERT_EQ(bad[0].seen.size(), 2u);
  EXPECT_TRUE(bad[0].seen[0][0][0]);
  EXPECT_FALSE(bad[0].seen[1][0][0]);
  EXPECT_TRUE(std::isinf(exactCriticalArrivalRate(bad)));
  EXPECT_EQ(blockPhi(bad[0], {LinkModel::iid(0.5)}), 1.0);
  EXPECT_EQ(marelliTest(bad, {LinkModel::iid(0.5)}).kind, Verdict::Kind::UNSTABLE);
}

// ---------------------------------------------------------------------------------------------
// T8 (Gan & Liu worked case): lambda_k = 1/12 from the conditional Gram matrix, and A3.

TEST(Stability, T8ExcitationArithmetic)
{
  const MatrixXd A = mat(2, 2, {0, -1, 1, 0});
  const Eigen::RowVector2d c(1, 0);
  const int h = 2, n = 2;
  const double pa = 0.5, R = 1.0;
  MatrixXd G = MatrixXd::Zero(2, 2);
  MatrixXd Aj = MatrixXd::Identity(2, 2);
  for (int j = 0; j < h; ++j)
  {
    const Eigen::RowVector2d cA = c * Aj;
    G += pa * cA.transpose() * cA / (1.0 + cA.squaredNorm());
    Aj = A * Aj;
  }
  const double lk = minEig(G) / (1 + h);
  EXPECT_NEAR(lk, 1.0 / 12.0, 1e-12);
  const double lam = 1 - lk;
  const double nrm = 1.0;  // spectral norm of a rotation, computed below
  EXPECT_NEAR(Eigen::JacobiSVD<MatrixXd>(A).singularValues()[0], nrm, 1e-12);
  auto printed = [&](int p)
  { return std::pow(2.0, (p - 1.0) / (p * h)) * nrm * nrm * std::pow(lam, 1.0 / (8.0 * n * p * p * (1 + R))); };
  auto proof = [&](int p)
  { return std::pow(16.0, p - 1.0) * std::pow(nrm, 8.0 * p * h) * std::pow(lam, 1.0 / (2.0 * n * h * (1 + R))); };
  EXPECT_NEAR(printed(1), 0.997285, 1e-6);
  EXPECT_NEAR(proof(1), 0.994577, 1e-6);
  EXPECT_NEAR(printed(2), 1.188, 1e-3);
  EXPECT_NEAR(proof(2), 15.9, 0.05);
}

// ---------------------------------------------------------------------------------------------
// Lin et al.'s example (their Section 7): thresholds 0.4 and 0.7

TEST(Stability, AoeThresholds)
{
  for (const auto& c : {std::make_pair(1.2910, 0.400005), std::make_pair(1.8257, 0.699986)})
  {
    const Model m = mc::aoeExampleModel(c.first);
    EXPECT_NEAR(aoeRecoveryThreshold(spectralRadius(m.A)), c.second, 1e-6);
    const MatrixXd Qn = m.B * m.Q * m.B.transpose();
    const Verdict above = aoeTheorem5(m.A, m.C, Qn, m.R, c.second + 0.01, 0.5);
    const Verdict below = aoeTheorem5(m.A, m.C, Qn, m.R, c.second - 0.01, 0.5);
    EXPECT_EQ(above.kind, Verdict::Kind::STABLE) << above.reason;
    EXPECT_EQ(below.kind, Verdict::Kind::UNSTABLE) << below.reason;
    const double exact = 1.0 - 1.0 / (c.first * c.first);
    EXPECT_EQ(aoeTheorem5(m.A, m.C, Qn, m.R, exact, 0.5).kind, Verdict::Kind::UNDECIDED);
    // Via the general exact test (Markov form of Corollary 26) and the report.
    const ChannelSettings ge = gilbert(0.05, c.second + 0.01);
    const StabilityReport rep = analyzeStability(m, &ge);
    EXPECT_NEAR(rep.model.recovery_exact, c.second, 1e-6);  // the reference values have 6 decimals
    EXPECT_EQ(rep.model.verdict.kind, Verdict::Kind::STABLE);
    EXPECT_EQ(rep.model.aoe_theorem5.kind, Verdict::Kind::STABLE);
    EXPECT_NEAR(rep.model.margin, 0.01, 1e-6);
    EXPECT_EQ(rep.model.margin_quantity, "recovery rate");
  }
}

TEST(Stability, AoeTheorem5NotApplicable)
{
  const Model m = mc::aoeExampleModel(1.2910);
  const MatrixXd Qn = m.B * m.Q * m.B.transpose();
  // Not strongly observable: C sees only a combination of two modes of equal modulus.
  const MatrixXd A = mat(2, 2, {1.5, 0, 0, -1.5});
  const Verdict v = aoeTheorem5(A, mat(1, 2, {1, 1}), Qn, mat(1, 1, {1}), 0.9, 0.5);
  EXPECT_EQ(v.kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_NE(v.reason.find("strongly observable"), std::string::npos);
  const Verdict j = aoeTheorem5(mat(2, 2, {1.2, 1, 0, 1.2}), mat(1, 2, {1, 0}), Qn, mat(1, 1, {1}), 0.9, 0.5);
  EXPECT_EQ(j.kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_NE(j.reason.find("diagonalizable"), std::string::npos);
  // A hidden GE chain (loss_good > 0) is not the on/off chain of Lin et al.
  const ChannelSettings ge = gilbert(0.05, 0.4, 1.0, 0.005);
  const StabilityReport rep = analyzeStability(m, &ge);
  EXPECT_EQ(rep.model.aoe_theorem5.kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_NE(rep.model.aoe_theorem5.reason.find("not"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Random systems with 1-D unstable modes: exact rate = lower bound < MARE threshold

TEST(Stability, RandomOneDimensionalUnstableModes)
{
  Rng rng(20240601);
  for (int trial = 0; trial < 12; ++trial)
  {
    const int n = 2 + trial % 3;
    // Real distinct eigenvalues: one or two unstable (distinct moduli), the rest stable.
    Eigen::VectorXd d(n);
    d[0] = (rng.bernoulli(0.5) ? 1 : -1) * rng.uniform(1.1, 2.0);
    for (int i = 1; i < n; ++i)
      d[i] = rng.uniform(-0.9, 0.9);
    if (n >= 3 && trial % 2 == 0)
      d[1] = std::abs(d[0]) + rng.uniform(0.2, 0.6);
    const MatrixXd T = randomMatrix(rng, n, n) + 2.0 * MatrixXd::Identity(n, n);
    const MatrixXd A = T * d.asDiagonal() * T.inverse();
    const MatrixXd C = randomMatrix(rng, 1, n);
    const StabilityReport rep = analyzeStability(simpleModel(A, C), nullptr);
    const double rho = d.cwiseAbs().maxCoeff();
    const double lb = 1.0 - 1.0 / (rho * rho);  // computed from the construction, not the code
    EXPECT_NEAR(rep.model.lower_bound, lb, 1e-9) << trial;
    EXPECT_NEAR(rep.model.exact_rate, lb, 1e-9) << trial;
    double M = 1.0;
    for (int i = 0; i < n; ++i)
      M *= std::max(1.0, std::abs(d[i]));
    EXPECT_NEAR(rep.model.closed_form_upper, 1.0 - 1.0 / (M * M), 1e-7) << trial;
    EXPECT_GE(rep.model.mare.converges_at, lb - 1e-12) << trial;
    if (M > rho * (1 + 1e-3))  // two unstable modes: the MARE threshold is strictly above
    {
      EXPECT_GT(rep.model.mare.diverges_at, lb + 1e-3) << trial;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Multi-sensor exact rate: each direction seen by its own sensor

TEST(Stability, MultiSensorLattice)
{
  const MatrixXd A = 2.0 * MatrixXd::Identity(2, 2);
  const auto blocks = analyseBlocks(A, {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  ASSERT_EQ(blocks.size(), 1u);
  EXPECT_EQ(blocks[0].method, BlockStructure::Method::LATTICE);
  // Phi = max(1 - l1, 1 - l2): the less reliable sensor decides.
  EXPECT_NEAR(blockPhi(blocks[0], {LinkModel::iid(0.9), LinkModel::iid(0.6)}), 0.4, 1e-12);
  EXPECT_NEAR(exactCriticalArrivalRate(blocks), 0.75, 1e-12);
  // Two sensors that both see a scalar mode: Phi = (1 - l)^2, critical 1 - 1/2 = 0.5 for |alpha| = 2.
  const auto b2 = analyseBlocks(mat(1, 1, {2}), {mat(1, 1, {1}), mat(1, 1, {3})});
  EXPECT_NEAR(exactCriticalArrivalRate(b2), 0.5, 1e-12);
  EXPECT_NEAR(sinopoliLowerBound(2.0, 2), 0.5, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Verdict kinds and reasons

TEST(Stability, VerdictReasons)
{
  const MatrixXd A = mat(2, 2, {1.3, 0, 0, 0.5});
  const MatrixXd C = mat(1, 2, {1, 1});
  // STABLE / UNSTABLE (exact), with the numbers.
  const ChannelSettings good = bernoulli(0.2), bad = bernoulli(0.8);
  const Verdict s = analyzeStability(simpleModel(A, C), &good).model.verdict;
  EXPECT_EQ(s.kind, Verdict::Kind::STABLE);
  EXPECT_NE(s.reason.find("Theorem 14"), std::string::npos);
  EXPECT_NEAR(s.numbers.at("max |alpha|^2 Phi"), 1.69 * 0.2, 1e-12);
  EXPECT_EQ(analyzeStability(simpleModel(A, C), &bad).model.verdict.kind, Verdict::Kind::UNSTABLE);
  // UNDECIDED: exactly at the critical rate (Theorem 14 equality).
  const ChannelSettings edge = bernoulli(1.0 / 1.69);
  const Verdict u = analyzeStability(simpleModel(A, C), &edge).model.verdict;
  EXPECT_EQ(u.kind, Verdict::Kind::UNDECIDED);
  EXPECT_NE(u.reason.find("Remark 15"), std::string::npos);
  // A non-diagonalizable block with several eigenvalues of common order (Jordan blocks at 1.5 and
  // -1.5, order 2): Theorem 14 with the kernel lattice of docs/stability.md 3.5c. The packets of one
  // phase, once enough have arrived, reveal half of the block (x1 + x3 and x2 - x4 at even steps), so
  // Phi = (1 - lambda)^{1/2} and the exact rate is 1 - 1/2.25^2 = 0.802469.
  const MatrixXd J = mat(4, 4, {1.5, 1, 0, 0, 0, 1.5, 0, 0, 0, 0, -1.5, 1, 0, 0, 0, -1.5});
  const MatrixXd CJ = mat(1, 4, {1, 0, 1, 0});
  const ChannelSettings between = bernoulli(1 - 0.7);  // lower bound 1 - 1/2.25 = 0.556
  const StabilityReport rj = analyzeStability(simpleModel(J, CJ), &between);
  EXPECT_NEAR(rj.model.exact_rate, 1.0 - 1.0 / (2.25 * 2.25), 1e-12);
  EXPECT_EQ(rj.model.verdict.kind, Verdict::Kind::UNSTABLE) << rj.model.verdict.reason;
  EXPECT_NEAR(rj.model.verdict.numbers.at("max |alpha|^2 Phi"), 2.25 * std::sqrt(0.3), 1e-9);
  EXPECT_EQ(stabilityVerdict(simpleModel(J, CJ), {0}, {LinkModel::iid(0.85)}).kind, Verdict::Kind::STABLE);
  // UNDECIDED between the lower bound and the MARE when Theorem 14 is not computed (the lattice
  // above the cap): the verdict falls back on the necessary condition and the MARE.
  AnalysisOptions capped;
  capped.lattice_cap = 1;
  const Verdict uj = stabilityVerdict(simpleModel(J, CJ), {0}, {LinkModel::iid(0.7)}, capped);
  EXPECT_EQ(uj.kind, Verdict::Kind::UNDECIDED) << uj.reason;
  EXPECT_NE(uj.reason.find("MARE"), std::string::npos);
  EXPECT_NE(uj.reason.find("lattice larger than 1"), std::string::npos);
  // ... and below the lower bound: unstable by Yang's Theorem 1.
  const Verdict lj = stabilityVerdict(simpleModel(J, CJ), {0}, {LinkModel::iid(0.5)}, capped);
  EXPECT_EQ(lj.kind, Verdict::Kind::UNSTABLE);
  EXPECT_NE(lj.reason.find("Theorem 1"), std::string::npos);
  // NOT_APPLICABLE: noise does not excite the unstable mode.
  Model m = simpleModel(A, C);
  m.B = mat(2, 1, {0, 1});
  m.Q = mat(1, 1, {1});
  const Verdict na = analyzeStability(m, &good).model.verdict;
  EXPECT_EQ(na.kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_NE(na.reason.find("controllable"), std::string::npos);
  // NOT_APPLICABLE without a channel.
  EXPECT_EQ(analyzeStability(simpleModel(A, C), nullptr).model.verdict.kind, Verdict::Kind::NOT_APPLICABLE);
  // A mode that no sensor observes even without losses (c = [0 1] misses the 1.3): it grows
  // whatever the links do, so E[P] is unbounded at every rate: the verdict is unstable and names
  // the state; the links' verdict concerns the observed mode 0.5, stable at every rate, and the
  // thresholds of the observed modes are kept apart (docs/stability.md 2.2).
  const StabilityReport ur = analyzeStability(simpleModel(A, mat(1, 2, {0, 1})), &good);
  EXPECT_FALSE(ur.detectable);
  EXPECT_NE(ur.dead_reckoned.find("(1.3)"), std::string::npos) << ur.dead_reckoned;
  EXPECT_NE(ur.dead_reckoned.find("of state 0 "), std::string::npos) << ur.dead_reckoned;
  EXPECT_EQ(ur.dead_states, "state 0");
  EXPECT_EQ(ur.model.dead_reckoned, ur.dead_reckoned);
  EXPECT_EQ(ur.model.verdict.kind, Verdict::Kind::UNSTABLE) << ur.model.verdict.reason;
  EXPECT_EQ(ur.model.verdict.reason.rfind("state 0 grows regardless of the links", 0), 0u) << ur.model.verdict.reason;
  EXPECT_EQ(ur.model.links_verdict.kind, Verdict::Kind::STABLE) << ur.model.links_verdict.reason;
  EXPECT_NE(ur.model.links_verdict.reason.find("observed modes"), std::string::npos);
  EXPECT_TRUE(std::isinf(ur.model.exact_rate) && std::isinf(ur.model.sufficient_threshold));
  EXPECT_TRUE(std::isnan(ur.model.margin));
  ASSERT_EQ(ur.model.observed.size(), 1u);
  EXPECT_EQ(ur.model.observed[0].verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(ur.model.observed[0].exact_rate, 0.0);  // A is stable on the observed modes
  EXPECT_TRUE(analyzeStability(simpleModel(A, C), &good).dead_reckoned.empty());
  EXPECT_EQ(toString(Verdict::Kind::NOT_APPLICABLE), "not applicable");
}

TEST(Stability, StrongObservabilityAndHelpers)
{
  EXPECT_EQ(strongObservability(mat(2, 2, {2, 0, 0, -2}), mat(1, 2, {1, 1})).kind, Verdict::Kind::UNSTABLE);
  EXPECT_EQ(strongObservability(mat(2, 2, {2, 0, 0, 3}), mat(1, 2, {1, 1})).kind, Verdict::Kind::STABLE);
  EXPECT_EQ(strongObservability(mat(2, 2, {2, 1, 0, 2}), mat(1, 2, {1, 0})).kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_TRUE(isDiagonalizable(2.0 * MatrixXd::Identity(3, 3)));
  EXPECT_NEAR(mahlerMeasure(mat(2, 2, {2, 0, 0, 3})), 6.0, 1e-12);
  // Complex pair with an irrational angle: two 1-D FMO blocks; with angle pi/2 (eigenvalues +-1.5i,
  // ratio -1): one block of order 2.
  const double t = 1.0;
  const auto irr = fmoBlocks(1.5 * mat(2, 2, {std::cos(t), -std::sin(t), std::sin(t), std::cos(t)}));
  EXPECT_EQ(irr.size(), 2u);
  const auto rat = fmoBlocks(1.5 * mat(2, 2, {0, -1, 1, 0}));
  ASSERT_EQ(rat.size(), 1u);
  EXPECT_EQ(rat[0].order, 2);
  // Rotation by pi/2 with a scalar sensor: kernels of c V and c V D are different lines.
  const auto rb = analyseBlocks(1.5 * mat(2, 2, {0, -1, 1, 0}), {mat(1, 2, {1, 0})});
  ASSERT_EQ(rb[0].method, BlockStructure::Method::LATTICE);
  // P(window unobservable) needs all arrivals at times of one parity: Phi = (1 - l)^{1/2}.
  EXPECT_NEAR(blockPhi(rb[0], {LinkModel::iid(0.36)}), 0.8, 1e-9);
}

TEST(Stability, LinkModelRates)
{
  const LinkModel g = LinkModel::fromSettings(gilbert(0.05, 0.4));
  EXPECT_NEAR(g.arrivalRate(), 0.4 / 0.45, 1e-15);
  EXPECT_NEAR(g.recoveryRate(), 0.4, 1e-15);
  EXPECT_NEAR(g.lossPersistence(), 0.6, 1e-15);
  const LinkModel b = LinkModel::fromSettings(bernoulli(0.2));
  EXPECT_NEAR(b.arrivalRate(), 0.8, 1e-15);
  EXPECT_NEAR(b.lossPersistence(), 0.2, 1e-15);
  // Hidden chain: stationary loss = pi_g lg + pi_b lb.
  const LinkModel h = LinkModel::fromSettings(gilbert(0.02, 0.1, 0.75, 0.01));
  const double pg = 0.1 / 0.12, pb = 0.02 / 0.12;
  EXPECT_NEAR(h.arrivalRate(), 1 - (pg * 0.01 + pb * 0.75), 1e-12);
  EXPECT_FALSE(h.onOff());
}

// ---------------------------------------------------------------------------------------------
// RSEIO checklist

TEST(Stability, RseioChecklist)
{
  const Model z = zhouModel(1.0);
  const Verdict v = rseioTheorem5(z, 0.8, LinkModel::iid(0.8));
  EXPECT_EQ(v.kind, Verdict::Kind::STABLE) << v.reason;
  EXPECT_EQ(v.numbers.at("observability m"), 0.0);  // W1 is PD: one arrival suffices
  EXPECT_EQ(rseioTheorem5(z, 0.8, LinkModel::iid(0.0)).kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_EQ(rseioTheorem5(z, 0.8, LinkModel::gilbertElliott(0.1, 0.2, 0.9, 0.0)).kind, Verdict::Kind::NOT_APPLICABLE);
  EXPECT_EQ(rseioTheorem5(z, 0.8, LinkModel::gilbertElliott(0.1, 0.2)).kind, Verdict::Kind::STABLE);
  // Singular A: not applicable.
  Model s = simpleModel(mat(2, 2, {1, 0, 0, 0}), mat(1, 2, {1, 1}));
  EXPECT_EQ(rseioTheorem5(s, 1.0, LinkModel::iid(0.5)).kind, Verdict::Kind::NOT_APPLICABLE);
  // Unobservable with no uncertainty (mu = 1 = KFIO): the observability word does not exist.
  Model u = simpleModel(mat(2, 2, {1.1, 0, 0, 0.5}), mat(1, 2, {0, 1}));
  EXPECT_EQ(rseioTheorem5(u, 1.0, LinkModel::iid(0.5)).kind, Verdict::Kind::UNDECIDED);
  // Gramian test against the explicit observability matrix for the word 1 0 1 (A1 = A2, W1 = C'C).
  const MatrixXd A = mat(2, 2, {1, 1, 0, 1}), Cc = mat(1, 2, {1, 0});
  const MatrixXd O = wordObservabilityGramian({1, 0, 1}, A, Cc.transpose() * Cc, A);
  const MatrixXd r1 = Cc * A, r3 = Cc * A * A * A;
  EXPECT_LT((O - (r1.transpose() * r1 + r3.transpose() * r3)).norm(), 1e-12);
  const ChannelSettings ch = bernoulli(0.2);
  EstimatorSettings es;
  es.algorithm = Algorithm::RSEIO;
  es.mu = 0.8;
  EXPECT_EQ(analyzeStability(z, &ch, &es).rseio.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(analyzeStability(z, &ch).rseio.kind, Verdict::Kind::NOT_APPLICABLE);
}

// ---------------------------------------------------------------------------------------------
// A link per sensor: verdicts for a rate vector, capacities, per-sensor margins and intervals

// A = diag(2, 3), sensor 1 sees the mode 2 only, sensor 2 the mode 3 only: two 1-D blocks, each
// with Phi = 1 - lambda of its one sensor, so E[P] is bounded iff 4 (1 - lambda_1) < 1 and
// 9 (1 - lambda_2) < 1, i.e. lambda_1 > 3/4 and lambda_2 > 8/9 (Theorem 14, 1-D blocks).
TEST(StabilityLinks, SeparateModesUnequalRates)
{
  const Model m = multiModel(mat(2, 2, {2, 0, 0, 3}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  const auto kind = [&](double l1, double l2) { return analyzeStability(m, iidLinks({l1, l2})).model.verdict.kind; };
  EXPECT_EQ(kind(0.76, 0.89), Verdict::Kind::STABLE);
  EXPECT_EQ(kind(0.8, 0.95), Verdict::Kind::STABLE);
  EXPECT_EQ(kind(0.74, 0.95), Verdict::Kind::UNSTABLE);
  EXPECT_EQ(kind(0.8, 0.88), Verdict::Kind::UNSTABLE);
  // Capacity above c_upper = h(A) = ln 6 and still unstable: the capacity only promises that SOME
  // allocation is stable (Yang et al., Theorem 6).
  const StabilityReport big = analyzeStability(m, iidLinks({0.7, 0.9999}));
  EXPECT_NEAR(big.capacity.upper, std::log(6.0), 1e-12);
  EXPECT_GT(big.capacity.total, big.capacity.upper);
  EXPECT_EQ(big.model.verdict.kind, Verdict::Kind::UNSTABLE);
  EXPECT_NE(big.capacity_note.find("does NOT"), std::string::npos) << big.capacity_note;
  EXPECT_FALSE(big.uniform_links);
  // The MARE at the rate vector: two decoupled scalar MAREs, each converging iff lambda_i > 1 - 1/a_i^2,
  // the exact thresholds here.
  const StabilityReport in = analyzeStability(m, iidLinks({0.8, 0.95}));
  EXPECT_EQ(in.mare_at_rates.rfind("converges", 0), 0u) << in.mare_at_rates;
  EXPECT_LT(in.mare_at_rates_certificate, 1.0);
  EXPECT_GT(in.mare_at_rates_trace, 0.0);
  const StabilityReport out = analyzeStability(m, iidLinks({0.74, 0.95}));
  EXPECT_EQ(out.mare_at_rates.rfind("diverges", 0), 0u) << out.mare_at_rates;
  EXPECT_NE(analyzeStability(m, {gilbert(0.1, 0.8), bernoulli(0.1)}).mare_at_rates.find("not applicable"),
            std::string::npos);
  // Below c_lower = ln 3 every allocation diverges.
  const StabilityReport small = analyzeStability(m, iidLinks({0.5, 0.5}));
  EXPECT_LT(small.capacity.total, small.capacity.lower);
  EXPECT_NE(small.capacity_note.find("every allocation"), std::string::npos) << small.capacity_note;
  // The rate each sensor needs, the other fixed: 3/4 and 8/9, decided by Theorem 14 (tolerance 1e-7).
  const StabilityReport rep = analyzeStability(m, iidLinks({0.8, 0.9}));
  ASSERT_EQ(rep.links.size(), 2u);
  for (const SensorLinkReport& l : rep.links)
  {
    EXPECT_TRUE(l.margin.half_line);
    EXPECT_EQ(l.margin.quantity, "arrival rate");
    EXPECT_NE(l.markov_note.find("no Gilbert-Elliott link"), std::string::npos) << l.markov_note;
  }
  EXPECT_NEAR(rep.links[0].margin.band.converges_at, 0.75, 1e-6);
  EXPECT_NEAR(rep.links[1].margin.band.converges_at, 8.0 / 9.0, 1e-6);
  EXPECT_LE(rep.links[1].margin.band.diverges_at, rep.links[1].margin.band.converges_at);
  EXPECT_NEAR(rep.links[0].margin.margin, 0.8 - 0.75, 1e-6);
  // With sensor 1 below 3/4 no rate of sensor 2 helps.
  const StabilityReport bad = analyzeStability(m, iidLinks({0.7, 0.9}));
  EXPECT_TRUE(std::isnan(bad.links[1].margin.band.converges_at));
  EXPECT_EQ(bad.links[1].margin.band.diverges_at, 1.0);
  // A lossless sensor is an i.i.d. link with arrival 1.
  const StabilityReport lossless = analyzeStability(m, iidLinks({0.8, -1}));
  EXPECT_TRUE(lossless.links[1].lossless);
  EXPECT_EQ(lossless.model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(analyzeStability(m, iidLinks({0.7, -1})).model.verdict.kind, Verdict::Kind::UNSTABLE);
}

// T3's block (A = diag(2, -2), order 2) seen by two sensors c = [1 1]: each 1-D lattice element is
// seen by each sensor at one of the two phases, so Phi = ((1 - lambda_1)(1 - lambda_2))^{1/2} and
// E[P] is bounded iff 16 (1 - lambda_1)(1 - lambda_2) < 1. With lambda_1 = 0.9 sensor 2 needs
// lambda_2 > 1 - 1/1.6 = 0.375.
TEST(StabilityLinks, LatticeBlockUnequalRates)
{
  const Model m = multiModel(mat(2, 2, {2, 0, 0, -2}), {mat(1, 2, {1, 1}), mat(1, 2, {1, 1})});
  EXPECT_EQ(analyzeStability(m, iidLinks({0.9, 0.5})).model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(analyzeStability(m, iidLinks({0.9, 0.3})).model.verdict.kind, Verdict::Kind::UNSTABLE);
  EXPECT_EQ(analyzeStability(m, iidLinks({0.5, 0.9})).model.verdict.kind, Verdict::Kind::STABLE);
  const StabilityReport rep = analyzeStability(m, iidLinks({0.9, 0.5}));
  EXPECT_NEAR(rep.links[1].margin.band.converges_at, 0.375, 1e-6);
  EXPECT_NEAR(rep.links[0].margin.band.converges_at, 0.875, 1e-6);  // 1 - 1/(16 * 0.5)
  // i.i.d. links: a half-line even for a lattice block.
  EXPECT_TRUE(rep.links[1].margin.half_line);
  // Without a Gilbert-Elliott link the Markov threshold of this p-dependent block is not computed
  // (no failure rate is assumed).
  const StabilityReport none = analyzeStability(simpleModel(mat(2, 2, {2, 0, 0, -2}), mat(1, 2, {1, 1})), nullptr);
  EXPECT_TRUE(std::isnan(none.model.recovery_exact));
  EXPECT_NE(none.model.recovery_note.find("failure rate p unknown"), std::string::npos) << none.model.recovery_note;
}

// T4's modes (A = diag(2, 3)) both seen by two sensors c = [1 1]: two 1-D blocks with
// Phi = (1 - lambda_1)(1 - lambda_2); the block 3 decides: 9 (1 - lambda_1)(1 - lambda_2) < 1.
// With lambda_1 = 0.5, sensor 2 needs lambda_2 > 1 - 2/9 = 7/9.
TEST(StabilityLinks, OneDimensionalBlocksExactRate)
{
  const Model m = multiModel(mat(2, 2, {2, 0, 0, 3}), {mat(1, 2, {1, 1}), mat(1, 2, {1, 1})});
  const StabilityReport rep = analyzeStability(m, iidLinks({0.5, 0.9}));
  EXPECT_EQ(rep.model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_NEAR(rep.links[1].margin.band.converges_at, 7.0 / 9.0, 1e-6);
  // The MARE at this rate vector: for one sensor its threshold is 35/36 (T4), far above the exact
  // 8/9, and here too it diverges although E[P] is bounded: reported beside the verdict, which stays
  // the exact one.
  EXPECT_EQ(rep.mare_at_rates.rfind("diverges", 0), 0u) << rep.mare_at_rates;
  EXPECT_NE(rep.mare_at_rates.find("does not prove instability"), std::string::npos);
  // 9 (1 - lambda_1) 0.1 < 1 for every lambda_1: sensor 1 needs nothing.
  EXPECT_EQ(rep.links[0].margin.band.converges_at, 0.0);
  EXPECT_EQ(analyzeStability(m, iidLinks({0.5, 0.75})).model.verdict.kind, Verdict::Kind::UNSTABLE);
  // The same verdict function is public.
  std::vector<LinkModel> links = {LinkModel::iid(0.5), LinkModel::iid(0.8)};
  EXPECT_EQ(stabilityVerdict(m, {0, 1}, links).kind, Verdict::Kind::STABLE);
  links[1] = LinkModel::iid(0.77);
  EXPECT_EQ(stabilityVerdict(m, {0, 1}, links).kind, Verdict::Kind::UNSTABLE);
  // The single-channel form is the per-sensor form with the same link everywhere.
  const ChannelSettings ch = bernoulli(0.2);
  const StabilityReport one = analyzeStability(m, &ch);
  const StabilityReport per = analyzeStability(m, iidLinks({0.8, 0.8}));
  EXPECT_EQ(one.model.verdict.kind, per.model.verdict.kind);
  EXPECT_EQ(one.model.margin, per.model.margin);
  EXPECT_TRUE(per.uniform_links);
}

// Rotation by 90 degrees scaled by 1.2, c = [1 0], on/off Gilbert-Elliott link with p = 0.5. The
// block {+-1.2i} has order 2 and c sees each 1-D lattice element at one phase of two, so
// Phi = [P^2]_bad,bad^{1/2} = ((1 - r)^2 + r p)^{1/2} and the verdict is stable iff
// (1 - r)^2 + 0.5 r < 1/1.2^4, i.e. r in (0.538451, 0.961549) (the roots of
// r^2 - 1.5 r + 1 - 1/2.0736, to 6 decimals): not a half-line.
TEST(StabilityLinks, RotationStableInterval)
{
  const Model m = simpleModel(mat(2, 2, {0, -1.2, 1.2, 0}), mat(1, 2, {1, 0}));
  const auto at = [&](double r)
  {
    const ChannelSettings ge = gilbert(0.5, r);
    return analyzeStability(m, &ge);
  };
  EXPECT_EQ(at(0.45).model.verdict.kind, Verdict::Kind::UNSTABLE);
  EXPECT_EQ(at(0.6).model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(at(0.75).model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(at(0.9).model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(at(0.97).model.verdict.kind, Verdict::Kind::UNSTABLE);
  const StabilityReport rep = at(0.6);
  ASSERT_EQ(rep.links.size(), 1u);
  const SensorMargin& mg = rep.links[0].margin;
  EXPECT_EQ(mg.quantity, "recovery rate");
  EXPECT_FALSE(mg.half_line);
  ASSERT_EQ(mg.stable.size(), 1u);
  EXPECT_NEAR(mg.stable[0].lower, 0.538451, 1e-6);
  EXPECT_NEAR(mg.stable[0].upper, 0.961549, 1e-6);
  EXPECT_NEAR(mg.margin, 0.6 - mg.stable[0].lower, 1e-12);
  // The report never contradicts its verdicts: no single critical recovery rate, the same interval
  // for the set, thresholds unknown rather than inf.
  EXPECT_TRUE(std::isnan(rep.model.recovery_exact));
  ASSERT_EQ(rep.model.recovery_stable.size(), 1u);
  EXPECT_NEAR(rep.model.recovery_stable[0].lower, mg.stable[0].lower, 1e-9);
  EXPECT_TRUE(std::isnan(rep.model.sufficient_threshold));
  EXPECT_GT(rep.model.margin, 0.0);
  EXPECT_LT(at(0.97).model.margin, 0.0);
  // Each edge separates the verdicts of the same function.
  const auto kind = [&](double r) { return stabilityVerdict(m, {0}, {LinkModel::gilbertElliott(0.5, r)}).kind; };
  EXPECT_EQ(kind(mg.stable[0].lower + 1e-6), Verdict::Kind::STABLE);
  EXPECT_EQ(kind(mg.stable[0].lower - 1e-6), Verdict::Kind::UNSTABLE);
  EXPECT_EQ(kind(mg.stable[0].upper - 1e-6), Verdict::Kind::STABLE);
  EXPECT_EQ(kind(mg.stable[0].upper + 1e-6), Verdict::Kind::UNSTABLE);
}

// A hidden Gilbert-Elliott chain has no recovery-rate margin; a Jordan pair (Theorem 14
// unavailable) gets its margin from the necessary condition and the MARE, with a band.
TEST(StabilityLinks, MarginFallbacks)
{
  const Model m = multiModel(mat(2, 2, {2, 0, 0, 3}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  std::vector<std::optional<ChannelSettings>> links = iidLinks({0.8, 0.95});
  links[0] = gilbert(0.05, 0.4, 1.0, 0.005);
  const StabilityReport rep = analyzeStability(m, links);
  EXPECT_TRUE(rep.links[0].margin.quantity.empty());
  EXPECT_NE(rep.links[0].margin.note.find("not applicable"), std::string::npos);
  EXPECT_NE(rep.links[0].markov_note.find("not applicable"), std::string::npos);
  const MatrixXd J = mat(4, 4, {1.5, 1, 0, 0, 0, 1.5, 0, 0, 0, 0, -1.5, 1, 0, 0, 0, -1.5});
  const Model mj = multiModel(J, {mat(1, 4, {1, 0, 1, 0}), mat(1, 4, {1, 0, 1, 0})});
  const StabilityReport rj = analyzeStability(mj, iidLinks({0.9, 0.9}));
  const SensorMargin& mg = rj.links[1].margin;
  EXPECT_TRUE(mg.half_line);
  ASSERT_TRUE(std::isfinite(mg.band.converges_at));
  EXPECT_EQ(stabilityVerdict(mj, {0, 1}, {LinkModel::iid(0.9), LinkModel::iid(mg.band.converges_at)}).kind,
            Verdict::Kind::STABLE);
  if (std::isfinite(mg.band.diverges_at))
  {
    EXPECT_NE(stabilityVerdict(mj, {0, 1}, {LinkModel::iid(0.9), LinkModel::iid(mg.band.diverges_at)}).kind,
              Verdict::Kind::STABLE);
  }
}

// ---------------------------------------------------------------------------------------------
// Several sensors, each with its own Gilbert-Elliott link (Theorem 14 with independent per-sensor
// chains: the operator of a lattice element is the Kronecker product of the sensors' operators, so
// Phi is the product of per-sensor Perron roots).

namespace
{

/// [P^2]_bad,bad of an on/off Gilbert-Elliott chain: (1 - r)^2 + r p.
double twoStepBad(double p, double r)
{
  return (1.0 - r) * (1.0 - r) + r * p;
}

/// Spectral radius of diag(loss_good, loss_bad) K^2, K the chain's transition matrix: the two-step
/// operator of a hidden Gilbert-Elliott link that must lose one phase of two.
double hiddenTwoStep(double p, double r, double loss_bad, double loss_good)
{
  Eigen::Matrix2d K;
  K << 1.0 - p, p, r, 1.0 - r;  // row-stochastic, state 0 = good
  const Eigen::Matrix2d D = Eigen::Vector2d(loss_good, loss_bad).asDiagonal();
  return (D * K * K).eigenvalues().cwiseAbs().maxCoeff();
}

}  // namespace

// The rotation (order-2 block {+-1.2i}) seen by two sensors c = [1 0], each on its own on/off link:
// each lattice element is seen by both sensors at one phase of two, so
// Phi = (f_1 f_2)^{1/2} with f_j = (1 - r_j)^2 + r_j p_j, and E[P] is bounded iff
// 1.2^4 f_1 f_2 < 1. With sensor 1 nearly always down (p_1 = 0.95, r_1 = 0.02: f_1 = 0.9794) and
// p_2 = 0.5, sensor 2 needs r^2 - 1.5 r + 1 - 1/(1.2^4 f_1) < 0: an interval, not a half-line.
TEST(StabilityLinks, MarkovLatticeTwoSensorsInterval)
{
  const MatrixXd A = mat(2, 2, {0, -1.2, 1.2, 0});
  const Model m = multiModel(A, {mat(1, 2, {1, 0}), mat(1, 2, {1, 0})});
  const double a4 = std::pow(1.2, 4);
  const auto kind = [&](double p1, double r1, double p2, double r2) {
    return stabilityVerdict(m, {0, 1}, {LinkModel::gilbertElliott(p1, r1), LinkModel::gilbertElliott(p2, r2)}).kind;
  };
  // Verdicts on a grid against the closed form, away from the boundary by 2 % of the product.
  int checked = 0;
  for (double p1 : {0.3, 0.6, 0.95})
    for (double r1 : {0.02, 0.3, 0.7})
      for (double p2 : {0.2, 0.5, 0.9})
        for (double r2 : {0.05, 0.5, 0.9, 0.99})
        {
          const double g = a4 * twoStepBad(p1, r1) * twoStepBad(p2, r2);
          if (std::abs(g - 1.0) < 0.02)
            continue;
          EXPECT_EQ(kind(p1, r1, p2, r2), g < 1.0 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE)
              << p1 << " " << r1 << " " << p2 << " " << r2 << " product " << g;
          ++checked;
        }
  EXPECT_GT(checked, 90);
  // Sensor 2's recovery-rate margin with sensor 1 fixed: roots of r^2 - 1.5 r + 1 - B.
  const double B = 1.0 / (a4 * twoStepBad(0.95, 0.02));
  const double disc = std::sqrt(2.25 - 4.0 * (1.0 - B));
  const double lo = (1.5 - disc) / 2.0, hi = (1.5 + disc) / 2.0;
  ASSERT_LT(hi, 1.0);
  std::vector<std::optional<ChannelSettings>> links = {gilbert(0.95, 0.02), gilbert(0.5, 0.7)};
  const StabilityReport rep = analyzeStability(m, links);
  EXPECT_EQ(rep.model.verdict.kind, Verdict::Kind::STABLE);
  const SensorMargin& mg = rep.links[1].margin;
  EXPECT_EQ(mg.quantity, "recovery rate");
  EXPECT_FALSE(mg.half_line);
  ASSERT_EQ(mg.stable.size(), 1u);
  EXPECT_NEAR(mg.stable[0].lower, lo, 1e-6);
  EXPECT_NEAR(mg.stable[0].upper, hi, 1e-6);
  EXPECT_NEAR(mg.margin, std::min(0.7 - lo, hi - 0.7), 1e-6);
  // Outside the interval the joint verdict turns.
  links[1] = gilbert(0.5, hi + 0.01);
  EXPECT_EQ(analyzeStability(m, links).model.verdict.kind, Verdict::Kind::UNSTABLE);
  links[1] = gilbert(0.5, lo - 0.01);
  EXPECT_EQ(analyzeStability(m, links).model.verdict.kind, Verdict::Kind::UNSTABLE);
}

// T3's block (A = diag(2, -2)) with c_1 = [1 1] and c_2 = [1 -1]: the element span[1, -1] is seen by
// sensor 1 only at odd phases and by sensor 2 only at even phases (and span[1, 1] the other way
// round), so Phi = (f_1 f_2)^{1/2} with f_j the two-step operator's Perron root of sensor j's link:
// (1 - r)^2 + r p for an on/off link, rho(diag(loss_good, loss_bad) K^2) for a hidden one. E[P] is
// bounded iff 4 Phi < 1, i.e. f_1 f_2 < 1/16.
TEST(StabilityLinks, MarkovLatticeOppositePhases)
{
  const Model m = multiModel(mat(2, 2, {2, 0, 0, -2}), {mat(1, 2, {1, 1}), mat(1, 2, {1, -1})});
  int checked = 0;
  for (double p1 : {0.02, 0.1, 0.4})
    for (double r1 : {0.3, 0.6, 0.95})
      for (double p2 : {0.01, 0.05, 0.3})
        for (double r2 : {0.2, 0.5, 0.9})
        {
          const double g = 16.0 * twoStepBad(p1, r1) * twoStepBad(p2, r2);
          if (std::abs(g - 1.0) < 0.02)
            continue;
          const Verdict v =
              stabilityVerdict(m, {0, 1}, {LinkModel::gilbertElliott(p1, r1), LinkModel::gilbertElliott(p2, r2)});
          EXPECT_EQ(v.kind, g < 1.0 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE)
              << p1 << " " << r1 << " " << p2 << " " << r2 << " 16 f1 f2 = " << g << ": " << v.reason;
          ++checked;
        }
  EXPECT_GT(checked, 60);
  // A hidden chain on sensor 2 (lossy in both states) next to an on/off chain on sensor 1.
  for (double r2 : {0.2, 0.5, 0.8})
  {
    const double f1 = twoStepBad(0.05, 0.6), f2 = hiddenTwoStep(0.1, r2, 0.9, 0.1);
    const double g = 16.0 * f1 * f2;
    const Verdict v = stabilityVerdict(
        m, {0, 1}, {LinkModel::gilbertElliott(0.05, 0.6), LinkModel::gilbertElliott(0.1, r2, 0.9, 0.1)});
    ASSERT_GT(std::abs(g - 1.0), 0.02) << r2;
    EXPECT_EQ(v.kind, g < 1.0 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE) << r2 << " 16 f1 f2 = " << g;
  }
  // Mixed: sensor 1 i.i.d. (f_1 = 1 - lambda_1 at its phase), sensor 2 on/off Markov.
  for (double l1 : {0.5, 0.9})
    for (double r2 : {0.3, 0.8})
    {
      const double g = 16.0 * (1.0 - l1) * twoStepBad(0.2, r2);
      ASSERT_GT(std::abs(g - 1.0), 0.02);
      EXPECT_EQ(stabilityVerdict(m, {0, 1}, {LinkModel::iid(l1), LinkModel::gilbertElliott(0.2, r2)}).kind,
                g < 1.0 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE)
          << l1 << " " << r2 << " " << g;
    }
}

// T5's modes (A = diag(2, 3), each sensor sees one mode) on on/off Gilbert-Elliott links: 1-D blocks
// with Phi = P(loss -> loss) = 1 - r of the one sensor, so E[P] is bounded iff r_1 > 3/4 and
// r_2 > 8/9, whatever p_1, p_2: each margin is a half-line in the recovery rate.
TEST(StabilityLinks, MarkovSeparateModesRecovery)
{
  const Model m = multiModel(mat(2, 2, {2, 0, 0, 3}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  for (double p : {0.01, 0.3, 0.9})
  {
    const auto kind = [&](double r1, double r2) {
      return analyzeStability(m, {gilbert(p, r1), gilbert(p / 2, r2)}).model.verdict.kind;
    };
    EXPECT_EQ(kind(0.76, 0.9), Verdict::Kind::STABLE) << p;
    EXPECT_EQ(kind(0.74, 0.9), Verdict::Kind::UNSTABLE) << p;
    EXPECT_EQ(kind(0.9, 0.88), Verdict::Kind::UNSTABLE) << p;
    const StabilityReport rep = analyzeStability(m, {gilbert(p, 0.8), gilbert(p / 2, 0.95)});
    ASSERT_EQ(rep.links.size(), 2u);
    EXPECT_EQ(rep.links[0].margin.quantity, "recovery rate");
    EXPECT_TRUE(rep.links[0].margin.half_line);
    EXPECT_NEAR(rep.links[0].margin.band.converges_at, 0.75, 1e-6) << p;
    EXPECT_NEAR(rep.links[1].margin.band.converges_at, 8.0 / 9.0, 1e-6) << p;
  }
}

// T7's Jordan block (A = [[1.2, 1], [0, 1.2]]) seen by two sensors c = [1 0] at unequal rates: O is
// FCR once packets arrived at two different steps, so the bad event over T steps is "at most one
// step with an arrival", with rate Phi = (1 - lambda_1)(1 - lambda_2) (Corollary 26 with the empty
// word as the one bad matrix): E[P] is bounded iff 1.44 (1 - lambda_1)(1 - lambda_2) < 1.
TEST(StabilityLinks, JordanBlockUnequalRates)
{
  const Model m = multiModel(mat(2, 2, {1.2, 1, 0, 1.2}), {mat(1, 2, {1, 0}), mat(1, 2, {1, 0})});
  for (double l1 : {0.05, 0.1, 0.2})
    for (double l2 : {0.05, 0.1, 0.15, 0.2, 0.3})
    {
      const double g = 1.44 * (1.0 - l1) * (1.0 - l2);
      if (std::abs(g - 1.0) < 0.01)
        continue;
      const Verdict v = analyzeStability(m, iidLinks({l1, l2})).model.verdict;
      EXPECT_EQ(v.kind, g < 1.0 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE)
          << l1 << " " << l2 << " g = " << g << ": " << v.reason;
    }
  // Sensor 2's need with lambda_1 = 0.1: 1 - 1/(1.44 * 0.9) = 0.228395.
  const StabilityReport rep = analyzeStability(m, iidLinks({0.1, 0.5}));
  EXPECT_TRUE(rep.links[1].margin.half_line);
  EXPECT_NEAR(rep.links[1].margin.band.converges_at, 1.0 - 1.0 / (1.44 * 0.9), 1e-6) << rep.links[1].margin.note;
}

// A random walk (|alpha| = 1): every recovery rate r > 0 keeps E[P] bounded (Phi = 1 - r), so the
// critical recovery rate is 0, reported as 0 and not as the last bisection bracket.
TEST(StabilityLinks, RandomWalkRecoveryRateIsZero)
{
  const Model m = simpleModel(mat(1, 1, {1.0}), mat(1, 1, {1.0}));
  const ChannelSettings ge = gilbert(0.3, 0.4);
  const StabilityReport rep = analyzeStability(m, &ge);
  EXPECT_EQ(rep.model.recovery_exact, 0.0);
  EXPECT_EQ(rep.model.exact_rate, 0.0);
  EXPECT_EQ(rep.model.verdict.kind, Verdict::Kind::STABLE);
}

// ---------------------------------------------------------------------------------------------
// Sensor schedules (Marelli et al. section 7): the cyclostationary Theorem 14

namespace
{

/// Marelli et al.'s section 7.3 example: A = diag([[a1, 1], [0, a1]], a2), H1 = [[2, 1, 0], [0, 1, 0]]
/// (sees the Jordan block fully), H2 = [[0, 0, 1], [0, 0, 2]] (sees the mode a2 only); sensor 1
/// transmits at odd k, sensor 2 at even k. The paper leaves the noises open: Q = I (B = I) and
/// R = I for both sensors.
Model scheduledExample(double a1, double a2, bool periodic, double q = 0.5)
{
  Model m = multiModel(mat(3, 3, {a1, 1, 0, 0, a1, 0, 0, 0, a2}),
                       {mat(2, 3, {2, 1, 0, 0, 1, 0}), mat(2, 3, {0, 0, 1, 0, 0, 2})});
  if (periodic)
  {
    m.schedule.kind = Schedule::Kind::PERIODIC;
    m.schedule.pattern = {{true, false}, {false, true}};
  }
  else
  {
    m.schedule.kind = Schedule::Kind::RANDOM;
    m.schedule.subsets = {{true, false}, {false, true}};
    m.schedule.transition = mat(2, 2, {q, 1 - q, q, 1 - q});
    m.schedule.initial = Eigen::Vector2d(q, 1 - q);
  }
  validateModel(m, "scheduled");
  return m;
}

}  // namespace

// i.i.d. loss eps on each sensor's link: the Jordan block is seen every second step, so
// Phi_1 = eps^{1/2} and the verdict flips at a1^4 eps = 1 (the paper's result); the mode a2 < a1
// (Phi_2 = eps^{1/2} too) never decides.
TEST(StabilitySchedule, PeriodicExampleFlipsAtAlpha4Lambda)
{
  const double a1 = 1.2, a2 = 1.1;
  const Model m = scheduledExample(a1, a2, true);
  const double eps_star = 1.0 / std::pow(a1, 4);  // 0.482253
  for (double f : {0.9, 0.97, 0.995, 1.005, 1.03, 1.1})
  {
    const double eps = f * eps_star;
    const StabilityReport rep = analyzeStability(m, iidLinks({1 - eps, 1 - eps}));
    EXPECT_EQ(rep.model.verdict.kind, f < 1 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE)
        << eps << ": " << rep.model.verdict.reason;
    EXPECT_NEAR(rep.model.verdict.numbers.at("max |alpha|^2 Phi"), a1 * a1 * std::sqrt(eps), 1e-9);
    EXPECT_NE(rep.model.verdict.reason.find("sensor schedule, tau = 2"), std::string::npos) << rep.model.verdict.reason;
  }
  // The common arrival rate at which it turns stable: 1 - 1/a1^4.
  const StabilityReport rep = analyzeStability(m, iidLinks({0.6, 0.6}));
  EXPECT_NEAR(rep.model.exact_rate, 1.0 - eps_star, 1e-6);
  EXPECT_NE(rep.model.exact_method.find("sensor schedule"), std::string::npos);
  EXPECT_TRUE(std::isnan(rep.model.lower_bound));
  EXPECT_NE(rep.mare_at_rates.find("not applicable: a sensor schedule"), std::string::npos);
  // Sensor 1's need with sensor 2 at 0.6: its own arrival rate > 1 - 1/a1^4 (sensor 2 only sees
  // the mode a2, which needs a2^4 (1 - lambda_2) < 1).
  EXPECT_NEAR(rep.links[0].margin.band.converges_at, 1.0 - eps_star, 1e-6);
  EXPECT_NEAR(rep.links[1].margin.band.converges_at, 1.0 - 1.0 / std::pow(a2, 4), 1e-6);
  // Without the schedule the same links are far more than enough: every step carries both sensors.
  Model plain = m;
  plain.schedule = Schedule();
  EXPECT_EQ(analyzeStability(plain, iidLinks({0.45, 0.45})).model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_EQ(analyzeStability(m, iidLinks({0.45, 0.45})).model.verdict.kind, Verdict::Kind::UNSTABLE);
}

// Gilbert-Elliott links that run in time (advance every step): sensor 1 transmits every second step,
// so the two-step matrix decides: Phi_1 = ([P^2]_bad,bad)^{1/2} = ((1 - r)^2 + r p)^{1/2}, and the
// verdict flips at a1^4 [P^2]_bad,bad = 1.
TEST(StabilitySchedule, PeriodicExampleMarkovTwoStep)
{
  const double a1 = 1.2;
  const Model m = scheduledExample(a1, 1.1, true);
  for (double p : {0.1, 0.4})
    for (double r : {0.2, 0.35, 0.5, 0.7, 0.9})
    {
      const double g = std::pow(a1, 4) * twoStepBad(p, r);
      if (std::abs(g - 1.0) < 0.01)
        continue;
      const StabilityReport rep = analyzeStability(m, {gilbert(p, r), gilbert(p, r)});
      EXPECT_EQ(rep.model.verdict.kind, g < 1 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE)
          << p << " " << r << " a1^4 [P^2]_bb = " << g << ": " << rep.model.verdict.reason;
    }
}

// A random i.i.d. schedule: sensor 1 with probability q, else sensor 2; loss eps on each link. At
// each step the Jordan block gets nothing with probability 1 - q (1 - eps), so
// Phi_1 = 1 - q (1 - eps) and the block is bounded iff a1^2 (1 - q (1 - eps)) < 1; the mode a2
// likewise with 1 - q.
TEST(StabilitySchedule, RandomScheduleIid)
{
  const double a1 = 1.2, a2 = 1.1;
  for (double q : {0.5, 0.8})
    for (double eps : {0.05, 0.2, 0.4, 0.6})
    {
      const Model m = scheduledExample(a1, a2, false, q);
      const double g = std::max(a1 * a1 * (1 - q * (1 - eps)), a2 * a2 * (1 - (1 - q) * (1 - eps)));
      if (std::abs(g - 1.0) < 0.01)
        continue;
      const Verdict v = analyzeStability(m, iidLinks({1 - eps, 1 - eps})).model.verdict;
      EXPECT_EQ(v.kind, g < 1 ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE) << q << " " << eps << " g = " << g;
      EXPECT_NEAR(v.numbers.at("max |alpha|^2 Phi"), g, 1e-9) << q << " " << eps;
    }
  // A Markov schedule with Gilbert-Elliott links runs on the joint chain (2 x 2 x 2 states); with a
  // schedule that always picks sensor 1 (row [1, 0]) it is the unscheduled single-link case:
  // Phi_1 = 1 - r.
  Model m = scheduledExample(a1, a2, false, 1.0);
  m.schedule.markov = true;
  m.schedule.transition = mat(2, 2, {1, 0, 1, 0});
  m.schedule.initial = Eigen::Vector2d(1, 0);
  const Verdict v = analyzeStability(m, {gilbert(0.2, 0.5), gilbert(0.2, 0.5)}).model.verdict;
  // Block 2 is never seen: unstable whatever block 1 does; block 1 alone: 1.44 * 0.5 < 1.
  EXPECT_EQ(v.kind, Verdict::Kind::UNSTABLE);
  const std::vector<BlockStructure> blocks = analyseBlocks(m.A, {m.C.topRows(2), m.C.bottomRows(2)});
  ASSERT_EQ(blocks.size(), 2u);
  const std::vector<LinkModel> links = {LinkModel::gilbertElliott(0.2, 0.5), LinkModel::gilbertElliott(0.2, 0.5)};
  EXPECT_NEAR(blockPhiScheduled(blocks[0], links, m.schedule), 0.5, 1e-12);
  EXPECT_NEAR(blockPhiScheduled(blocks[1], links, m.schedule), 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Link design (link_design.hpp): least-cost i.i.d. rates against the closed forms

TEST(StabilityDesign, ClosedForms)
{
  const double g = 0.9;
  // T5's modes, one sensor each: lambda_1 = 1 - g/4, lambda_2 = 1 - g/9 for either cost.
  const Model t5 = multiModel(mat(2, 2, {2, 0, 0, 3}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  for (DesignCost c : {DesignCost::TOTAL_RATE, DesignCost::CAPACITY})
  {
    const LinkDesign d = designLinks(t5, c, g);
    ASSERT_TRUE(d.applicable) << d.note;
    EXPECT_NEAR(d.rates[0], 1 - g / 4, 1e-9);
    EXPECT_NEAR(d.rates[1], 1 - g / 9, 1e-9);
    EXPECT_NEAR(d.alone[1], 1 - g / 9, 1e-9);
    EXPECT_EQ(d.check.kind, Verdict::Kind::STABLE);
    EXPECT_NEAR(d.check.numbers.at("max |alpha|^2 Phi"), g, 1e-9);  // on the cap: the least cost
  }
  // T4's modes seen by both sensors: only (1 - l1)(1 - l2) <= g/9 matters; the least total rate
  // puts it all on one sensor (concave cost: a vertex), 1 - g/9; the capacity is the same.
  const Model t4 = multiModel(mat(2, 2, {2, 0, 0, 3}), {mat(1, 2, {1, 1}), mat(1, 2, {1, 1})});
  const LinkDesign d4 = designLinks(t4, DesignCost::TOTAL_RATE, g);
  ASSERT_TRUE(d4.applicable) << d4.note;
  EXPECT_NEAR(d4.rates[0] + d4.rates[1], 1 - g / 9, 1e-9);
  EXPECT_NEAR(std::min(d4.rates[0], d4.rates[1]), 0.0, 1e-12);
  EXPECT_NEAR(designLinks(t4, DesignCost::CAPACITY, g).cost_value, std::log(9 / g), 1e-9);
  EXPECT_EQ(d4.alone[0], 0.0);  // the other sensor alone, lossless, suffices
  // T3 (lattice of order 2): Phi = (1 - lambda)^{1/2}: lambda = 1 - (g/4)^2 -> 15/16 as g -> 1.
  const Model t3 = simpleModel(mat(2, 2, {2, 0, 0, -2}), mat(1, 2, {1, 1}));
  EXPECT_NEAR(designLinks(t3, DesignCost::TOTAL_RATE, g).rates[0], 1 - g * g / 16, 1e-9);
  const double near = designLinks(t3, DesignCost::TOTAL_RATE, 0.9999).rates[0];
  EXPECT_GT(near, 15.0 / 16.0);
  EXPECT_LT(near, 15.0 / 16.0 + 1e-4);
  // An unstable mode no sensor observes (3 here) grows whatever the links do: no design keeps
  // E[P] bounded, so none is given and the note names the state.
  const LinkDesign dr = designLinks(simpleModel(mat(2, 2, {2, 0, 0, 3}), mat(1, 2, {1, 0})), DesignCost::TOTAL_RATE, g);
  EXPECT_FALSE(dr.applicable);
  EXPECT_TRUE(dr.rates.empty());
  EXPECT_EQ(dr.note.rfind("not applicable: state 1 grows regardless of the links", 0), 0u) << dr.note;
  // Not applicable: a schedule, a bad cap.
  EXPECT_FALSE(designLinks(t5, DesignCost::TOTAL_RATE, 1.0).applicable);
  Model sched = t5;
  sched.schedule.kind = Schedule::Kind::PERIODIC;
  sched.schedule.pattern = {{true, false}, {false, true}};
  EXPECT_NE(designLinks(sched, DesignCost::TOTAL_RATE).note.find("schedule"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Blocks that are not diagonalizable (docs/stability.md 3.5c): the kernel lattice of the unipotent
// part, checked exhaustively against the rank of the rows a window of packets actually delivers.

namespace
{

/// Rank of the rows H_j A^t (t = time in the window) of the received (sensor, time) pairs,
/// restricted to nothing (the whole state: these systems are one block).
int receivedRank(const MatrixXd& A, const std::vector<MatrixXd>& H, const std::vector<std::vector<bool>>& got)
{
  const int n = static_cast<int>(A.rows());
  MatrixXd rows(0, n);
  MatrixXd At = MatrixXd::Identity(n, n);
  for (std::size_t t = 0; t < got.size(); ++t)
  {
    for (std::size_t j = 0; j < H.size(); ++j)
      if (got[t][j])
      {
        rows.conservativeResize(rows.rows() + H[j].rows(), n);
        rows.bottomRows(H[j].rows()) = H[j] * At;
      }
    At = A * At;
  }
  return rows.rows() == 0 ? 0 : numericalRank(rows.cast<std::complex<double>>(), 1e-9);
}

}  // namespace

// For every arrival pattern of a window of T steps (every subset of the (sensor, time) pairs), with
// N the block's order and n_k its dimension:
//  - lower bound: if, for some lattice element K, no (sensor, phase) pair that informs on K
//    delivered anything, the window leaves the block unobservable;
//  - upper bound: if the window leaves the block unobservable, then for some lattice element K,
//    every (sensor, phase) pair that informs on K delivered fewer than n_k packets.
// Together they give Phi = max over K of prod_j rho(prod_s D_js P_j)^{1/N} (docs/stability.md 3.5c).
// Systems: a Jordan pair at +-1.5 (order 2) with c = [1 0 1 0]; a constant-velocity block with a
// position and a velocity sensor; a constant-acceleration block with a velocity sensor; and a
// Jordan block of size 2 beside a 1-D block at the same eigenvalue with a sensor on each.
TEST(StabilityJordan, LatticePredictsEveryWindow)
{
  struct System
  {
    const char* name;
    MatrixXd A;
    std::vector<MatrixXd> H;
    int T;
  };
  const std::vector<System> systems = {
      {"jordan pair",
       mat(4, 4, {1.5, 1, 0, 0, 0, 1.5, 0, 0, 0, 0, -1.5, 1, 0, 0, 0, -1.5}),
       {mat(1, 4, {1, 0, 1, 0})},
       12},
      {"constant velocity", mat(2, 2, {1, 0.1, 0, 1}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})}, 7},
      {"constant acceleration",
       mat(3, 3, {1, 0.1, 0.005, 0, 1, 0.1, 0, 0, 1}),
       {mat(1, 3, {0, 1, 0}), mat(1, 3, {1, 0, 0})},
       6},
      {"jordan beside 1-D",
       mat(3, 3, {1.2, 1, 0, 0, 1.2, 0, 0, 0, 1.2}),
       {mat(1, 3, {0, 1, 1}), mat(1, 3, {1, 0, 0})},
       6}};
  for (const System& sys : systems)
  {
    const auto blocks = analyseBlocks(sys.A, sys.H);
    ASSERT_EQ(blocks.size(), 1u) << sys.name;
    const BlockStructure& b = blocks[0];
    ASSERT_NE(b.method, BlockStructure::Method::UNAVAILABLE) << sys.name;
    const int n = static_cast<int>(sys.A.rows());
    const int N = b.block.order;
    const std::size_t S = sys.H.size();
    const int pairs = sys.T * static_cast<int>(S);
    int unobservable = 0;
    for (long mask = 0; mask < (1L << pairs); ++mask)
    {
      std::vector<std::vector<bool>> got(sys.T, std::vector<bool>(S));
      std::vector<std::vector<int>> count(S, std::vector<int>(N, 0));  // packets per (sensor, phase)
      for (int t = 0; t < sys.T; ++t)
        for (std::size_t j = 0; j < S; ++j)
        {
          got[t][j] = (mask >> (t * static_cast<int>(S) + static_cast<int>(j))) & 1L;
          count[j][t % N] += got[t][j] ? 1 : 0;
        }
      const bool unobs = receivedRank(sys.A, sys.H, got) < n;
      bool silent = false, few = false;
      for (const auto& seen : b.seen)
      {
        bool all_silent = true, all_few = true;
        for (std::size_t j = 0; j < S; ++j)
          for (int s = 0; s < N; ++s)
            if (seen[j][s])
            {
              all_silent = all_silent && count[j][s] == 0;
              all_few = all_few && count[j][s] < n;
            }
        silent = silent || all_silent;
        few = few || all_few;
      }
      if (silent)
        ASSERT_TRUE(unobs) << sys.name << ": mask " << mask << " silences a lattice element but is observable";
      if (unobs)
        ASSERT_TRUE(few) << sys.name << ": mask " << mask << " is unobservable with every element informed";
      unobservable += unobs ? 1 : 0;
    }
    EXPECT_GT(unobservable, 0) << sys.name;
  }
}

// The lattices themselves, and Phi: the Jordan pair needs both phases (Phi = (1 - l)^{1/2}); the
// constant-velocity block with a velocity sensor has the position direction as an element that only
// the position sensor informs on (Phi = its loss persistence, the velocity sensor cannot help).
TEST(StabilityJordan, PhiOfJordanStructures)
{
  const auto pair =
      analyseBlocks(mat(4, 4, {1.5, 1, 0, 0, 0, 1.5, 0, 0, 0, 0, -1.5, 1, 0, 0, 0, -1.5}), {mat(1, 4, {1, 0, 1, 0})});
  ASSERT_EQ(pair.size(), 1u);
  EXPECT_EQ(pair[0].method, BlockStructure::Method::LATTICE);
  EXPECT_EQ(pair[0].block.order, 2);
  EXPECT_EQ(pair[0].seen.size(), 3u);  // the block and the two halves each phase leaves unobservable
  EXPECT_NEAR(blockPhi(pair[0], {LinkModel::iid(0.6)}), std::sqrt(0.4), 1e-12);
  const auto cv = analyseBlocks(mat(2, 2, {1, 0.1, 0, 1}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  ASSERT_EQ(cv.size(), 1u);
  EXPECT_EQ(cv[0].seen.size(), 2u);
  EXPECT_NEAR(blockPhi(cv[0], {LinkModel::iid(0.3), LinkModel::iid(0.9)}), 0.7, 1e-12);
  EXPECT_NEAR(blockPhi(cv[0], {LinkModel::iid(0.3), LinkModel::iid(0.0)}), 0.7, 1e-12);
  EXPECT_EQ(blockPhi(cv[0], {LinkModel::iid(0.0), LinkModel::iid(1.0)}), 1.0);
  EXPECT_TRUE(blockGrowth(cv[0], {LinkModel::iid(0.0), LinkModel::iid(1.0)}).one);
  EXPECT_FALSE(blockGrowth(cv[0], {LinkModel::iid(1e-9), LinkModel::iid(0.0)}).one);
  // A Gilbert-Elliott link that never leaves its bad state (r = 0, every packet lost there) keeps
  // Phi at exactly 1; any r > 0 brings it below 1.
  EXPECT_TRUE(blockGrowth(cv[0], {LinkModel::gilbertElliott(0.1, 0.0), LinkModel::iid(1.0)}).one);
  EXPECT_FALSE(blockGrowth(cv[0], {LinkModel::gilbertElliott(0.1, 1e-6), LinkModel::iid(1.0)}).one);
}

// On the unit circle the verdict is exact (docs/stability.md 3.5d): a constant-velocity model with a
// position sensor and a velocity sensor is stable at every positive position rate, whatever the
// velocity link does, and unstable at rate 0; the position sensor "needs > 0" and the velocity
// sensor needs nothing. With only velocity sensors the positions are dead-reckoned: reported apart,
// and the verdict about the links is stable.
TEST(StabilityJordan, ConstantVelocityVerdictsAndMargins)
{
  const Model m = multiModel(mat(2, 2, {1, 0.1, 0, 1}), {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})});
  for (double pos : {1e-6, 0.01, 0.5, 1.0})
    for (double vel : {0.0, 0.3, 1.0})
      EXPECT_EQ(stabilityVerdict(m, {0, 1}, {LinkModel::iid(pos), LinkModel::iid(vel)}).kind, Verdict::Kind::STABLE)
          << pos << " " << vel;
  const Verdict lost = stabilityVerdict(m, {0, 1}, {LinkModel::iid(0.0), LinkModel::iid(1.0)});
  EXPECT_EQ(lost.kind, Verdict::Kind::UNSTABLE);
  EXPECT_NE(lost.reason.find("Phi = 1"), std::string::npos) << lost.reason;
  EXPECT_EQ(stabilityVerdict(m, {0, 1}, {LinkModel::gilbertElliott(0.2, 0.0), LinkModel::iid(1.0)}).kind,
            Verdict::Kind::UNSTABLE);
  const std::vector<SensorMargin> margins = sensorMargins(m, {LinkModel::iid(0.2), LinkModel::iid(0.7)});
  ASSERT_EQ(margins.size(), 2u);
  EXPECT_TRUE(margins[0].any_positive) << margins[0].note;
  EXPECT_EQ(margins[0].band.converges_at, 0.0);
  EXPECT_DOUBLE_EQ(margins[0].margin, 0.2);
  EXPECT_FALSE(margins[1].any_positive);
  EXPECT_EQ(margins[1].band.converges_at, 0.0) << margins[1].note;
  EXPECT_NE(margins[1].note.find("cover"), std::string::npos);
  const StabilityReport rep = analyzeStability(m, iidLinks({0.2, 0.7}));
  EXPECT_EQ(rep.model.exact_rate, 0.0);
  EXPECT_EQ(rep.model.verdict.kind, Verdict::Kind::STABLE);
  EXPECT_TRUE(rep.links[0].margin.any_positive);
  // Velocity only: the position is dead-reckoned (its variance grows linearly whatever the links
  // do): unstable, and the sensor's needed rate is none; the velocity alone needs any positive rate.
  const Model vel = multiModel(mat(2, 2, {1, 0.1, 0, 1}), {mat(1, 2, {0, 1})});
  const StabilityReport rv = analyzeStability(vel, iidLinks({0.5}));
  EXPECT_FALSE(rv.dead_reckoned.empty());
  EXPECT_NE(rv.dead_reckoned.find("(1) of state 0 "), std::string::npos) << rv.dead_reckoned;
  EXPECT_EQ(rv.model.verdict.kind, Verdict::Kind::UNSTABLE) << rv.model.verdict.reason;
  EXPECT_EQ(rv.model.links_verdict.kind, Verdict::Kind::STABLE) << rv.model.links_verdict.reason;
  EXPECT_EQ(SetVerdicts(vel, {0}).deadReckoned(), rv.dead_reckoned);
  ASSERT_EQ(rv.links.size(), 1u);
  const SensorMargin& vm = rv.links[0].margin;
  EXPECT_TRUE(std::isnan(vm.band.converges_at)) << vm.note;
  EXPECT_TRUE(std::isnan(vm.margin));
  EXPECT_EQ(vm.grows_regardless, "state 0");
  EXPECT_EQ(vm.converges_at_observed, 0.0) << vm.note;
  EXPECT_EQ(vm.note.rfind("none: state 0 grows regardless of the links", 0), 0u) << vm.note;
}

// SetVerdicts computes the model's part once: the same verdicts and margins as the free functions.
TEST(StabilityJordan, SetVerdictsAgreeWithFreeFunctions)
{
  const Model m =
      multiModel(mat(3, 3, {1.2, 1, 0, 0, 1.2, 0, 0, 0, 0.5}), {mat(1, 3, {1, 0, 1}), mat(1, 3, {0, 1, 0})});
  const SetVerdicts sv(m, {0, 1});
  EXPECT_TRUE(sv.exact());
  for (double a : {0.1, 0.3, 0.5})
    for (double b : {0.0, 0.4, 0.9})
    {
      const std::vector<LinkModel> links = {LinkModel::iid(a), LinkModel::iid(b)};
      EXPECT_EQ(sv.verdict(links).reason, stabilityVerdict(m, {0, 1}, links).reason);
      const auto m1 = sv.margins(links), m2 = sensorMargins(m, links);
      for (std::size_t i = 0; i < 2; ++i)
        EXPECT_EQ(m1[i].note, m2[i].note);
    }
  EXPECT_THROW(sv.verdict({LinkModel::iid(0.5)}), std::invalid_argument);
  EXPECT_THROW(SetVerdicts(m, {0, 2}), std::invalid_argument);
  EXPECT_THROW(SetVerdicts(m, {0}).margins({LinkModel::iid(0.5)}), std::invalid_argument);
}
