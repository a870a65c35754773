// The statistics of heavy tails in the Monte Carlo outputs (montecarlo.hpp, quantile_sketch.hpp):
// the quantile sketch against exact order statistics, its merge and folding; the engine's tail
// probabilities, growth exponents and time-average errors against direct computation, sharded and
// not; and the covariance-only experiment against the closed forms of the scalar plant (Sinopoli's
// lambda_c = 1 - 1/a^2 and the Gilbert-Elliott threshold r_c = 1 - 1/a^2) through its tail
// probabilities.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/experiments/quantile_sketch.hpp"

using namespace networked_estimation;

namespace
{

/// The value of rank floor(q (n - 1)) of the sorted values (QuantileSketch's definition).
double exactQuantile(std::vector<double> v, double q)
{
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1)))];
}

/// Heavy-tailed values of both signs: Pareto magnitudes (tail index 0.7) over 12 decades, zeros and
/// infinities.
std::vector<double> awkwardSample(Rng& rng, std::size_t n)
{
  std::vector<double> v;
  for (std::size_t i = 0; i < n; ++i)
  {
    const double u = rng.uniform();
    if (u < 0.02)
      v.push_back(0.0);
    else if (u < 0.03)
      v.push_back(std::numeric_limits<double>::infinity());
    else
    {
      const double m = 1e-6 * std::pow(1.0 - rng.uniform(), -1.0 / 0.7);
      v.push_back(u < 0.3 ? -m : m);
    }
  }
  return v;
}

