// The stability verdicts against an oracle of the test's own (docs/stability.md 2): seeded random
// models whose eigen-structure is chosen, so that the answer follows from the closed form of
// Marelli et al.'s Theorem 14 for blocks of order 1, written here without the library:
//
//   E[P] bounded  <=>  |lambda_j|^2 prod_{s sees j} f_s < 1  for every mode j with |lambda_j| >= 1,
//
// f_s the loss persistence of sensor s's link (i.i.d.: 1 - arrival rate; on/off Gilbert-Elliott:
// 1 - r; lossless: 0), "s sees j" meaning C_s v_j != 0 for the eigenvector v_j. A mode that no
// sensor sees has an empty product (1), so it is unbounded whenever |lambda_j| >= 1: the
// dead-reckoned case. The links' verdict is the same condition over the modes some sensor sees.
// This holds when A is diagonalizable with distinct moduli (each real eigenvalue, and each complex
// pair whose angle is not a rational multiple of pi with a small denominator, is a block of order
// 1), and for a Jordan block on the unit circle, where lambda = +-1 and its eigenvector decide.
//
// Also the rate each sensor needs (others fixed) from the same formula, and a few Monte Carlo
// growth checks of E[P_k] on each side of the boundary with a Riccati recursion written here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "networked_estimation/stability/stability.hpp"
#include "stability_test_support.hpp"

using namespace networked_estimation;
using namespace networked_estimation::test;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

/// A block of the modal form: a real eigenvalue, a complex pair (rotation block), or a 2 x 2 Jordan
/// block with lambda = +-1.
struct Block
{
  enum Kind
  {
    REAL,
    COMPLEX,
    JORDAN
  } kind = REAL;
  double modulus = 0.0;
  double value = 0.0;  ///< REAL, JORDAN: the eigenvalue
  double angle = 0.0;  ///< COMPLEX: the argument
  int offset = 0;      ///< first modal coordinate
  int size() const { return kind == REAL ? 1 : 2; }
};

struct OracleCase
{
  Model model;
  std::vector<Block> blocks;
  std::vector<std::vector<bool>> sees;  ///< sees[s][b]: sensor s sees block b
  std::vector<std::optional<ChannelSettings>> links;
  std::vector<double> f;  ///< per sensor: loss persistence of its link
};

/// A random angle in (0.2, pi - 0.2) whose ratio to pi is at least 2e-3 from every p/q, q <= 30: the
/// pair is then two blocks of order 1 (the library groups ratios with denominators up to 24).
double irrationalAngle(std::mt19937_64& rng)
{
  std::uniform_real_distribution<double> u(0.2, M_PI - 0.2);
  for (;;)
  {
    const double t = u(rng);
    bool ok = true;
    for (int q = 1; q <= 30 && ok; ++q)
      ok = std::abs(t / M_PI * q - std::round(t / M_PI * q)) / q > 2e-3;
    if (ok)
      return t;
  }
}

