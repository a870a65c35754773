// Monte Carlo engine and experiments (montecarlo.hpp): determinism across thread counts, the
// qualitative claims of Zhou's Fig. 1, the bounds (28) of Lin et al.'s Theorem 3, Yang et al.'s Example 1.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"

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
  WorkerFactory f = []() -> RunFunction {
    return [](long r, double* out) {
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
  WorkerFactory f = []() -> RunFunction {
    return [](long r, double* out) {
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
  EXPECT_EQ(experimentCsv(r), "case,series,x,mean,sd,n\nc,S,1,1,0.5,3\nc,S,2,3,0,3\n");
  const std::string json = experimentJson(r);
  EXPECT_NE(json.find("\"y_label\": \"a \\\"quoted\\\" \\\\ label\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"line\\nbreak\""), std::string::npos);
  EXPECT_NE(json.find("\"time_average\": 2, \"final\": 3, \"window\": [1, 2]"), std::string::npos) << json;
}
