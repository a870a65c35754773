// Monte Carlo engine and experiments (montecarlo.hpp): determinism across thread counts, the
// qualitative claims of Zhou's Fig. 1, the bounds (28) of Lin et al.'s Theorem 3, Yang et al.'s Example 1;
// sharding (montecarlo_shards.hpp): shards merged equal the unsharded run bit for bit.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string>

#include "experiments/paper_models.hpp"  // private header (src/core)
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/experiments/montecarlo_shards.hpp"

using namespace networked_estimation;

namespace
{

ExperimentResult run(const std::string& name, long runs, long steps, int threads, std::uint64_t seed = 1)
{
  MonteCarloConfig cfg;
  cfg.experiment = name;
  cfg.runs = runs;
  cfg.steps = steps;
  cfg.threads = threads;
  cfg.seed = seed;
  return runExperiment(cfg);
}

const CaseResult& findCase(const ExperimentResult& r, const std::string& name)
{
  for (const CaseResult& c : r.cases)
    if (c.name == name)
      return c;
  throw std::runtime_error("no case " + name);
}

const SeriesResult& findSeries(const CaseResult& c, const std::string& name)
{
  for (const SeriesResult& s : c.series)
    if (s.name == name)
      return s;
  throw std::runtime_error("no series " + name + " in case " + c.name);
}

}  // namespace

TEST(MonteCarloEngine, MomentsMatchDirectComputation)
{
  // values of run r: r and r^2 (deterministic), 130 runs span three blocks
  const long runs = 130;
  WorkerFactory f = []() -> RunFunction
  {
    return [](long r, double* out)
    {
      out[0] = static_cast<double>(r);
      out[1] = 5.0;
    };
  };
  std::vector<double> raw;
  const Moments m = runMonteCarlo(runs, 2, 3, f, nullptr, &raw);
  EXPECT_EQ(m.n, runs);
  EXPECT_NEAR(m.mean[0], (runs - 1) / 2.0, 1e-12);
  // sample sd of 0..n-1 = sqrt(n (n + 1) / 12)
  EXPECT_NEAR(m.sd[0], std::sqrt(runs * (runs + 1) / 12.0), 1e-10);
  EXPECT_EQ(m.mean[1], 5.0);
  EXPECT_EQ(m.sd[1], 0.0);
  ASSERT_EQ(raw.size(), 2u * runs);
  EXPECT_EQ(raw[2 * 77], 77.0);
}

TEST(MonteCarloEngine, RethrowsErrorOfRun)
{
  WorkerFactory f = []() -> RunFunction
  {
    return [](long r, double* out)
    {
      if (r == 70)
        throw DivergenceError("boom");
      out[0] = 1.0;
    };
  };
  EXPECT_THROW(runMonteCarlo(200, 1, 2, f), DivergenceError);
}

TEST(MonteCarlo, ThreadCountDoesNotChangeResults)
{
  const ExperimentResult a = run("zhou_fig1", 200, 100, 1);
  const ExperimentResult b = run("zhou_fig1", 200, 100, 2);
  ASSERT_EQ(a.cases.size(), 3u);
  ASSERT_EQ(a.cases.size(), b.cases.size());
  for (std::size_t c = 0; c < a.cases.size(); ++c)
  {
    ASSERT_EQ(a.cases[c].series.size(), 4u);
    for (std::size_t s = 0; s < a.cases[c].series.size(); ++s)
    {
      EXPECT_EQ(a.cases[c].series[s].mean, b.cases[c].series[s].mean);
      EXPECT_EQ(a.cases[c].series[s].sd, b.cases[c].series[s].sd);
    }
  }
  EXPECT_EQ(experimentCsv(a), experimentCsv(b));
  // a different seed gives different data
  EXPECT_NE(experimentCsv(run("zhou_fig1", 64, 20, 2, 1)), experimentCsv(run("zhou_fig1", 64, 20, 2, 2)));
}

TEST(MonteCarlo, ZhouFig1QualitativeClaims)
{
  // Zhou's claims about his Fig. 1, at 2000 runs over the paper's horizon; time averages over k = 80..500.
  const ExperimentResult r = run("zhou_fig1", 2000, 500, 0);
  for (const CaseResult& c : r.cases)
  {
    const double kf = findSeries(c, "KF").time_average, kfio = findSeries(c, "KFIO").time_average;
    const double rse = findSeries(c, "RSE").time_average, rseio = findSeries(c, "RSEIO").time_average;
    EXPECT_EQ(findSeries(c, "RSEIO").window0, 80.0);
    EXPECT_LT(rseio, rse) << c.name;
    EXPECT_LT(kfio, kf) << c.name;
  }
  const CaseResult& d10 = findCase(r, "delta10_mu0.8");
  EXPECT_LT(findSeries(d10, "RSEIO").time_average, 0.9 * findSeries(d10, "KFIO").time_average);
  const CaseResult& d1 = findCase(r, "delta1_mu0.95");
  const double a = findSeries(d1, "RSEIO").time_average, b = findSeries(d1, "KFIO").time_average;
  EXPECT_LT(std::abs(a - b) / b, 0.02) << "RSEIO " << a << " KFIO " << b;
}