OracleCase randomCase(std::mt19937_64& rng)
{
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  OracleCase c;
  // Blocks: moduli in [0.3, 2.5] at least 0.08 apart and from 1, at most one unit Jordan block.
  const int target = 2 + static_cast<int>(u01(rng) * 5);  // n in 2..6
  int n = 0;
  bool jordan = false;
  std::vector<double> moduli;
  while (n < target)
  {
    Block b;
    const double pick = u01(rng);
    if (pick < 0.2 && !jordan && target - n >= 2)
    {
      b.kind = Block::JORDAN;
      b.value = u01(rng) < 0.5 ? 1.0 : -1.0;
      b.modulus = 1.0;
      jordan = true;
    }
    else
    {
      b.kind = pick < 0.6 || target - n < 2 ? Block::REAL : Block::COMPLEX;
      for (;;)
      {
        b.modulus = 0.3 + 2.2 * u01(rng);
        bool apart = std::abs(b.modulus - 1.0) > 0.08;
        for (double m : moduli)
          apart = apart && std::abs(b.modulus - m) > 0.08;
        if (apart)
          break;
      }
      if (b.kind == Block::REAL)
        b.value = u01(rng) < 0.5 ? b.modulus : -b.modulus;
      else
        b.angle = irrationalAngle(rng);
    }
    moduli.push_back(b.modulus);
    b.offset = n;
    n += b.size();
    c.blocks.push_back(b);
  }
  MatrixXd J = MatrixXd::Zero(n, n);
  for (const Block& b : c.blocks)
  {
    const int o = b.offset;
    if (b.kind == Block::REAL)
      J(o, o) = b.value;
    else if (b.kind == Block::JORDAN)
      J.block(o, o, 2, 2) << b.value, 1.0, 0.0, b.value;
    else
      J.block(o, o, 2, 2) << b.modulus * std::cos(b.angle), -b.modulus * std::sin(b.angle),
          b.modulus * std::sin(b.angle), b.modulus * std::cos(b.angle);
  }
  // A well-conditioned change of basis x = T z.
  MatrixXd T(n, n);
  for (;;)
  {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        T(i, j) = gauss(rng);
    Eigen::JacobiSVD<MatrixXd> svd(T);
    const VectorXd sv = svd.singularValues();
    if (sv(n - 1) > 0 && sv(0) / sv(n - 1) < 30.0)
      break;
  }
  const MatrixXd Tinv = T.inverse();
  // Sensors: 1-4, each 1 or 2 rows, each seeing a random subset of the blocks.
  const int S = 1 + static_cast<int>(u01(rng) * 4);
  std::vector<MatrixXd> Cs;
  for (int s = 0; s < S; ++s)
  {
    const int rows = u01(rng) < 0.7 ? 1 : 2;
    MatrixXd Cm = MatrixXd::Zero(rows, n);
    std::vector<bool> sees;
    for (const Block& b : c.blocks)
    {
      const bool seen = u01(rng) < 0.6;
      bool counts = seen;
      if (seen)
        for (int r = 0; r < rows; ++r)
          for (int k = 0; k < b.size(); ++k)
          {
            const double v = gauss(rng);
            Cm(r, b.offset + k) = (v < 0 ? -0.2 : 0.2) + v;  // |entry| > 0.2: clearly seen
          }
      // A Jordan block seen through its second coordinate only: C v = 0 for its eigenvector e1, so
      // the block is not seen (the integrated coordinate is dead-reckoned).
      if (seen && b.kind == Block::JORDAN && u01(rng) < 0.3)
      {
        Cm.col(b.offset).setZero();
        counts = false;
      }
      sees.push_back(counts);
    }
    c.sees.push_back(sees);
    Cs.push_back(Cm * Tinv);
  }
  c.model = multiModel(T * J * Tinv, Cs);
  // Random noise covariances: R_s = L L' + 0.1 I (whitening must not change what a sensor sees).
  for (const Sensor& s : c.model.sensors)
  {
    MatrixXd L(s.size, s.size);
    for (int i = 0; i < s.size; ++i)
      for (int j = 0; j < s.size; ++j)
        L(i, j) = gauss(rng);
    c.model.R.block(s.offset, s.offset, s.size, s.size) = L * L.transpose() + 0.1 * MatrixXd::Identity(s.size, s.size);
  }
  validateModel(c.model, "oracle");
  // Links: i.i.d., on/off Gilbert-Elliott or lossless.
  for (int s = 0; s < S; ++s)
  {
    const double pick = u01(rng);
    if (pick < 0.45)
    {
      const double arrival = 0.05 + 0.95 * u01(rng);
      c.links.push_back(bernoulli(1.0 - arrival));
      c.f.push_back(1.0 - arrival);
    }
    else if (pick < 0.85)
    {
      const double p = 0.05 + 0.55 * u01(rng), r = 0.05 + 0.95 * u01(rng);
      c.links.push_back(gilbert(p, r));
      c.f.push_back(1.0 - r);
    }
    else
    {
      c.links.push_back(std::nullopt);
      c.f.push_back(0.0);
    }
  }
  // At least one channel: with every sensor lossless the analysis has no link to judge.
  if (std::none_of(c.links.begin(), c.links.end(), [](const auto& l) { return l.has_value(); }))
  {
    const double arrival = 0.05 + 0.95 * u01(rng);
    c.links[0] = bernoulli(1.0 - arrival);
    c.f[0] = 1.0 - arrival;
  }
  return c;
}

/// |lambda_b|^2 prod_{s sees b} f_s, with sensor `skip` left out (-1: none).
double growth(const OracleCase& c, std::size_t b, int skip = -1)
{
  double g = c.blocks[b].modulus * c.blocks[b].modulus;
  for (std::size_t s = 0; s < c.f.size(); ++s)
    if (c.sees[s][b] && static_cast<int>(s) != skip)
      g *= c.f[s];
  return g;
}

bool seenBySome(const OracleCase& c, std::size_t b)
{
  for (const auto& row : c.sees)
    if (row[b])
      return true;
  return false;
}