class Files
{
public:
  Files()
  {
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    dir_ = std::filesystem::temp_directory_path() / ("test_heavy_tails_" + std::to_string(stamp));
    std::filesystem::create_directories(dir_);
  }
  ~Files()
  {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::string write(const std::string& name, const std::string& text) const
  {
    std::ofstream out(dir_ / name);
    out << text;
    return (dir_ / name).string();
  }

private:
  std::filesystem::path dir_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// The sketch

TEST(QuantileSketch, WithinItsRelativeErrorOfTheExactQuantiles)
{
  Rng rng(3);
  const std::vector<double> v = awkwardSample(rng, 20001);
  QuantileSketch s;
  for (double x : v)
    s.add(x);
  s.add(std::nan(""));  // counted apart, not ranked
  EXPECT_EQ(s.count(), 20002u);
  EXPECT_EQ(s.nanCount(), 1u);
  for (double q : {0.0, 0.001, 0.05, 0.25, 0.3, 0.5, 0.75, 0.95, 0.969, 0.99, 1.0})
  {
    const double exact = exactQuantile(v, q), got = s.quantile(q);
    if (std::isinf(exact) || exact == 0.0)
      EXPECT_EQ(got, exact) << "q = " << q;
    else  // the bin's representative is within a of every value of the bin (1e-12: rounding of the log)
      EXPECT_LE(std::abs(got - exact), QuantileSketch::kRelativeError * (1 + 1e-12) * std::abs(exact))
          << "q = " << q << ": " << got << " vs " << exact;
  }
  EXPECT_TRUE(std::isnan(QuantileSketch().quantile(0.5)));
  EXPECT_TRUE(std::isnan(s.quantile(1.5)));
}

TEST(QuantileSketch, MergeIsExactInAnyOrderAndSurvivesEncoding)
{
  Rng rng(8);
  const std::vector<double> v = awkwardSample(rng, 3000);
  QuantileSketch whole, a, b, c;
  for (std::size_t i = 0; i < v.size(); ++i)
  {
    whole.add(v[i]);
    (i % 3 == 0 ? a : i % 3 == 1 ? b : c).add(v[i]);
  }
  QuantileSketch abc = a, cba = c;
  abc.merge(b);
  abc.merge(c);
  cba.merge(b);
  cba.merge(a);
  EXPECT_TRUE(abc == whole);
  EXPECT_TRUE(cba == whole);
  EXPECT_FALSE(a == whole);
  const QuantileSketch back = QuantileSketch::decode(whole.encode(), "test");
  EXPECT_TRUE(back == whole);
  for (double q : {0.05, 0.5, 0.95})
    EXPECT_EQ(back.quantile(q), whole.quantile(q));
  // malformed lists are refused, naming the problem
  std::vector<std::int64_t> bad = whole.encode();
  bad.pop_back();
  EXPECT_THROW(QuantileSketch::decode(bad, "test"), InputError);
  bad = whole.encode();
  bad[0] = -1;
  EXPECT_THROW(QuantileSketch::decode(bad, "test"), InputError);
  EXPECT_THROW(QuantileSketch::decode({0, 0, 0}, "test"), InputError);
}

TEST(QuantileSketch, FoldsTheSmallestMagnitudesBeyondItsBinsAndSaysSo)
{
  // 1e-30 .. 1e+30: 60 decades, about 6900 bins, more than kMaxBins (2048, about 18 decades): the
  // values below 1e30 / 10^17.8 fold into the lowest bin kept, whatever the order they come in
  std::vector<double> v;
  for (int e = -300; e <= 300; ++e)
    v.push_back(std::pow(10.0, e / 10.0));
  QuantileSketch up, down;
  for (double x : v)
    up.add(x);
  for (auto it = v.rbegin(); it != v.rend(); ++it)
    down.add(*it);
  EXPECT_TRUE(up == down);
  EXPECT_TRUE(std::isnan(up.quantile(0.05)));  // in the folded bin: not estimable
  EXPECT_TRUE(std::isnan(up.quantile(0.5)));
  const double exact = exactQuantile(v, 0.95);
  EXPECT_LE(std::abs(up.quantile(0.95) - exact), 0.0101 * exact);
  const QuantileSketch back = QuantileSketch::decode(up.encode(), "test");
  EXPECT_TRUE(back == up);
  EXPECT_TRUE(std::isnan(back.quantile(0.5)));
}

// ---------------------------------------------------------------------------------------------
// The engine

namespace
{

/// Run r: 2 series of 12 values, v_k = exp(g_r k) (1 + k/8) with g_r = 0.01 (r % 5 - 2) for the
/// first (so the per-run growth exponents are known) and Pareto-like values for the second.
WorkerFactory seriesValues()
{
  return []() -> RunFunction
  {
    return [](long r, double* out)
    {
      Rng rng(deriveSeed(5, static_cast<std::uint64_t>(r)));
      const double g = 0.01 * static_cast<double>(r % 5 - 2);
      for (int k = 1; k <= 12; ++k)
      {
        out[k - 1] = std::exp(g * k);
        out[12 + k - 1] = std::pow(1.0 - rng.uniform(), -1.0 / 1.5);
      }
    };
  };
}

}  // namespace

TEST(HeavyTailStatistics, EngineMatchesTheDirectComputation)
{
  const long runs = 300;
  std::vector<double> x(12);
  for (int k = 1; k <= 12; ++k)
    x[static_cast<std::size_t>(k - 1)] = k;
  CallStatistics st;
  st.quantiles = true;
  st.thresholds = {1.05, 2.0};
  st.spans = {{0, x, 3.0, 10.0}, {12, x, 1.0, 12.0}};
  std::vector<double> raw;
  const Moments m = runMonteCarlo(runs, 24, 3, seriesValues(), nullptr, &raw, &st);
  ASSERT_EQ(raw.size(), static_cast<std::size_t>(runs) * 24);  // the values alone, not the accumulators
  ASSERT_EQ(m.mean.size(), 24u);
  ASSERT_EQ(m.sketches.size(), 24u);
  ASSERT_EQ(m.exceed.size(), 48u);
  for (std::size_t v = 0; v < 24; ++v)
  {
    std::vector<double> col;
    for (long r = 0; r < runs; ++r)
      col.push_back(raw[static_cast<std::size_t>(r) * 24 + v]);
    for (std::size_t t = 0; t < 2; ++t)
    {
      const double above =
          static_cast<double>(std::count_if(col.begin(), col.end(), [&](double c) { return c > st.thresholds[t]; }));
      EXPECT_NEAR(m.exceed[v * 2 + t], above / runs, 1e-12) << v << " " << t;
    }
    EXPECT_LE(std::abs(m.sketches[v].quantile(0.5) - exactQuantile(col, 0.5)), 0.0101 * exactQuantile(col, 0.5));
  }
  // span 0: log v_k = g_r k, its slope over k = 7 .. 12 is g_r exactly: mean 0 over the five values of g,
  // sd that of {-2, -1, 0, 1, 2} / 100 (sample sd with 300 runs, 60 of each)
  ASSERT_EQ(m.growth_mean.size(), 2u);
  EXPECT_NEAR(m.growth_mean[0], 0.0, 1e-12);
  EXPECT_NEAR(m.growth_sd[0], 0.01 * std::sqrt(2.0 * runs / (runs - 1)), 1e-12);
  // the time averages: the mean over the runs of each run's window mean, and their sd
  double sum = 0.0, sum2 = 0.0;
  for (long r = 0; r < runs; ++r)
  {
    double a = 0.0;
    for (int k = 3; k <= 10; ++k)
      a += raw[static_cast<std::size_t>(r) * 24 + static_cast<std::size_t>(k - 1)];
    a /= 8.0;
    sum += a;
    sum2 += a * a;
  }
  EXPECT_NEAR(m.average_mean[0], sum / runs, 1e-12);
  EXPECT_NEAR(m.average_sd[0], std::sqrt((sum2 - sum * sum / runs) / (runs - 1)), 1e-9);

  // sharded in 3 and merged: the same statistics, the sketches bit for bit
  std::vector<CallBlocks> calls;
  for (int k = 1; k <= 3; ++k)
  {
    BlockSession session = BlockSession::shard(k, 3);
    std::vector<double> part;
    runMonteCarlo(runs, 24, 2, seriesValues(), nullptr, &part, &st, &session);
    std::vector<CallBlocks> c = session.takeCalls();
    ASSERT_EQ(c.size(), 1u);
    ASSERT_TRUE(c[0].quantiles);
    if (calls.empty())
    {
      calls = c;
      calls[0].blocks.assign(static_cast<std::size_t>(blockCount(runs)), BlockMoments());
      calls[0].sketches.assign(24, QuantileSketch());
    }
    for (BlockMoments& b : c[0].blocks)
      calls[0].blocks[static_cast<std::size_t>(b.index)] = b;
    for (std::size_t v = 0; v < 24; ++v)
      calls[0].sketches[v].merge(c[0].sketches[v]);
  }
  BlockSession replay = BlockSession::replay(calls);
  std::vector<double> merged_raw;
  const Moments merged = runMonteCarlo(runs, 24, 1, seriesValues(), nullptr, &merged_raw, &st, &replay);
  EXPECT_EQ(merged.mean, m.mean);
  EXPECT_EQ(merged.exceed, m.exceed);
  EXPECT_EQ(merged.growth_mean, m.growth_mean);
  EXPECT_EQ(merged.average_sd, m.average_sd);
  EXPECT_EQ(merged_raw, raw);
  for (std::size_t v = 0; v < 24; ++v)
    EXPECT_TRUE(merged.sketches[v] == m.sketches[v]) << v;
}

TEST(HeavyTailStatistics, ExperimentOutputs)
{
  MonteCarloConfig cfg;
  cfg.experiment = "zhou_fig1";
  cfg.runs = 200;
  cfg.steps = 40;
  cfg.threads = 2;
  cfg.thresholds = {50.0, 500.0};
  const ExperimentResult r = runExperiment(cfg);
  const std::string csv = experimentCsv(r);
  EXPECT_EQ(csv.substr(0, csv.find('\n')), "case,series,x,mean,sd,n,se,p5,p25,median,p75,p95,P_gt_50,P_gt_500");
  const SeriesResult& kf = r.cases.at(0).series.at(0);
  ASSERT_EQ(kf.median.size(), 40u);
  ASSERT_EQ(kf.exceed.size(), 2u);
  for (std::size_t k = 0; k < 40; ++k)
  {
    EXPECT_LE(kf.p5[k], kf.p25[k]);
    EXPECT_LE(kf.p25[k], kf.median[k]);
    EXPECT_LE(kf.median[k], kf.p75[k]);
    EXPECT_LE(kf.p75[k], kf.p95[k]);
    EXPECT_GE(kf.exceed[0][k], kf.exceed[1][k]);
  }
  // the squared error of a stable filter: a finite growth exponent near 0, an estimable mean
  EXPECT_TRUE(std::isfinite(kf.growth));
  EXPECT_LT(std::abs(kf.growth), 0.05);
  EXPECT_TRUE(kf.mean_estimable) << kf.mean_note;
  EXPECT_GT(kf.time_average_sd, 0.0);
  const std::string json = experimentJson(r);
  EXPECT_NE(json.find("\"thresholds\": [50, 500],"), std::string::npos);
  EXPECT_NE(json.find("\"growth\": {\"rate\": "), std::string::npos);
  EXPECT_NE(json.find("\"statistic\": \"mean\""), std::string::npos);

  MonteCarloConfig bad = cfg;
  bad.thresholds = {1.0, 1.0};
  EXPECT_THROW(runExperiment(bad), ConfigError);
  bad.thresholds = {std::nan("")};
  EXPECT_THROW(runExperiment(bad), ConfigError);
  bad.thresholds.assign(kMaxThresholds + 1, 0.0);
  for (std::size_t i = 0; i < bad.thresholds.size(); ++i)
    bad.thresholds[i] = static_cast<double>(i);
  EXPECT_THROW(runExperiment(bad), ConfigError);
}

// ---------------------------------------------------------------------------------------------
// Closed forms of the scalar plant, through the tail probabilities

namespace
{

/// The scalar plant x+ = a x + w, y = x + v (Q = R = 1) under kfio. A loss maps P to a^2 P + 1, so
/// P + d with d = 1 / (a^2 - 1) is multiplied by a^2 exactly; after an arrival P < R = 1. Hence, with
/// M1 >= 1 and M2 = a^(2K) (M1 + d) - d, tr P_T exceeds M2 exactly when the last K steps were lost
/// and P_{T-K} exceeds M1:
///   P(P_T > M2) = P(K losses in a row after P > M1) P(P_{T-K} > M1),
/// so in the stationary regime (T >> K) the ratio p2 / p1 is (1 - lambda)^K for i.i.d. arrivals
/// and (1 - r)^K for a Gilbert-Elliott link losing everything in its bad state (P > M1 >= 1 means
/// the link is bad). E[P] = integral of P(P > M) dM is finite iff that decay beats the growth a^2:
/// (1 - lambda) a^2 < 1, i.e. lambda > lambda_c = 1 - 1/a^2 (Sinopoli et al.), and r > 1 - 1/a^2 on
/// the Gilbert-Elliott link. The test estimates rho = (p2 / p1)^(1/K) and checks rho a^2 against its
/// closed form and against 1.
///
/// Tolerance: p1 and p2 are fractions of n runs of nested events, so var(log p2 - log p1) is about
/// (1/p2 - 1/p1) / n (binomial, delta method), and the SE of log rho is that root over K. 4.5 SE
/// leaves a false failure at about 7e-6 (normal tails; n p2 >= 90 in every case below), and each
/// case's closed-form log(rho a^2) is at least 6 SE from 0, so the side of 1 is decided too.
struct TailCase
{
  std::string channel;
  double rho;  ///< the closed form: 1 - lambda, or 1 - r
};

void checkTailDecay(const TailCase& tc)
{
  const double a = 1.5, a2 = a * a, d = 1.0 / (a2 - 1.0), M1 = 10.0;
  const int K = 2;
  const double M2 = std::pow(a2, K) * (M1 + d) - d;
  Files f;
  MonteCarloConfig cfg;
  cfg.experiment = "covariance";
  cfg.model_path = f.write("scalar.yaml", "name: scalar\nA: [[1.5]]\nQ: [[1]]\nC: [[1]]\nR: [[1]]\nP0: [[1]]\n");
  cfg.channel_args = {f.write("link.yaml", tc.channel)};
  cfg.settings_paths = {f.write("kfio.yaml", "algorithm: kfio\n")};
  cfg.runs = 60000;
  cfg.steps = 80;
  cfg.threads = 2;
  cfg.seed = 3;
  cfg.thresholds = {M1, M2};
  const ExperimentResult r = runExperiment(cfg);
  const SeriesResult& s = r.cases.at(0).series.at(0);
  const double n = static_cast<double>(s.n);
  const double p1 = s.exceed.at(0).back(), p2 = s.exceed.at(1).back();
  ASSERT_GE(n * p2, 90.0) << tc.channel;
  const double log_rho = std::log(p2 / p1) / K;
  const double se = std::sqrt((1.0 / p2 - 1.0 / p1) / n) / K;
  EXPECT_NEAR(log_rho, std::log(tc.rho), 4.5 * se) << tc.channel;
  const double closed = std::log(tc.rho * a2);        // > 0: E[P] infinite
  ASSERT_GT(std::abs(closed), 6 * se) << tc.channel;  // the case decides the side of 1
  EXPECT_EQ(log_rho + std::log(a2) > 0.0, closed > 0.0) << tc.channel;
  // where the mean is infinite the outputs say the mean is not estimable
  if (closed > 0.3)
    EXPECT_FALSE(s.mean_estimable) << tc.channel;
}

}  // namespace

TEST(ClosedForms, ScalarCriticalArrivalRate)
{
  // lambda_c = 1 - 1/1.5^2 = 0.556: 0.35 below it (E[P] infinite), 0.7 above
  checkTailDecay({"model: bernoulli\nloss: 0.65\n", 0.65});
  checkTailDecay({"model: bernoulli\nloss: 0.3\n", 0.3});
}

TEST(ClosedForms, GilbertElliottCriticalRecoveryRate)
{
  // r_c = 1 - 1/1.5^2 = 0.556 whatever p: r = 0.35 below it, 0.7 above
  checkTailDecay({"model: gilbert_elliott\np: 0.3\nr: 0.35\nloss_good: 0\nloss_bad: 1\n", 0.65});
  checkTailDecay({"model: gilbert_elliott\np: 0.3\nr: 0.7\nloss_good: 0\nloss_bad: 1\n", 0.3});
}