TEST(MonteCarlo, ZhouFig2SamplesAndSymmetry)
{
  const ExperimentResult r = run("zhou_fig2", 100, 50, 2);
  ASSERT_EQ(r.cases.size(), 4u);
  ASSERT_EQ(r.samples.size(), 4u);
  ASSERT_EQ(r.sample_columns.size(), 4u);
  for (std::size_t c = 0; c < 4; ++c)
  {
    ASSERT_EQ(r.samples[c].values.size(), 400u);
    EXPECT_EQ(r.cases[c].x, std::vector<double>{50.0});
    for (std::size_t i = 0; i < 100; ++i)
      EXPECT_EQ(r.samples[c].values[4 * i + 1], r.samples[c].values[4 * i + 2]);
  }
  const std::string csv = samplesCsv(r);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "case,run,P11,P12,P21,P22");
}

TEST(MonteCarlo, LinFig4Bounds)
{
  const ExperimentResult r = run("lin_fig4", 150, 30, 0);
  ASSERT_EQ(r.cases.size(), 1u);
  const CaseResult& c = r.cases[0];
  const SeriesResult& ack = findSeries(c, "tr P_ACK");
  const SeriesResult& oe = findSeries(c, "tr E[P] (OE)");
  const SeriesResult& aoe = findSeries(c, "tr E[P^e] (AOE)");
  const SeriesResult& s = findSeries(c, "tr S_k");
  for (std::size_t k = 0; k < c.x.size(); ++k)
  {
    EXPECT_EQ(ack.sd[k], 0.0);  // deterministic given Gamma
    EXPECT_EQ(s.sd[k], 0.0);
    EXPECT_LE(ack.mean[k], oe.mean[k]) << "k = " << k + 1;
    EXPECT_LE(ack.mean[k], aoe.mean[k]) << "k = " << k + 1;
    const double se_oe = oe.sd[k] / std::sqrt(static_cast<double>(oe.n));
    const double se_aoe = aoe.sd[k] / std::sqrt(static_cast<double>(aoe.n));
    EXPECT_LE(oe.mean[k], s.mean[k] + 4.0 * se_oe) << "k = " << k + 1;
    EXPECT_LE(aoe.mean[k], s.mean[k] + 4.0 * se_aoe) << "k = " << k + 1;
  }
}

TEST(MonteCarlo, YangFig2References)
{
  const ExperimentResult r = run("yang_fig2", 4000, 40, 0);
  const CaseResult& c = r.cases[0];
  const SeriesResult& g = findSeries(c, "lower bound G_k");
  const SeriesResult& m = findSeries(c, "Monte Carlo tr E[P-_k]");
  const SeriesResult& v = findSeries(c, "MARE upper bound V_k");
  EXPECT_NEAR(g.final_value, 1.031306, 1e-5);
  EXPECT_NEAR(v.final_value, 1.298036, 1e-5);
  const double se = m.sd.back() / std::sqrt(static_cast<double>(m.n));
  EXPECT_NEAR(m.final_value, 1.2205, 5.0 * std::hypot(se, 0.0003));
  for (std::size_t k = 0; k < c.x.size(); ++k)
  {
    EXPECT_LE(g.mean[k], m.mean[k] + 1e-12);
    EXPECT_LE(m.mean[k], v.mean[k] + 4.0 * m.sd[k] / std::sqrt(static_cast<double>(m.n)) + 1e-12);
  }
}