enum class Truth
{
  BOUNDED,
  UNBOUNDED,
  TOO_CLOSE  ///< within 1e-6 of the boundary: not checked
};

/// The oracle's answer over the blocks with |lambda| >= 1 (only those some sensor sees: `links_only`).
Truth oracle(const OracleCase& c, bool links_only)
{
  Truth t = Truth::BOUNDED;
  for (std::size_t b = 0; b < c.blocks.size(); ++b)
  {
    if (c.blocks[b].modulus < 1.0 || (links_only && !seenBySome(c, b)))
      continue;
    const double g = growth(c, b);
    if (g >= 1.0 + 1e-6 || (c.blocks[b].modulus == 1.0 && g == 1.0))
      return Truth::UNBOUNDED;  // on the unit circle: exactly 1 when nothing that arrives sees it
    if (g > 1.0 - 1e-6)
      t = Truth::TOO_CLOSE;
  }
  return t;
}

const char* name(Truth t)
{
  return t == Truth::BOUNDED ? "stable" : t == Truth::UNBOUNDED ? "unstable" : "too close";
}

/// The least rate of sensor s (its arrival rate, or recovery rate r at its p), the others fixed, that
/// keeps the blocks of `links_only`'s scope bounded: max over the blocks s sees of 1 - 1 / g_without_s;
/// NaN when some block it does not see is unbounded anyway, or (not links_only) some block with
/// |lambda| >= 1 is seen by nobody.
double neededRate(const OracleCase& c, int s, bool links_only)
{
  double need = 0.0;
  for (std::size_t b = 0; b < c.blocks.size(); ++b)
  {
    if (c.blocks[b].modulus < 1.0 || (links_only && !seenBySome(c, b)))
      continue;
    const double g = growth(c, b, s);
    if (!c.sees[static_cast<std::size_t>(s)][b])
    {
      if (g >= 1.0)
        return std::nan("");
      continue;
    }
    need = std::max(need, 1.0 - 1.0 / g);
  }
  return need;
}

std::string describeCase(const OracleCase& c)
{
  std::string out = "blocks:";
  char buf[128];
  for (const Block& b : c.blocks)
  {
    std::snprintf(buf, sizeof buf, " %s |%.4f|",
                  b.kind == Block::REAL     ? "real"
                  : b.kind == Block::JORDAN ? "jordan"
                                            : "pair",
                  b.modulus);
    out += buf;
  }
  for (std::size_t s = 0; s < c.f.size(); ++s)
  {
    std::snprintf(buf, sizeof buf, "; s%zu f=%.4f sees", s + 1, c.f[s]);
    out += buf;
    for (std::size_t b = 0; b < c.blocks.size(); ++b)
      out += c.sees[s][b] ? " 1" : " 0";
  }
  return out;
}

}  // namespace

