// The loss model of a recorded link and the whole fit (link_fit.hpp); its delays are delay_fit.cpp's.
#include "networked_estimation/link/link_fit.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "networked_estimation/common/numbers.hpp"
#include "networked_estimation/common/random.hpp"

namespace networked_estimation
{
namespace link_fit_detail
{

constexpr double kZ95 = 1.959963984540054;

/// A two-state Gilbert-Elliott chain: p good -> bad, r bad -> good, P(lost | good), P(lost | bad).
struct Chain
{
  double p, r, lg, lb;
};

/// The forward variables are rescaled only when they get small (below kRescale) and at the end,
/// not at every step: a division and a logarithm per step were most of the cost. The likelihood is
/// the product of the scales, the scaled backward variables use the same scales (1 between), and
/// the expected counts are those of the usual scaled recursions (Rabiner's), since every scale
/// cancels in alpha_k beta_k.
constexpr double kRescale = 1e-150;

/// The scaled forward recursion of the losses (lost[k] = 1) under the chain started in its
/// stationary law: calls record(k, a0, a1, inv) with the forward variables at k after their
/// scaling by inv (1 where none was applied) and returns the log-likelihood (-inf when a loss
/// pattern is impossible under the chain).
template <typename Record>
double forwardPass(const std::vector<std::uint8_t>& lost, const Chain& c, Record&& record)
{
  const double e0[2] = {1.0 - c.lg, c.lg}, e1[2] = {1.0 - c.lb, c.lb};
  const double sum = c.p + c.r;
  double a0 = sum > 0 ? c.r / sum : 1.0, a1 = sum > 0 ? c.p / sum : 0.0;
  double ll = 0.0;
  const std::size_t n = lost.size();
  for (std::size_t k = 0; k < n; ++k)
  {
    if (k > 0)
    {
      const double b0 = a0 * (1.0 - c.p) + a1 * c.r;
      const double b1 = a0 * c.p + a1 * (1.0 - c.r);
      a0 = b0;
      a1 = b1;
    }
    a0 *= e0[lost[k]];
    a1 *= e1[lost[k]];
    const double s = a0 + a1;
    double inv = 1.0;
    if (s < kRescale || k + 1 == n)
    {
      if (!(s > 0.0))
        return -std::numeric_limits<double>::infinity();
      ll += std::log(s);
      inv = 1.0 / s;
      a0 *= inv;
      a1 *= inv;
    }
    record(k, a0, a1, inv);
  }
  return ll;
}

/// Log-likelihood of the losses under the chain (forwardPass alone).
double chainLogLikelihood(const std::vector<std::uint8_t>& lost, const Chain& c)
{
  return forwardPass(lost, c, [](std::size_t, double, double, double) {});
}

/// One Baum-Welch iteration: the chain's re-estimate, and the log-likelihood of `c`. `alpha` and
/// `inv_scale` are work space.
Chain baumWelchStep(const std::vector<std::uint8_t>& lost, const Chain& c, std::vector<double>& alpha,
                    std::vector<double>& inv_scale, double& ll)
{
  const std::size_t n = lost.size();
  alpha.resize(2 * n);
  inv_scale.resize(n);
  const double e0[2] = {1.0 - c.lg, c.lg}, e1[2] = {1.0 - c.lb, c.lb};
  ll = forwardPass(lost, c,
                   [&](std::size_t k, double a0, double a1, double inv)
                   {
                     alpha[2 * k] = a0;
                     alpha[2 * k + 1] = a1;
                     inv_scale[k] = inv;
                   });
  if (!std::isfinite(ll))
    return c;
  // Backward, accumulating the expected counts.
  double beta0 = 1.0, beta1 = 1.0;
  double g0 = alpha[2 * (n - 1)], g1 = alpha[2 * (n - 1) + 1];  // expected visits of each state
  double g0_lost = lost[n - 1] ? g0 : 0.0, g1_lost = lost[n - 1] ? g1 : 0.0;
  double t0 = 0.0, t1 = 0.0, x01 = 0.0, x10 = 0.0;  // visits followed by a transition, and the switches
  for (std::size_t k = n - 1; k-- > 0;)
  {
    const double f0 = e0[lost[k + 1]] * beta0 * inv_scale[k + 1];
    const double f1 = e1[lost[k + 1]] * beta1 * inv_scale[k + 1];
    const double a0k = alpha[2 * k], a1k = alpha[2 * k + 1];
    const double xi00 = a0k * (1.0 - c.p) * f0, xi01 = a0k * c.p * f1;
    const double xi10 = a1k * c.r * f0, xi11 = a1k * (1.0 - c.r) * f1;
    const double gamma0 = xi00 + xi01, gamma1 = xi10 + xi11;
    t0 += gamma0;
    t1 += gamma1;
    x01 += xi01;
    x10 += xi10;
    if (lost[k])
    {
      g0_lost += gamma0;
      g1_lost += gamma1;
    }
    beta0 = (1.0 - c.p) * f0 + c.p * f1;
    beta1 = c.r * f0 + (1.0 - c.r) * f1;
  }
  g0 += t0;
  g1 += t1;
  Chain next = c;
  if (t0 > 0.0)
    next.p = x01 / t0;
  if (t1 > 0.0)
    next.r = x10 / t1;
  if (g0 > 0.0)
    next.lg = g0_lost / g0;
  if (g1 > 0.0)
    next.lb = g1_lost / g1;
  return next;
}

/// Baum-Welch from `c` for at most `iterations` iterations or until the log-likelihood grows by
/// less than `tolerance`; returns whether it converged, with `c` and `ll` the last chain and its
/// log-likelihood.
bool baumWelch(const std::vector<std::uint8_t>& lost, Chain& c, double& ll, int iterations, double tolerance,
               std::vector<double>& alpha, std::vector<double>& inv_scale, int& done)
{
  double previous = -std::numeric_limits<double>::infinity();
  for (int it = 0; it < iterations; ++it, ++done)
  {
    const Chain next = baumWelchStep(lost, c, alpha, inv_scale, ll);
    if (!std::isfinite(ll))
      return false;
    if (ll - previous < tolerance)
      return true;
    previous = ll;
    c = next;
  }
  ll = chainLogLikelihood(lost, c);
  return false;
}

double logit(double x)
{
  const double e = 1e-12;
  x = std::min(1.0 - e, std::max(e, x));
  return std::log(x / (1.0 - x));
}

double logistic(double t)
{
  return 1.0 / (1.0 + std::exp(-t));
}

Chain chainOf(const Eigen::Vector4d& t)
{
  return Chain{logistic(t(0)), logistic(t(1)), logistic(t(2)), logistic(t(3))};
}

}  // namespace link_fit_detail

LinkStatistics linkStatistics(const SlotTrace& t)
{
  LinkStatistics s;
  s.expected = t.slots();
  s.received = t.received();
  s.lost = s.expected - s.received;
  s.duplicates = t.duplicates;
  s.reordered = t.reordered;
  s.loss_rate = s.expected ? static_cast<double>(s.lost) / static_cast<double>(s.expected) : kNaN;
  s.bursts.assign(2, 0);
  s.gaps.assign(2, 0);
  std::size_t run = 0;
  for (std::size_t k = 0; k <= t.arrived.size(); ++k)
  {
    const bool end = k == t.arrived.size();
    if (k > 0 && (end || t.arrived[k] != t.arrived[k - 1]))
    {
      std::vector<std::size_t>& h = t.arrived[k - 1] ? s.gaps : s.bursts;
      if (h.size() <= run)
        h.resize(run + 1, 0);
      ++h[run];
      run = 0;
    }
    ++run;
  }
  std::size_t bursts = 0, gaps = 0;
  for (std::size_t k = 1; k < s.bursts.size(); ++k)
  {
    bursts += s.bursts[k];
    if (s.bursts[k])
      s.longest_burst = k;
  }
  for (std::size_t k = 1; k < s.gaps.size(); ++k)
    gaps += s.gaps[k];
  s.mean_burst = bursts ? static_cast<double>(s.lost) / static_cast<double>(bursts) : kNaN;
  s.mean_gap = gaps ? static_cast<double>(s.received) / static_cast<double>(gaps) : kNaN;
  s.longest_outage = static_cast<double>(s.longest_burst + 1) * t.period;
  s.reorder_fraction = s.received ? static_cast<double>(s.reordered) / static_cast<double>(s.received) : kNaN;
  s.duplicate_fraction = s.received ? static_cast<double>(s.duplicates) / static_cast<double>(s.received) : kNaN;
  return s;
}

double logLikelihood(const std::vector<std::uint8_t>& arrived, const LinkModel& link)
{
  std::vector<std::uint8_t> lost(arrived.size());
  for (std::size_t k = 0; k < arrived.size(); ++k)
    lost[k] = arrived[k] ? 0 : 1;
  if (link.kind == LinkModel::Kind::IID)
    return link_fit_detail::chainLogLikelihood(lost, {0.0, 1.0, 1.0 - link.arrival, 1.0 - link.arrival});
  return link_fit_detail::chainLogLikelihood(lost, {link.p, link.r, link.loss_good, link.loss_bad});
}

GilbertElliottFit fitGilbertElliott(const std::vector<std::uint8_t>& arrived, const FitOptions& o)
{
  using namespace link_fit_detail;
  GilbertElliottFit fit;
  std::vector<std::uint8_t> lost(arrived.size());
  std::size_t losses = 0;
  for (std::size_t k = 0; k < arrived.size(); ++k)
  {
    lost[k] = arrived[k] ? 0 : 1;
    losses += lost[k];
  }
  if (losses == 0 || losses == lost.size() || lost.size() < 2)
  {
    fit.note = losses == 0 ? "nothing was lost" : "nothing arrived";
    fit.log_likelihood = kNaN;
    fit.p = fit.r = fit.loss_good = fit.loss_bad = ParameterEstimate{kNaN, kNaN, kNaN};
    return fit;
  }
  const ArrivalCounts counts = countArrivals(arrived);
  const LinkEstimate g = estimateLink(counts);
  const double loss_rate = static_cast<double>(losses) / static_cast<double>(lost.size());
  // The starts: near the Gilbert fit (an on/off chain, slightly opened), then seeded draws.
  std::vector<Chain> starts;
  const double gp = g.failure.trials ? g.failure.value : 0.01, gr = g.recovery.trials ? g.recovery.value : 0.5;
  starts.push_back({std::min(0.9, std::max(1e-4, gp)), std::min(0.99, std::max(1e-3, gr)), 0.02 * loss_rate, 0.9});
  Rng rng(o.seed);
  while (static_cast<int>(starts.size()) < std::max(1, o.ge_starts))
    starts.push_back({rng.uniform(0.002, 0.2), rng.uniform(0.05, 0.9), rng.uniform(0.0, std::min(0.5, loss_rate)),
                      rng.uniform(std::max(loss_rate, 0.3), 1.0)});
  // Every start for a few iterations, then the best of them to convergence (the usual short-run
  // strategy: EM's first iterations already separate the starts' basins).
  std::vector<double> alpha, inv_scale;
  Chain best{};
  double best_ll = -std::numeric_limits<double>::infinity();
  int best_done = 0;
  for (Chain c : starts)
  {
    double ll = 0.0;
    int done = 0;
    baumWelch(lost, c, ll, std::min(o.max_iterations, 10), o.tolerance, alpha, inv_scale, done);
    if (std::isfinite(ll) && ll > best_ll)
    {
      best_ll = ll;
      best = c;
      best_done = done;
    }
  }
  fit.starts = static_cast<int>(starts.size());
  if (!std::isfinite(best_ll))
  {
    fit.note = "Baum-Welch found no start with a finite likelihood";
    fit.log_likelihood = kNaN;
    fit.p = fit.r = fit.loss_good = fit.loss_bad = ParameterEstimate{kNaN, kNaN, kNaN};
    return fit;
  }
  int done = best_done;
  fit.converged = baumWelch(lost, best, best_ll, o.max_iterations - best_done, o.tolerance, alpha, inv_scale, done);
  fit.iterations = done;
  // The bad state is the one that loses more.
  if (best.lg > best.lb)
    best = Chain{best.r, best.p, best.lb, best.lg};
  fit.log_likelihood = best_ll;
  fit.p.value = best.p;
  fit.r.value = best.r;
  fit.loss_good.value = best.lg;
  fit.loss_bad.value = best.lb;

  // 95 % intervals: the observed information (numerical Hessian of the log-likelihood) on the logits.
  Eigen::Vector4d theta(logit(best.p), logit(best.r), logit(best.lg), logit(best.lb));
  const double h = 1e-3;
  Eigen::Matrix4d H;
  const double f0 = chainLogLikelihood(lost, chainOf(theta));
  for (int i = 0; i < 4; ++i)
    for (int j = i; j < 4; ++j)
    {
      Eigen::Vector4d a = theta, b = theta, c = theta, d = theta;
      if (i == j)
      {
        a(i) += h;
        b(i) -= h;
        H(i, i) = (chainLogLikelihood(lost, chainOf(a)) - 2.0 * f0 + chainLogLikelihood(lost, chainOf(b))) / (h * h);
        continue;
      }
      a(i) += h, a(j) += h;
      b(i) += h, b(j) -= h;
      c(i) -= h, c(j) += h;
      d(i) -= h, d(j) -= h;
      H(i, j) = H(j, i) = (chainLogLikelihood(lost, chainOf(a)) - chainLogLikelihood(lost, chainOf(b)) -
                           chainLogLikelihood(lost, chainOf(c)) + chainLogLikelihood(lost, chainOf(d))) /
                          (4.0 * h * h);
    }
  const Eigen::Matrix4d info = -H;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(info);
  ParameterEstimate* out[4] = {&fit.p, &fit.r, &fit.loss_good, &fit.loss_bad};
  const bool finite = info.allFinite();
  if (finite && eig.info() == Eigen::Success && eig.eigenvalues().minCoeff() > 1e-9 * eig.eigenvalues().maxCoeff())
  {
    const Eigen::Matrix4d cov = info.inverse();
    for (int i = 0; i < 4; ++i)
    {
      const double sd = std::sqrt(cov(i, i));
      out[i]->lower = logistic(theta(i) - kZ95 * sd);
      out[i]->upper = logistic(theta(i) + kZ95 * sd);
    }
  }
  else
  {
    for (ParameterEstimate* e : out)
      e->lower = e->upper = kNaN;
    fit.note =
        "the information matrix is singular at the fit: some parameter is not identifiable (the chain "
        "degenerates to a simpler link), no intervals";
  }
  return fit;
}

LossFit fitLoss(const std::vector<std::uint8_t>& arrived, const FitOptions& o)
{
  LossFit f;
  f.counts = countArrivals(arrived);
  f.estimate = estimateLink(f.counts);
  const double n = static_cast<double>(arrived.size());
  f.bernoulli.name = "bernoulli";
  f.bernoulli.parameters = 1;
  f.bernoulli.log_likelihood = logLikelihood(arrived, fittedLink(f, IntervalEnd::POINT));
  f.gilbert.name = "gilbert";
  f.gilbert.parameters = 2;
  {
    // The Gilbert link at the count estimates (what linkAt gives in Markov mode).
    const LinkModel g = linkAt(f.estimate, true, IntervalEnd::POINT);
    f.gilbert.log_likelihood = logLikelihood(arrived, g);
  }
  f.gilbert_elliott.name = "gilbert_elliott";
  f.gilbert_elliott.parameters = 4;
  if (o.fit_ge)
    f.ge = fitGilbertElliott(arrived, o);
  else
  {
    f.ge.note = "not fitted";
    f.ge.log_likelihood = kNaN;
  }
  f.gilbert_elliott.log_likelihood = f.ge.log_likelihood;
  for (ModelScore* m : {&f.bernoulli, &f.gilbert, &f.gilbert_elliott})
    m->bic = static_cast<double>(m->parameters) * std::log(n) - 2.0 * m->log_likelihood;
  f.chosen = "bernoulli";
  double best = f.bernoulli.bic;
  for (const ModelScore* m : {&f.gilbert, &f.gilbert_elliott})
    if (std::isfinite(m->bic) && m->bic < best)
    {
      best = m->bic;
      f.chosen = m->name;
    }
  std::ostringstream os;
  os.precision(6);
  os << "chosen by BIC = k ln n - 2 ln L (the least): bernoulli " << f.bernoulli.bic << ", gilbert " << f.gilbert.bic
     << ", gilbert_elliott ";
  if (std::isfinite(f.gilbert_elliott.bic))
    os << f.gilbert_elliott.bic;
  else
    os << "not fitted (" << f.ge.note << ")";
  f.choice_note = os.str();
  return f;
}

LinkModel fittedLink(const LossFit& f, IntervalEnd end)
{
  if (f.chosen == "gilbert_elliott")
  {
    const GilbertElliottFit& g = f.ge;
    auto at = [end](const ParameterEstimate& e, bool high_is_bad)
    {
      if (end == IntervalEnd::POINT || std::isnan(e.lower))
        return e.value;
      const bool bad = end == IntervalEnd::PESSIMISTIC;
      return bad == high_is_bad ? e.upper : e.lower;
    };
    const double tiny = 1e-9;
    return LinkModel::gilbertElliott(std::max(tiny, at(g.p, true)), std::max(tiny, at(g.r, false)),
                                     at(g.loss_bad, true), at(g.loss_good, true));
  }
  return linkAt(f.estimate, f.chosen == "gilbert", end);
}

ChannelSettings settingsOf(const LinkModel& link, const ChannelSettings& base)
{
  ChannelSettings s = base;
  s.replay.reset();
  if (link.kind == LinkModel::Kind::IID)
  {
    s.model = LossModelKind::BERNOULLI;
    s.loss = 1.0 - link.arrival;
    return s;
  }
  s.model = LossModelKind::GILBERT_ELLIOTT;
  s.p = link.p;
  s.r = link.r;
  s.loss_bad = link.loss_bad;
  s.loss_good = link.loss_good;
  return s;
}

std::vector<double> burstLengthLaw(const LinkModel& link, std::size_t kmax)
{
  std::vector<double> out(kmax + 1, 0.0);
  const Eigen::MatrixXd P = link.transition();
  const Eigen::VectorXd L = link.stateLoss();
  const Eigen::Index m = L.size();
  // The state distribution at the first loss of a burst: an arrival, then a loss.
  Eigen::VectorXd pi(m);
  if (m == 1)
    pi << 1.0;
  else
  {
    const double sum = link.p + link.r;
    pi << (sum > 0 ? link.r / sum : 1.0), (sum > 0 ? link.p / sum : 0.0);
  }
  Eigen::RowVectorXd w = (pi.cwiseProduct(Eigen::VectorXd::Ones(m) - L)).transpose() * P;
  w = w.cwiseProduct(L.transpose());
  const double total = w.sum();
  if (!(total > 0.0))
    return out;
  w /= total;
  const Eigen::MatrixXd PL = P * L.asDiagonal();
  const Eigen::VectorXd ends = P * (Eigen::VectorXd::Ones(m) - L);
  for (std::size_t k = 1; k <= kmax; ++k)
  {
    out[k] = w.dot(ends);
    w = w * PL;
  }
  return out;
}

LinkFit fitLink(const SlotTrace& trace, const FitOptions& o)
{
  LinkFit f;
  f.trace = trace;
  f.stats = linkStatistics(trace);
  f.loss = fitLoss(trace.arrived, o);
  f.delay = fitDelay(trace);
  ChannelSettings base;
  base.delay = f.delay.delay;
  base.jitter = f.delay.jitter;
  base.distribution = f.delay.distribution;
  base.reorder = trace.reordered > 0;
  base.duplicate = f.stats.received ? std::min(1.0, f.stats.duplicate_fraction) : 0.0;
  f.channel = settingsOf(fittedLink(f.loss, IntervalEnd::POINT), base);
  return f;
}

}  // namespace networked_estimation