// Sinopoli et al.'s transition: for the scalar plant a = -1.25 the lower bound S and the MARE bound V
// are finite exactly above lambda_c = 1 - 1/a^2 = 0.36, the MARE's critical rate equals it (the
// scalar MARE threshold is 1 - 1/a^2), and above lambda_max the Monte Carlo E[P-_T] lies between the
// bounds: within 4 standard errors of the lower (the horizon's E[P-_T] has converged to 1e-6 of its limit
// at these rates) and below the upper (V_k bounds E[P-_k] at every k from X_0 = 0).
TEST(MonteCarlo, SinopoliFig2BoundsAndCriticalRates)
{
  const ExperimentResult r = run("sinopoli_fig2", 600, 100, 0);
  ASSERT_EQ(r.cases.size(), 2u);
  for (const CaseResult& c : r.cases)
  {
    const SeriesResult& lo = findSeries(c, "lower bound tr S (lambda)");
    const SeriesResult& mc = findSeries(c, "Monte Carlo tr E[P-_T]");
    const SeriesResult& up = findSeries(c, "upper bound tr V (lambda), MARE");
    ASSERT_EQ(c.x.size(), 50u);
    for (std::size_t i = 0; i < c.x.size(); ++i)
    {
      const double l = c.x[i];
      // rho(A) = 1.25 in both plants: S is finite iff (1 - lambda) 1.5625 < 1
      EXPECT_EQ(std::isfinite(lo.mean[i]), l > 0.36 + 1e-12) << c.name << " lambda " << l;
      if (c.name == "scalar")
        EXPECT_EQ(std::isfinite(up.mean[i]), l > 0.36 + 1e-12) << "lambda " << l;
      if (std::isfinite(up.mean[i]))
      {
        EXPECT_LE(lo.mean[i], up.mean[i] * (1 + 1e-9)) << c.name << " lambda " << l;
        const double se = mc.sd[i] / std::sqrt(static_cast<double>(mc.n));
        if (l >= 0.6)
        {
          EXPECT_GE(mc.mean[i], lo.mean[i] * (1 - 1e-6) - 4 * se) << c.name << " lambda " << l;
          EXPECT_LE(mc.mean[i], up.mean[i] * (1 + 1e-9) + 4 * se) << c.name << " lambda " << l;
        }
      }
    }
  }
  ASSERT_EQ(r.notes.size(), 2u);
  EXPECT_NE(r.notes[0].find("scalar: lambda_min = 1 - 1/rho(A)^2 = 0.36 "), std::string::npos) << r.notes[0];
  // the scalar lambda_max (the MARE's certified rate) is lambda_c within the bisection's 1e-4
  const std::string::size_type at = r.notes[0].find("lambda_max (MARE, certified) = ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_NEAR(std::stod(r.notes[0].substr(at + 31)), 0.36, 1.5e-4) << r.notes[0];
  EXPECT_NE(r.notes[1].find("three_states: lambda_min = 1 - 1/rho(A)^2 = 0.36 "), std::string::npos) << r.notes[1];
}

// Mo and Sinopoli's tail: the Monte Carlo fraction of runs with P-_T > M lies inside the exact
// bracket (1 - lambda)^j1 .. (1 - lambda)^j2 at every M (binomial standard error sqrt(p (1 - p) / n)
// of the nearer bound, 4 of them), and the bracket decays as M^-phi with phi = ln(1 - lambda) /
// ln(1/a^2): its log-log slope between M = 10^2 and 10^8 is -phi within the bracket's step (one
// loss more or less at each end over 6 decades: 2 ln(1 - lambda) / ln(10^6) in the slope).
TEST(MonteCarlo, MoSinopoliTailInsideTheExactBracket)
{
  const ExperimentResult r = run("mo_sinopoli_tail", 10000, 200, 0);
  const CaseResult& c = r.cases.at(0);
  ASSERT_EQ(c.series.size(), 9u);
  const double lambdas[] = {0.2, 0.36, 0.6};
  for (std::size_t i = 0; i < 3; ++i)
  {
    const SeriesResult& mc = c.series[3 * i];
    const SeriesResult& lo = c.series[3 * i + 1];
    const SeriesResult& hi = c.series[3 * i + 2];
    ASSERT_NE(mc.name.find("Monte Carlo"), std::string::npos);
    ASSERT_NE(lo.name.find("lower bound"), std::string::npos);
    for (std::size_t j = 0; j < c.x.size(); ++j)
    {
      EXPECT_LE(lo.mean[j], hi.mean[j]);
      const double n = static_cast<double>(mc.n);
      EXPECT_GE(mc.mean[j], lo.mean[j] - 4 * std::sqrt(lo.mean[j] * (1 - lo.mean[j]) / n) - 1e-12)
          << mc.name << " M " << c.x[j];
      EXPECT_LE(mc.mean[j], hi.mean[j] + 4 * std::sqrt(hi.mean[j] * (1 - hi.mean[j]) / n) + 1e-12)
          << mc.name << " M " << c.x[j];
    }
    const double phi = std::log(1 - lambdas[i]) / std::log(1 / 1.5625);
    const std::size_t j2 = 8, j10 = 32;  // M = 10^2, 10^8
    ASSERT_NEAR(c.x[j2], 1e2, 1e-9);
    ASSERT_NEAR(c.x[j10], 1e8, 1e-5);
    for (const SeriesResult* b : {&lo, &hi})
    {
      const double slope = (std::log(b->mean[j10]) - std::log(b->mean[j2])) / std::log(1e6);
      EXPECT_NEAR(slope, -phi, -2 * std::log(1 - lambdas[i]) / std::log(1e6)) << b->name;
    }
  }
  // at lambda_c = 0.36 the exponent is 1: the mean is at the edge of finite
  EXPECT_NE(c.series[3].name.find("(phi = 1)"), std::string::npos) << c.series[3].name;
}

TEST(MonteCarlo, UnknownExperimentNamesTheValidOnes)
{
  try
  {
    checkExperimentName("zhou_fig9");
    FAIL() << "no error";
  }
  catch (const ConfigError& e)
  {
    const std::string what = e.what();
    EXPECT_NE(what.find("zhou_fig9"), std::string::npos);
    for (const std::string& n : experimentNames())
      EXPECT_NE(what.find(n), std::string::npos) << n;
  }
  EXPECT_THROW(run("nope", 1, 1, 1), ConfigError);
  MonteCarloConfig cfg;
  cfg.experiment = "custom";  // without files
  EXPECT_THROW(runExperiment(cfg), ConfigError);
  EXPECT_NO_THROW(checkExperimentName("lin_fig5"));
}

TEST(MonteCarlo, OutputFormats)
{
  ExperimentResult r;
  r.experiment = "t";
  r.runs = 3;
  r.steps = 2;
  r.x_label = "k";
  r.y_label = "a \"quoted\" \\ label";
  r.assumptions = {"line\nbreak"};
  CaseResult c;
  c.name = "c";
  c.title = "T";
  c.x = {1, 2};
  SeriesResult s;
  s.name = "S";
  s.mean = {1.0, 3.0};
  s.sd = {0.5, 0.0};
  s.n = 3;
  s.window0 = 1;
  s.window1 = 2;
  c.series.push_back(s);
  r.cases.push_back(c);
  summarise(r);
  EXPECT_EQ(r.cases[0].series[0].time_average, 2.0);
  EXPECT_EQ(r.cases[0].series[0].final_value, 3.0);
  // se = sd / sqrt(n); no quantiles computed: empty cells
  EXPECT_EQ(experimentCsv(r),
            "case,series,x,mean,sd,n,se,p5,p25,median,p75,p95\nc,S,1,1,0.5,3,0.2886751346,,,,,\n"
            "c,S,2,3,0,3,0,,,,,\n");
  const std::string json = experimentJson(r);
  EXPECT_NE(json.find("\"y_label\": \"a \\\"quoted\\\" \\\\ label\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"line\\nbreak\""), std::string::npos);
  EXPECT_NE(json.find("\"time_average\": 2, \"final\": 3, \"window\": [1, 2]"), std::string::npos) << json;
  // the standard error at x = 1 is 29 % of the mean: not estimable, the plots take the median
  EXPECT_FALSE(r.cases[0].series[0].mean_estimable);
  EXPECT_NE(json.find("\"final_se\": 0, \"growth\": null, \"statistic\": \"median\", \"mean_note\": \"mean not "
                      "estimable: its standard error is 29 % of it at x = 1\""),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"thresholds\": [],"), std::string::npos) << json;
}