// 240 seeded random models: the verdict, the links' verdict and every sensor's needed rate against
// the closed form; verdictOnly against the full report on every 8th model.
TEST(StabilityOracle, RandomModelsAgreeWithTheClosedForm)
{
  std::mt19937_64 rng(20261206);
  int models = 0, verdicts = 0, margins = 0, disagreements = 0, close = 0, unstable = 0, dead = 0;
  for (int k = 0; k < 240; ++k)
  {
    const OracleCase c = randomCase(rng);
    ++models;
    const VerdictReport v = verdictOnly(c.model, c.links);
    const Truth truth = oracle(c, false), links_truth = oracle(c, true);
    if (truth == Truth::TOO_CLOSE || links_truth == Truth::TOO_CLOSE)
    {
      ++close;
      continue;
    }
    const Verdict::Kind want = truth == Truth::BOUNDED ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE;
    const Verdict::Kind want_links = links_truth == Truth::BOUNDED ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE;
    unstable += truth == Truth::UNBOUNDED;
    dead += v.dead_states.empty() ? 0 : 1;
    verdicts += 2;
    if (v.verdict.kind != want || v.links_verdict.kind != want_links)
      ++disagreements;
    EXPECT_EQ(v.verdict.kind, want) << "model " << k << " (" << describeCase(c) << "): oracle " << name(truth)
                                    << ", verdict " << describe(v.verdict);
    EXPECT_EQ(v.links_verdict.kind, want_links)
        << "model " << k << " (" << describeCase(c) << "): oracle " << name(links_truth) << ", links' verdict "
        << describe(v.links_verdict);
    // Each sensor's needed rate, the others fixed.
    for (std::size_t s = 0; s < c.f.size(); ++s)
    {
      if (!c.links[s])
        continue;  // a lossless sensor has no rate of its own
      const SensorMargin& m = v.links[s].margin;
      const bool dead_model = !v.dead_states.empty();
      const double need = neededRate(c, static_cast<int>(s), false);
      const double need_links = neededRate(c, static_cast<int>(s), true);
      const double got = m.band.converges_at;
      const double got_observed = dead_model ? m.converges_at_observed : got;
      ++margins;
      const bool ok = (std::isnan(need) ? std::isnan(got) : std::abs(got - need) < 1e-5) &&
                      (std::isnan(need_links) ? std::isnan(got_observed) : std::abs(got_observed - need_links) < 1e-5);
      disagreements += ok ? 0 : 1;
      EXPECT_TRUE(ok) << "model " << k << " sensor " << s + 1 << " (" << describeCase(c) << "): needs " << need
                      << " (observed modes " << need_links << "), got " << got << " (observed " << got_observed
                      << "): " << m.note;
    }
    // The full report says the same.
    if (k % 8 == 0)
    {
      const StabilityReport rep = analyzeStability(c.model, c.links);
      EXPECT_EQ(rep.model.verdict.kind, v.verdict.kind) << describe(rep.model.verdict);
      EXPECT_EQ(rep.model.links_verdict.kind, v.links_verdict.kind) << describe(rep.model.links_verdict);
      ASSERT_EQ(rep.links.size(), v.links.size());
      for (std::size_t s = 0; s < v.links.size(); ++s)
      {
        const double a = rep.links[s].margin.band.converges_at, b = v.links[s].margin.band.converges_at;
        EXPECT_TRUE((std::isnan(a) && std::isnan(b)) || a == b) << a << " vs " << b;
      }
    }
  }
  std::printf(
      "oracle: %d models, %d verdicts and %d needed rates checked, %d within 1e-6 of the boundary "
      "skipped, %d unbounded, %d with dead-reckoned modes, %d disagreements\n",
      models, verdicts, margins, close, unstable, dead, disagreements);
  EXPECT_EQ(disagreements, 0);
  // The generator must reach both sides and the dead-reckoned case, or the test proves little.
  EXPECT_GE(models - close, 200);
  EXPECT_GE(unstable, 40);
  EXPECT_GE(verdicts / 2 - unstable, 40);
  EXPECT_GE(dead, 20);
}

// ---------------------------------------------------------------------------------------------
// Monte Carlo growth of E[P_k] of the Kalman filter with intermittent observations, by a Riccati
// recursion written here (no library estimator), on a few cases on each side of the boundary.

namespace
{

/// The sample mean of tr P_k over `runs` runs of the random Riccati recursion, k = 0..steps.
/// links[s]: {arrival probability after an arrival, arrival probability after a loss} (i.i.d.:
/// both the arrival rate; on/off Gilbert-Elliott: 1 - p and r), starting from the stationary law.
std::vector<double> meanTrace(const Model& m, const std::vector<std::pair<double, double>>& links, int runs, int steps,
                              std::uint64_t seed)
{
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = m.n();
  std::vector<double> mean(static_cast<std::size_t>(steps) + 1, 0.0);
  for (int run = 0; run < runs; ++run)
  {
    MatrixXd P = m.P0;
    std::vector<bool> arrived(links.size());
    for (std::size_t s = 0; s < links.size(); ++s)
    {
      const double stay = links[s].first, come = links[s].second;  // stationary P(arrived)
      arrived[s] = u(rng) < (stay == 1.0 ? 1.0 : come / (1.0 - stay + come));
    }
    mean[0] += P.trace();
    for (int k = 1; k <= steps; ++k)
    {
      P = m.A * P * m.A.transpose() + m.B * m.Q * m.B.transpose();
      for (std::size_t s = 0; s < links.size(); ++s)
      {
        arrived[s] = u(rng) < (arrived[s] ? links[s].first : links[s].second);
        if (!arrived[s])
          continue;
        const Sensor& sn = m.sensors[s];
        const MatrixXd C = m.C.middleRows(sn.offset, sn.size);
        const MatrixXd S = C * P * C.transpose() + m.R.block(sn.offset, sn.offset, sn.size, sn.size);
        const MatrixXd K = S.ldlt().solve(C * P).transpose();
        P = P - K * C * P;
        P = 0.5 * (P + P.transpose());
      }
      mean[static_cast<std::size_t>(k)] += P.trace();
    }
  }
  for (double& v : mean)
    v /= runs;
  return mean;
}

}  // namespace

