// Experiments sinopoli_fig2 and mo_sinopoli_tail (docs/reproducing.md): the transition to an
// unbounded E[P] of the Kalman filter with intermittent observations (Sinopoli et al. 2004) as a
// function of the arrival rate, with its lower and upper bounds and the critical rates lambda_min and
// lambda_max, and the tail probability P(P > M) of the prediction covariance (Mo and Sinopoli), whose
// power-law decay M^(-phi) has phi > 1, a finite mean, exactly above the critical rate.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "experiments/montecarlo_experiments.hpp"
#include "networked_estimation/common/eigenvalues.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/stability/bounds.hpp"

namespace networked_estimation
{
namespace mc
{

namespace
{

/// A plant x+ = A x + w, y = C x + v (w ~ N(0, Q), v ~ N(0, R)) of Sinopoli et al.'s examples.
struct SinopoliPlant
{
  std::string name, title;
  Eigen::MatrixXd A, C, Q, R;
};

std::vector<SinopoliPlant> sinopoliPlants()
{
  SinopoliPlant s;
  s.name = "scalar";
  s.A = Eigen::MatrixXd::Constant(1, 1, -1.25);
  s.C = Eigen::MatrixXd::Constant(1, 1, 1.0);
  s.Q = Eigen::MatrixXd::Constant(1, 1, 1.0);
  s.R = Eigen::MatrixXd::Constant(1, 1, 2.5);
  SinopoliPlant g;
  g.name = "three_states";
  g.A.resize(3, 3);
  g.A << 1.25, 1.0, 0.0, 0.0, 0.9, 7.0, 0.0, 0.0, 0.6;
  g.C.resize(1, 3);
  g.C << 1.0, 0.0, 2.0;
  g.Q = 20.0 * Eigen::MatrixXd::Identity(3, 3);
  g.R = Eigen::MatrixXd::Constant(1, 1, 2.5);
  return {s, g};
}

/// The prediction covariance after one step of the Kalman filter with intermittent observations:
/// P- <- A (P- updated when the measurement arrived) A' + Q.
Eigen::MatrixXd riccatiStep(const SinopoliPlant& p, const Eigen::MatrixXd& Pm, bool arrived)
{
  Eigen::MatrixXd P = Pm;
  if (arrived)
  {
    const Eigen::MatrixXd S = p.C * Pm * p.C.transpose() + p.R;
    const Eigen::MatrixXd K = Pm * p.C.transpose() * S.inverse();
    P = Pm - K * p.C * Pm;
    P = 0.5 * (P + P.transpose());
  }
  Eigen::MatrixXd next = p.A * P * p.A.transpose() + p.Q;
  return 0.5 * (next + next.transpose());
}

/// The whitened sensor matrix R^-1/2 C (one sensor).
std::vector<Eigen::MatrixXd> whitened(const SinopoliPlant& p)
{
  const Eigen::LLT<Eigen::MatrixXd> llt(p.R);
  return {llt.matrixL().solve(p.C)};
}

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

double sinopoliCriticalRate(double a)
{
  return std::abs(a) <= 1.0 ? 0.0 : 1.0 - 1.0 / (a * a);
}

ExperimentResult sinopoliFig2(const RunConfig& rc)
{
  const long T = rc.steps;
  const std::vector<SinopoliPlant> plants = sinopoliPlants();
  // lambda = 0.02, 0.04, ..., 1: 50 rates
  std::vector<double> lambda;
  for (int i = 1; i <= 50; ++i)
    lambda.push_back(0.02 * i);
  const std::size_t nl = lambda.size(), np = plants.size();
  const std::uint64_t seed = rc.seed;
  if (rc.progress)
    rc.progress->setTotal(rc.runs);

  // Run r at rate i of plant p: P-_1 = Q (x_0 known: P_0 = 0), arrivals i.i.d. with P(arrived) =
  // lambda_i from Rng(deriveSeed(deriveSeed(seed, r), 1 + p * nl + i)); the value is tr P-_T.
  WorkerFactory factory = [&plants, &lambda, T, nl, np, seed]() -> RunFunction
  {
    return [&plants, &lambda, T, nl, np, seed](long r, double* out)
    {
      const std::uint64_t rs = deriveSeed(seed, static_cast<std::uint64_t>(r));
      for (std::size_t p = 0; p < np; ++p)
        for (std::size_t i = 0; i < nl; ++i)
        {
          Rng rng(deriveSeed(rs, 1 + p * nl + i));
          Eigen::MatrixXd P = plants[p].Q;
          for (long k = 1; k < T && std::isfinite(P.trace()); ++k)
            P = riccatiStep(plants[p], P, rng.bernoulli(lambda[i]));
          const double t = P.trace();
          out[p * nl + i] = std::isfinite(t) ? t : kInf;
        }
    };
  };
  const CallStatistics stats = callStatistics(rc);
  const Moments m = runMonteCarlo(rc.runs, nl * np, rc.threads, factory, rc.progress, nullptr, &stats, rc.session);

  ExperimentResult res;
  res.x_label = "arrival rate lambda";
  res.y_label = "tr P- (prediction covariance)";
  res.log_y = true;
  for (std::size_t p = 0; p < np; ++p)
  {
    const SinopoliPlant& pl = plants[p];
    const std::vector<Eigen::MatrixXd> H = whitened(pl);
    const double rho = spectralRadius(pl.A);
    const double lambda_min = sinopoliLowerBound(rho);
    const CriticalBand band = mareCriticalRate(pl.A, pl.Q, H, lambda_min, 1.0);
    // The asymptotic bounds of E[P-] at each rate: S (the lower bound's limit, finite iff (1 - lambda)
    // rho^2 < 1) and V (the MARE's certified fixed point); infinite where they diverge.
    Moments lower, upper;
    lower.n = upper.n = m.n;
    for (double l : lambda)
    {
      double s = kInf;
      try
      {
        s = lowerBoundLimit(pl.A, pl.Q, 1.0 - l).trace();
      }
      catch (const std::domain_error&)
      {
      }
      lower.mean.push_back(s);
      const MareResult v = solveMare(Mare(pl.A, pl.Q, H, {l}));
      upper.mean.push_back(v.status == MareResult::Status::CONVERGED ? v.X.trace() : kInf);
    }
    lower.sd.assign(nl, 0.0);
    upper.sd.assign(nl, 0.0);
    CaseResult c;
    c.name = pl.name;
    c.title =
        (pl.name == "scalar" ? "scalar a = -1.25: lambda_c = 1 - 1/a^2 = " + fmt(sinopoliCriticalRate(-1.25))
                             : "n = 3: lambda_min = " + fmt(lambda_min) + ", lambda_max = " + fmt(band.converges_at));
    c.x = lambda;
    c.series.push_back(makeSeries("lower bound tr S (lambda)", lower, 0, nl, lambda.front(), lambda.back()));
    c.series.push_back(makeSeries("Monte Carlo tr E[P-_T]", m, p * nl, nl, lambda.front(), lambda.back()));
    c.series.push_back(makeSeries("upper bound tr V (lambda), MARE", upper, 0, nl, lambda.front(), lambda.back()));
    c.series[0].bound = c.series[2].bound = true;
    res.cases.push_back(c);
    res.notes.push_back(pl.name + ": lambda_min = 1 - 1/rho(A)^2 = " + fmt(lambda_min) + " (rho(A) = " + fmt(rho) +
                        "), lambda_max (MARE, certified) = " + fmt(band.converges_at) + " (diverges at " +
                        fmt(band.diverges_at) + ")");
  }
  res.assumptions = {
      "Sinopoli et al. 2004, Section VII: the scalar plant a = -1.25, c = 1, q = 1, r = 2.5 (lambda_c = 1 - 1/a^2 = "
      "0.36) and the three-state plant A = [1.25 1 0; 0 0.9 7; 0 0 0.6], C = [1 0 2], Q = 20 I, R = 2.5",
      "x_0 known (P_0 = 0): P-_1 = Q; the value is tr P-_T at the last step T (--steps), of the Kalman filter "
      "with intermittent observations, i.i.d. arrivals with P(arrived) = lambda",
      "lower bound S: the limit of S_{k+1} = (1 - lambda) A S_k A' + Q (infinite when (1 - lambda) rho(A)^2 >= 1); "
      "upper bound V: the certified fixed point of the MARE (infinite where it diverges); both as in "
      "docs/stability.md 3.1 and 3.2",
      "P- depends only on the arrivals: the Monte Carlo runs the Riccati recursion alone (run r, rate i, plant p: "
      "Rng(deriveSeed(deriveSeed(seed, r), 1 + p * 50 + i)))",
  };
  return res;
}

ExperimentResult moSinopoliTail(const RunConfig& rc)
{
  const long T = rc.steps;
  const SinopoliPlant pl = sinopoliPlants().front();  // the scalar plant
  const double a2 = pl.A(0, 0) * pl.A(0, 0), q = pl.Q(0, 0), r_noise = pl.R(0, 0);
  const std::vector<double> lambda = {0.2, 0.36, 0.6};
  // M = 10^0, 10^0.25, ..., 10^8
  std::vector<double> M;
  for (int i = 0; i <= 32; ++i)
    M.push_back(std::pow(10.0, 0.25 * i));
  const std::size_t nl = lambda.size(), nm = M.size();
  const std::uint64_t seed = rc.seed;
  if (rc.progress)
    rc.progress->setTotal(rc.runs);

  // Per run and rate: whether P-_T > M, for every M (the fractions over the runs are P(P-_T > M)).
  WorkerFactory factory = [&pl, &lambda, &M, T, nl, nm, seed]() -> RunFunction
  {
    return [&pl, &lambda, &M, T, nl, nm, seed](long r, double* out)
    {
      const std::uint64_t rs = deriveSeed(seed, static_cast<std::uint64_t>(r));
      for (std::size_t i = 0; i < nl; ++i)
      {
        Rng rng(deriveSeed(rs, 1 + i));
        Eigen::MatrixXd P = pl.Q;
        for (long k = 1; k < T; ++k)
          P = riccatiStep(pl, P, rng.bernoulli(lambda[i]));
        for (std::size_t j = 0; j < nm; ++j)
          out[i * nm + j] = P(0, 0) > M[j] ? 1.0 : 0.0;
      }
    };
  };
  const Moments m = runMonteCarlo(rc.runs, nl * nm, rc.threads, factory, rc.progress, nullptr, nullptr, rc.session);

  // The exact bracket of the stationary tail: P- = f^(L+1)(P+) with f(P) = a^2 P + q, L the losses
  // since the last arrival (P(L >= j) = (1 - lambda)^j) and P+ at that arrival in [q r / (q + r), r).
  // So P(P- > M) lies between (1 - lambda)^j1 and (1 - lambda)^j2, j1 the least j with
  // f^(j+1)(q r / (q + r)) > M and j2 the least with f^(j+1)(r) > M (exact up to the start: T steps).
  auto leastLosses = [&](double p_plus, double bound)
  {
    double p = a2 * p_plus + q;
    int j = 0;
    while (!(p > bound) && j < 100000)
    {
      p = a2 * p + q;
      ++j;
    }
    return j;
  };
  ExperimentResult res;
  res.x_label = "M";
  res.y_label = "P(P-_T > M)";
  res.log_x = res.log_y = true;
  CaseResult c;
  c.name = "scalar";
  c.title = "scalar a = -1.25 (lambda_c = 0.36): P(P- > M) ~ M^-phi";
  c.x = M;
  for (std::size_t i = 0; i < nl; ++i)
  {
    const double l = lambda[i];
    const double phi = std::log(1.0 - l) / std::log(1.0 / a2);
    Moments lo, hi;
    lo.n = hi.n = m.n;
    for (double bound : M)
    {
      lo.mean.push_back(std::pow(1.0 - l, leastLosses(q * r_noise / (q + r_noise), bound)));
      hi.mean.push_back(std::pow(1.0 - l, leastLosses(r_noise, bound)));
    }
    lo.sd.assign(nm, 0.0);
    hi.sd.assign(nm, 0.0);
    const std::string tag = "lambda = " + fmt(l) + " (phi = " + fmt(std::round(phi * 1000.0) / 1000.0) + ")";
    c.series.push_back(makeSeries("Monte Carlo, " + tag, m, i * nm, nm, M.front(), M.back()));
    c.series.push_back(makeSeries("lower bound, " + tag, lo, 0, nm, M.front(), M.back()));
    c.series.push_back(makeSeries("upper bound, " + tag, hi, 0, nm, M.front(), M.back()));
    c.series[c.series.size() - 2].bound = c.series.back().bound = true;
  }
  res.cases.push_back(c);
  res.assumptions = {
      "Mo and Sinopoli's tail probability P(P > M) of the scalar plant of sinopoli_fig2 (a = -1.25, c = 1, q = 1, "
      "r = 2.5) at lambda = 0.2, 0.36 (= lambda_c), 0.6; P-_T at the last step T (--steps), P-_1 = q",
      "bounds: P- = f^(L+1)(P+), f(P) = a^2 P + q, L the losses since the last arrival (P(L >= j) = (1 - "
      "lambda)^j) and P+ in [q r/(q + r), r): P(P- > M) lies between (1 - lambda)^j1 and (1 - lambda)^j2 (exact "
      "up to the horizon T)",
      "the tail decays as M^-phi, phi = ln(1 - lambda) / ln(1/a^2): E[P] is finite iff phi > 1 iff lambda > 1 - "
      "1/a^2",
  };
  return res;
}

}  // namespace mc
}  // namespace networked_estimation