// ---------------------------------------------------------------------------------------------
// Shards

namespace
{

/// Equal bit for bit (NaN payloads and the sign of zero included).
bool sameBits(const std::vector<double>& a, const std::vector<double>& b)
{
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

::testing::AssertionResult sameMoments(const Moments& a, const Moments& b)
{
  if (a.n != b.n)
    return ::testing::AssertionFailure() << "n " << a.n << " vs " << b.n;
  if (!sameBits(a.mean, b.mean))
    return ::testing::AssertionFailure() << "means differ";
  if (!sameBits(a.sd, b.sd))
    return ::testing::AssertionFailure() << "sds differ";
  return ::testing::AssertionSuccess();
}

/// Run values that exercise the round trip: non-terminating fractions, large and subnormal
/// magnitudes, negative zero, and (with `nonfinite`) an infinity in run 77 (its mean becomes
/// infinite, its M2 NaN).
WorkerFactory awkwardValues(bool nonfinite)
{
  return [nonfinite]() -> RunFunction
  {
    return [nonfinite](long r, double* out)
    {
      const double x = static_cast<double>(r);
      out[0] = std::sin(x) / 3.0;
      out[1] = 1e300 * std::cos(0.7 * x);
      out[2] = 4.9406564584124654e-324 * static_cast<double>(r % 5);
      out[3] = -0.0;
      out[4] = nonfinite && r == 77 ? std::numeric_limits<double>::infinity() : std::exp(0.01 * x) - 1.0;
    };
  };
}

/// A shard file around the blocks of one engine call (the experiment name only has to be valid).
ShardFile engineShard(std::vector<CallBlocks> calls, long runs, int k, int n)
{
  ShardFile sf;
  sf.config.experiment = "zhou_fig1";
  sf.config.runs = runs;
  sf.config.steps = 1;
  sf.shard = k;
  sf.shards = n;
  sf.fingerprint = inputsFingerprint(sf.inputs);
  sf.calls = std::move(calls);
  return sf;
}

MonteCarloConfig smallConfig(const std::string& name, long runs, long steps)
{
  MonteCarloConfig cfg;
  cfg.experiment = name;
  cfg.runs = runs;
  cfg.steps = steps;
  cfg.threads = 2;
  return cfg;
}

/// The JSON with the timing fields (threads, wall_seconds) removed.
std::string withoutTiming(const std::string& json)
{
  std::string out, line;
  std::istringstream in(json);
  while (std::getline(in, line))
    if (line.find("\"threads\":") == std::string::npos && line.find("\"wall_seconds\":") == std::string::npos)
      out += line + "\n";
  return out;
}

}  // namespace

TEST(MonteCarloShards, ShardSpecSyntax)
{
  int k = 0, n = 0;
  EXPECT_TRUE(parseShardSpec("1/1", k, n));
  EXPECT_EQ(k, 1);
  EXPECT_EQ(n, 1);
  EXPECT_TRUE(parseShardSpec("3/7", k, n));
  EXPECT_EQ(k, 3);
  EXPECT_EQ(n, 7);
  for (const char* bad :
       {"0/3", "4/3", "x", "1/0", "", "1/", "/3", "1/3/4", "-1/3", "+1/3", " 1/3", "1/3 ", "1.0/3", "1/99999999"})
    EXPECT_FALSE(parseShardSpec(bad, k, n)) << "'" << bad << "'";
}

TEST(MonteCarloShards, MergedBlocksEqualUnshardedBitForBit)
{
  const std::size_t values = 5;
  // 1 run, exactly one block, runs not a multiple of 64, and (with 7 shards) more shards than blocks
  for (const long runs : {1L, 64L, 130L, 449L})
    for (const bool nonfinite : {false, true})
    {
      if (nonfinite && runs < 78)
        continue;
      std::vector<double> plain_raw;
      const Moments plain = runMonteCarlo(runs, values, 2, awkwardValues(nonfinite), nullptr, &plain_raw);
      ASSERT_EQ(plain.n, runs);
      ASSERT_EQ(std::isfinite(plain.mean[4]), !nonfinite);  // inf - inf: NaN from run 78 on
      for (const int n : {1, 3, 7})
        for (const bool raw : {false, true})
        {
          SCOPED_TRACE("runs " + std::to_string(runs) + ", N " + std::to_string(n) + (raw ? ", raw" : "") +
                       (nonfinite ? ", inf" : ""));
          CallBlocks merged;
          merged.runs = runs;
          merged.values = values;
          merged.raw = raw;
          long covered = 0;
          for (int k = 1; k <= n; ++k)
          {
            BlockSession session = BlockSession::shard(k, n);
            std::vector<double> shard_raw;
            runMonteCarlo(runs, values, 3, awkwardValues(nonfinite), nullptr, raw ? &shard_raw : nullptr, nullptr,
                          &session);
            std::vector<CallBlocks> calls = session.takeCalls();
            ASSERT_EQ(calls.size(), 1u);
            long expected_blocks = 0;
            for (long b = k - 1; b < blockCount(runs); b += n)
              ++expected_blocks;
            ASSERT_EQ(static_cast<long>(calls[0].blocks.size()), expected_blocks);  // 0 for some with N = 7
            // through the file format and back: every double exactly
            const ShardFile written = engineShard(calls, runs, k, n);
            const ShardFile read = parseShard(
                shardJson(written), "mem/zhou_fig1.shard-" + std::to_string(k) + "-of-" + std::to_string(n) + ".json");
            ASSERT_EQ(read.calls.size(), 1u);
            ASSERT_EQ(read.calls[0].blocks.size(), calls[0].blocks.size());
            for (std::size_t j = 0; j < calls[0].blocks.size(); ++j)
            {
              const BlockMoments& a = calls[0].blocks[j];
              const BlockMoments& b = read.calls[0].blocks[j];
              EXPECT_EQ(a.index, b.index);
              EXPECT_EQ(a.count, b.count);
              EXPECT_TRUE(sameBits(a.mean, b.mean)) << "block " << a.index;
              EXPECT_TRUE(sameBits(a.m2, b.m2)) << "block " << a.index;
              EXPECT_TRUE(sameBits(a.raw, b.raw)) << "block " << a.index;
              covered += b.count;
              merged.blocks.push_back(b);
            }
          }
          EXPECT_EQ(covered, runs);
          std::sort(merged.blocks.begin(), merged.blocks.end(),
                    [](const BlockMoments& a, const BlockMoments& b) { return a.index < b.index; });
          std::vector<double> merged_raw;
          EXPECT_TRUE(sameMoments(combineBlocks(merged, raw ? &merged_raw : nullptr), plain));
          EXPECT_TRUE(!raw || sameBits(merged_raw, plain_raw));
          // a replay returns the merged moments without running anything
          BlockSession replay = BlockSession::replay({merged});
          WorkerFactory never = []() -> RunFunction
          {
            ADD_FAILURE() << "a replay ran a worker";
            return [](long, double*) {};
          };
          std::vector<double> replay_raw;
          EXPECT_TRUE(sameMoments(
              runMonteCarlo(runs, values, 2, never, nullptr, raw ? &replay_raw : nullptr, nullptr, &replay), plain));
          EXPECT_TRUE(!raw || sameBits(replay_raw, plain_raw));
          EXPECT_EQ(replay.replayed(), 1u);
        }
    }
}

TEST(MonteCarloShards, ReplayAndCombineRefuseWrongBlocks)
{
  BlockSession session = BlockSession::shard(1, 1);
  runMonteCarlo(200, 5, 1, awkwardValues(false), nullptr, nullptr, nullptr, &session);
  const CallBlocks all = session.takeCalls().at(0);
  ASSERT_EQ(all.blocks.size(), 4u);
  CallBlocks gap = all;
  gap.blocks.erase(gap.blocks.begin() + 2);
  EXPECT_THROW(combineBlocks(gap), InputError);
  CallBlocks swapped = all;
  std::swap(swapped.blocks[1], swapped.blocks[2]);
  EXPECT_THROW(combineBlocks(swapped), InputError);
  CallBlocks short_block = all;
  short_block.blocks[3].count = 64;  // the last block of 200 runs has 8
  EXPECT_THROW(combineBlocks(short_block), InputError);
  EXPECT_EQ(combineBlocks(all).n, 200);
  std::vector<double> raw;
  EXPECT_THROW(combineBlocks(all, &raw), InputError);  // recorded without per-run values

  // a replay asked for another call size, or for more calls than recorded
  BlockSession replay = BlockSession::replay({all});
  EXPECT_THROW(runMonteCarlo(199, 5, 1, awkwardValues(false), nullptr, nullptr, nullptr, &replay), InputError);
  BlockSession replay2 = BlockSession::replay({all});
  EXPECT_EQ(runMonteCarlo(200, 5, 1, awkwardValues(false), nullptr, nullptr, nullptr, &replay2).n, 200);
  EXPECT_THROW(runMonteCarlo(200, 5, 1, awkwardValues(false), nullptr, nullptr, nullptr, &replay2), InputError);
}

TEST(MonteCarloShards, ExperimentMergeEqualsUnsharded)
{
  // zhou_fig2: four calls with per-run samples; zhou_fig1: two calls over one data set
  for (const std::string name : {"zhou_fig2", "zhou_fig1"})
  {
    const MonteCarloConfig cfg = smallConfig(name, 150, 20);
    const ExperimentResult plain = runExperiment(cfg);
    for (const int n : {1, 3, 7})
    {
      SCOPED_TRACE(name + ", N " + std::to_string(n));
      std::vector<ShardFile> shards;
      for (int k = n; k >= 1; --k)  // any order
      {
        const ShardFile sf = runShard(cfg, k, n);
        shards.push_back(parseShard(shardJson(sf), "mem/" + shardFileName(name, k, n)));
      }
      const ExperimentResult merged = mergeShards(shards);
      EXPECT_EQ(experimentCsv(merged), experimentCsv(plain));
      EXPECT_EQ(samplesCsv(merged), samplesCsv(plain));
      EXPECT_EQ(withoutTiming(experimentJson(merged)), withoutTiming(experimentJson(plain)));
      ASSERT_EQ(merged.cases.size(), plain.cases.size());
      for (std::size_t c = 0; c < plain.cases.size(); ++c)
        for (std::size_t s = 0; s < plain.cases[c].series.size(); ++s)
        {
          EXPECT_TRUE(sameBits(merged.cases[c].series[s].mean, plain.cases[c].series[s].mean));
          EXPECT_TRUE(sameBits(merged.cases[c].series[s].sd, plain.cases[c].series[s].sd));
        }
    }
  }
  if (::testing::Test::HasFailure())
    return;
  // the samples are really there: shard 2 of 3 holds runs 64..127 of every case
  const ShardFile sf = runShard(smallConfig("zhou_fig2", 150, 20), 2, 3);
  ASSERT_EQ(sf.calls.size(), 4u);
  ASSERT_EQ(sf.calls[0].blocks.size(), 1u);
  EXPECT_EQ(sf.calls[0].blocks[0].index, 1);
  EXPECT_EQ(sf.calls[0].blocks[0].raw.size(), 64u * 4u);
}

TEST(MonteCarloShards, MergeRefusesShardsThatDoNotBelongTogether)
{
  const MonteCarloConfig cfg = smallConfig("zhou_fig2", 150, 10);
  std::vector<ShardFile> three;
  for (int k = 1; k <= 3; ++k)
  {
    three.push_back(runShard(cfg, k, 3));
    three.back().path = "d/" + shardFileName("zhou_fig2", k, 3);
  }
  auto refused = [](std::vector<ShardFile> shards, const std::vector<std::string>& words)
  {
    try
    {
      mergeShards(std::move(shards));
      ADD_FAILURE() << "no error";
    }
    catch (const InputError& e)
    {
      for (const std::string& w : words)
        EXPECT_NE(std::string(e.what()).find(w), std::string::npos) << "'" << w << "' not in: " << e.what();
    }
  };
  refused({three[0], three[2]}, {"missing shard 2 of 3"});
  std::vector<ShardFile> dup = three;
  dup.push_back(three[1]);
  dup.back().path = "e/" + shardFileName("zhou_fig2", 2, 3);
  refused(dup, {"duplicate shard 2 of 3", "d/zhou_fig2.shard-2-of-3.json", "e/zhou_fig2.shard-2-of-3.json"});
  MonteCarloConfig other = cfg;
  other.seed = 2;
  std::vector<ShardFile> foreign = three;
  foreign[1] = runShard(other, 2, 3);
  foreign[1].path = "f/" + shardFileName("zhou_fig2", 2, 3);
  refused(foreign, {"f/zhou_fig2.shard-2-of-3.json", "foreign shard", "seed is 2", "but 1"});
  other = cfg;
  other.runs = 149;
  foreign[1] = runShard(other, 2, 3);
  foreign[1].path = "f/x.json";
  refused(foreign, {"f/x.json", "runs is 149"});
  refused({}, {"no shard files"});

  // malformed files name the file, the line and the problem
  const std::string text = shardJson(three[0]);
  auto malformed = [](const std::string& t, const std::string& word)
  {
    try
    {
      parseShard(t, "bad.json");
      ADD_FAILURE() << "no error for " << word;
    }
    catch (const InputError& e)
    {
      EXPECT_EQ(std::string(e.what()).rfind("bad.json: ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  malformed(text.substr(0, text.size() / 2), "line ");
  malformed("not json", "line 1, column 1: expected '{'");
  std::string bad_runs = text;
  bad_runs.replace(bad_runs.find("\"runs\": 150"), 11, "\"runs\": \"x\"");
  malformed(bad_runs, "'runs': expected an integer");
  std::string lost_block = text;
  lost_block.replace(lost_block.find("\"index\": 0"), 10, "\"index\": 1");
  malformed(lost_block, "expected block 0, found block 1");
  std::string edited = text;
  edited.replace(edited.find("\"fingerprint\": \""), 16, "\"fingerprint\": \"0");
  malformed(edited, "'fingerprint'");
}

// The papers' models: Zhou's and Lin et al.'s examples are config/models' files compiled into the
// core (cmake/embedded_models.cmake) with the varied parameter applied, and equal, number for
// number, the models the experiments ran when they were written in C++ (the references below).

namespace
{

bool sameModel(const Model& a, const Model& b, std::string& why)
{
  auto mat = [&](const char* name, const Eigen::MatrixXd& x, const Eigen::MatrixXd& y)
  {
    if (x.rows() == y.rows() && x.cols() == y.cols() && x == y)
      return true;
    std::ostringstream os;
    os << name << ": " << x.rows() << "x" << x.cols() << " [" << x << "] vs " << y.rows() << "x" << y.cols() << " ["
       << y << "]";
    why = os.str();
    return false;
  };
  if (a.name != b.name || a.period != b.period)
  {
    why =
        "name or period: " + a.name + " " + std::to_string(a.period) + " vs " + b.name + " " + std::to_string(b.period);
    return false;
  }
  if (!mat("A", a.A, b.A) || !mat("B", a.B, b.B) || !mat("Q", a.Q, b.Q) || !mat("C", a.C, b.C) || !mat("R", a.R, b.R) ||
      !mat("x0", a.x0, b.x0) || !mat("P0", a.P0, b.P0) || !mat("Bu", a.Bu, b.Bu))
    return false;
  if (a.sensors.size() != b.sensors.size() || a.uncertainty.size() != b.uncertainty.size())
  {
    why = "sensor or uncertainty count";
    return false;
  }
  for (std::size_t i = 0; i < a.sensors.size(); ++i)
    if (a.sensors[i].name != b.sensors[i].name || a.sensors[i].offset != b.sensors[i].offset ||
        a.sensors[i].size != b.sensors[i].size)
    {
      why = "sensor " + std::to_string(i);
      return false;
    }
  for (std::size_t i = 0; i < a.uncertainty.size(); ++i)
  {
    if (!mat("dA", a.uncertainty[i].dA, b.uncertainty[i].dA) || !mat("dB", a.uncertainty[i].dB, b.uncertainty[i].dB) ||
        !mat("dC", a.uncertainty[i].dC, b.uncertainty[i].dC))
      return false;
    if (a.uncertainty[i].range != b.uncertainty[i].range)
    {
      why = "range";
      return false;
    }
  }
  if (a.schedule.active() || b.schedule.active() || a.states != b.states || a.angles != b.angles ||
      a.motion != b.motion || a.two_d_mode != b.two_d_mode)
  {
    why = "schedule, states, angles or motion";
    return false;
  }
  return true;
}

/// Zhou's example as montecarlo.cpp wrote it before the models were read from config/models.
Model zhouReference(double delta)
{
  Model m;
  m.name = "zhou_example";
  m.period = 0.01;
  m.A.resize(2, 2);
  m.A << 0.9802, 0.0196, 0.0, 0.9802;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q.resize(2, 2);
  m.Q << 1.9608, 0.0195, 0.0195, 1.9605;
  m.C.resize(1, 2);
  m.C << 1, -1;
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.x0 = Eigen::Vector2d(1, 0);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors.push_back({"y", 0, 1});
  Uncertainty u;
  u.dA = Eigen::MatrixXd::Zero(2, 2);
  u.dA(0, 1) = 0.099;
  u.dB = Eigen::MatrixXd::Zero(2, 2);
  u.dC = Eigen::MatrixXd::Zero(1, 2);
  u.range = delta;
  m.uncertainty.push_back(u);
  m.Bu.resize(2, 0);
  return m;
}

/// Lin et al.'s example as montecarlo.cpp wrote it before.
Model aoeReference(double rhoA)
{
  Model m;
  m.name = "aoe_example";
  m.period = 0.01;
  m.A.resize(2, 2);
  m.A << rhoA, 0, 0, 1.005;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = 20.0 * Eigen::MatrixXd::Identity(2, 2);
  m.C.resize(2, 2);
  m.C << 1, -1, 0, 1;
  m.R = 20.0 * Eigen::MatrixXd::Identity(2, 2);
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors.push_back({"y", 0, 2});
  m.Bu.resize(2, 1);
  m.Bu << -1, 1;
  return m;
}

}  // namespace

TEST(PaperModels, BuiltInFilesAreConfigModels)
{
  const std::string root = NE_SOURCE_DIR;
  for (const std::string name : {"zhou_example", "aoe_example"})
  {
    std::string why;
    EXPECT_TRUE(sameModel(mc::builtInModel(name), loadModel(root + "/config/models/" + name + ".yaml"), why))
        << name << ": " << why;
  }
  EXPECT_THROW(mc::builtInModel("no_such_model"), std::logic_error);
}

TEST(PaperModels, ExperimentsRunTheModelsOfBefore)
{
  // zhou_fig1 and zhou_fig2 use delta 1 and 10, lin_fig2..5 the rho of their cases
  for (double delta : {1.0, 10.0, 0.5})
  {
    std::string why;
    EXPECT_TRUE(sameModel(mc::zhouExampleModel(delta), zhouReference(delta), why)) << "delta " << delta << ": " << why;
  }
  for (double rho : {1.2910, 1.8257, 1.1, 0.9})
  {
    std::string why;
    EXPECT_TRUE(sameModel(mc::aoeExampleModel(rho), aoeReference(rho), why)) << "rhoA " << rho << ": " << why;
  }
}

// Plot hints: each experiment says in its JSON how it is drawn (the "plot" member), so that the
// plot script has no per-experiment code (docs/formats.md, "Plot hints").
TEST(MonteCarlo, JsonCarriesPlotHints)
{
  const nlohmann::json fig1 = nlohmann::json::parse(experimentJson(run("zhou_fig1", 64, 100, 2)));
  ASSERT_TRUE(fig1.contains("plot")) << fig1.dump();
  EXPECT_EQ(fig1["plot"]["kind"], "averaged");
  EXPECT_EQ(fig1["plot"]["tails"], true);
  EXPECT_EQ(fig1["plot"]["zoom"], nlohmann::json::parse("[80, 500]"));
  EXPECT_EQ(fig1["x_label"], "k");
  EXPECT_EQ(fig1["log_y"], true);

  const ExperimentResult r2 = run("zhou_fig2", 64, 20, 2);
  const nlohmann::json fig2 = nlohmann::json::parse(experimentJson(r2));
  const nlohmann::json& p2 = fig2["plot"];
  EXPECT_EQ(p2["kind"], "density");
  EXPECT_EQ(p2["tails"], false);
  EXPECT_EQ(p2["title"], "EPDF of the elements of $P_{20|20}$");
  ASSERT_EQ(p2["columns"].size(), 3u);
  const std::vector<std::string> ij = {"11", "12", "22"};
  for (std::size_t i = 0; i < 3; ++i)
  {
    const nlohmann::json& c = p2["columns"][i];
    EXPECT_EQ(c["column"], "P" + ij[i]);
    EXPECT_EQ(c["label"], "$[P_{20|20}]_{" + ij[i] + "}$");
    EXPECT_EQ(c["title"], "$P_{" + ij[i] + "}$");
    // every column drawn is one of the samples file's
    EXPECT_NE(std::find(r2.sample_columns.begin(), r2.sample_columns.end(), c["column"].get<std::string>()),
              r2.sample_columns.end());
  }
  ASSERT_EQ(p2["case_labels"].size(), r2.cases.size());
  EXPECT_EQ(p2["case_labels"]["P0_0.1"], "$P_{0|0} = 0.1\\,I_2$");
  EXPECT_EQ(p2["case_labels"]["P0_100"], "$P_{0|0} = 100\\,I_2$");

  const nlohmann::json lin = nlohmann::json::parse(experimentJson(run("lin_fig4", 64, 10, 2)));
  EXPECT_EQ(lin["plot"], nlohmann::json::parse(R"({"kind": "series", "tails": true})"));

  ExperimentResult sweep;
  sweep.experiment = "sweep";
  sweep.plot.kind = PlotHints::Kind::SWEEP;
  sweep.plot.tails = false;
  EXPECT_EQ(nlohmann::json::parse(experimentJson(sweep))["plot"],
            nlohmann::json::parse(R"({"kind": "sweep", "tails": false})"));
}