// Each side of the boundary, g = |lambda|^2 prod f: the growth of the sample mean of tr P from step 6
// to step 12 over 20000 runs. Unstable side (g ~ 2, every sensor that sees the mode lost with
// probability >= 0.49 per step): E[tr P_k] is driven by the runs that lost that mode for their last
// m steps (probability >= 0.49^m, tr P ~ 4^m); each of the 2^12 loss patterns of 12 steps is expected
// in >= 20000 * 0.49^12 ~ 3 runs, so the sample mean follows E[tr P_k] and the ratio is near
// g^6 ~ 60. Stable side (g <= 0.64): the recursion forgets P_0 within a few steps and the ratio is
// near 1. Thresholds 4 and 2.5: the ratio's spread over 200 seeds of the scalar cases (simulated
// apart) was 7.7 to 166 on the unstable side (the widest: the Gilbert-Elliott link, whose losses
// come in runs) and 0.75 to 1.72 on the stable side, so each threshold is a factor 1.5 to 2 beyond
// the extreme of 200 draws.
TEST(StabilityOracle, MonteCarloGrowthOnEachSide)
{
  struct McCase
  {
    Model model;
    std::vector<std::optional<ChannelSettings>> links;
    std::vector<std::pair<double, double>> chain;
    bool bounded;
  };
  const MatrixXd A1 = mat(1, 1, {2.0});
  const MatrixXd C1 = mat(1, 1, {1.0});
  // two real modes: 1.2 (eigenvector [3.2, 1], seen by both sensors) and -2 (eigenvector [0, 1],
  // seen by s2 only)
  const MatrixXd A2 = mat(2, 2, {1.2, 0.0, 1.0, -2.0});
  const std::vector<MatrixXd> C2 = {mat(1, 2, {1, 0}), mat(1, 2, {0, 1})};
  std::vector<McCase> cases = {
      // scalar, 4 (1 - lambda): lambda 0.5 -> 2 (unbounded), 0.85 -> 0.6 (bounded)
      {simpleModel(A1, C1), iidLinks({0.5}), {{0.5, 0.5}}, false},
      {simpleModel(A1, C1), iidLinks({0.85}), {{0.85, 0.85}}, true},
      // two sensors on the same mode: 4 (1 - l)^2: 0.3 each -> 1.96, 0.6 each -> 0.64
      {multiModel(A1, {C1, C1}), iidLinks({0.3, 0.3}), {{0.3, 0.3}, {0.3, 0.3}}, false},
      {multiModel(A1, {C1, C1}), iidLinks({0.6, 0.6}), {{0.6, 0.6}, {0.6, 0.6}}, true},
      // on/off Gilbert-Elliott, p = 0.2: 4 (1 - r): r = 0.5 -> 2, r = 0.85 -> 0.6
      {simpleModel(A1, C1), {gilbert(0.2, 0.5)}, {{0.8, 0.5}}, false},
      {simpleModel(A1, C1), {gilbert(0.2, 0.85)}, {{0.8, 0.85}}, true},
      // the mode -2 (s2 only): 4 (1 - l2): l2 = 0.5 -> 2; l2 = 0.9 -> 0.4 (and 1.44 (1 - l1)(1 - l2) < 1)
      {multiModel(A2, C2), iidLinks({0.9, 0.5}), {{0.9, 0.9}, {0.5, 0.5}}, false},
      {multiModel(A2, C2), iidLinks({0.5, 0.9}), {{0.5, 0.5}, {0.9, 0.9}}, true},
  };
  std::uint64_t seed = 7;
  for (const McCase& c : cases)
  {
    const std::vector<double> mean = meanTrace(c.model, c.chain, 20000, 12, seed++);
    const double ratio = mean[12] / mean[6];
    const Verdict v = verdictOnly(c.model, c.links).verdict;
    std::printf("Monte Carlo: %s, E[tr P_12] / E[tr P_6] = %.3g\n", c.bounded ? "bounded" : "unbounded", ratio);
    EXPECT_EQ(v.kind, c.bounded ? Verdict::Kind::STABLE : Verdict::Kind::UNSTABLE) << describe(v);
    if (c.bounded)
      EXPECT_LT(ratio, 2.5) << "E[tr P] 12/6 = " << ratio << "; " << describe(v);
    else
      EXPECT_GT(ratio, 4.0) << "E[tr P] 12/6 = " << ratio << "; " << describe(v);
  }
}
