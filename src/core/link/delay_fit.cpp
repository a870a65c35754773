// The delays of a recorded link: their quantiles with 95 % intervals, moments, jitter, lag-1
// correlation and the channel's delay law (link_fit.hpp, fitDelay).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "networked_estimation/common/numbers.hpp"
#include "networked_estimation/link/link_fit.hpp"

namespace networked_estimation
{
namespace
{

/// Numerical quantile of ascending values by linear interpolation between order statistics (numpy's
/// default).
double quantile(const std::vector<double>& sorted, double q)
{
  const double h = static_cast<double>(sorted.size() - 1) * q;
  const std::size_t lo = static_cast<std::size_t>(std::floor(h));
  if (lo + 1 >= sorted.size())
    return sorted[lo];
  return sorted[lo] + (h - static_cast<double>(lo)) * (sorted[lo + 1] - sorted[lo]);
}

/// The 95 % intervals of p50, p90, p99 (link_fit.hpp, DelayFit): the q-quantile lies below the
/// k-th smallest of n independent delays with probability P(Binomial(n, q) >= k), so the ranks
/// n q -+ z sqrt(n q (1 - q)) (normal approximation, rounded outwards) bracket it with about 95 %
/// probability. Correlated delays carry less information: with the lag-1 correlation rho > 0 the
/// fraction below the quantile varies as if from n_eff = n (1 - rho) / (1 + rho) samples (an AR(1)
/// process; the indicator of a delay below a quantile is less correlated than the delays
/// themselves, so this errs wide), and the ranks spread by sqrt(n / n_eff) more.
void quantileIntervals(const std::vector<double>& x, DelayFit& d)
{
  const double n = static_cast<double>(x.size());
  const double rho = std::isfinite(d.lag1) && d.lag1 > 0.0 ? std::min(d.lag1, 0.999) : 0.0;
  d.effective_samples = std::max(1.0, n * (1.0 - rho) / (1.0 + rho));
  const double z = 1.959963984540054;
  struct Target
  {
    double q;
    double *lower, *upper;
    bool* open;
  };
  for (const Target& t :
       {Target{0.5, &d.p50_lower, &d.p50_upper, &d.p50_open}, Target{0.9, &d.p90_lower, &d.p90_upper, &d.p90_open},
        Target{0.99, &d.p99_lower, &d.p99_upper, &d.p99_open}})
  {
    const double half = z * std::sqrt(n * t.q * (1.0 - t.q) * n / d.effective_samples);
    const double lo = std::floor(n * t.q - half), hi = std::ceil(n * t.q + half) + 1.0;  // 1-based ranks
    *t.open = lo < 1.0 || hi > n;
    const std::size_t l = static_cast<std::size_t>(std::max(1.0, lo)) - 1;
    const std::size_t u = static_cast<std::size_t>(std::min(n, std::max(1.0, hi))) - 1;
    *t.lower = x[l];
    *t.upper = x[u];
  }
}

/// The pareto delay law's location c and scale s (d = c + s P, P ~ Pareto(1, 3)) by maximum
/// likelihood: s = min - c, and u = min - c solving 3 n / u = 4 sum 1 / (x_i - min + u).
/// Returns the log-likelihood (-inf when the smallest delay is too common for this law).
double paretoFit(const std::vector<double>& x, double xmin, double& c, double& s)
{
  const double n = static_cast<double>(x.size());
  auto g = [&](double u)
  {
    double sum = 0.0;
    for (double v : x)
      sum += 1.0 / (v - xmin + u);
    return 4.0 * sum - 3.0 * n / u;
  };
  double spread = 0.0;
  for (double v : x)
    spread = std::max(spread, v - xmin);
  if (!(spread > 0.0))
    return -std::numeric_limits<double>::infinity();
  double lo = spread * 1e-12, hi = spread;
  if (g(lo) >= 0.0)
    return -std::numeric_limits<double>::infinity();
  while (g(hi) < 0.0 && hi < spread * 1e12)
    hi *= 2.0;
  for (int i = 0; i < 200 && hi / lo > 1.0 + 1e-12; ++i)
  {
    const double mid = std::sqrt(lo * hi);
    (g(mid) < 0.0 ? lo : hi) = mid;
  }
  const double u = std::sqrt(lo * hi);
  c = xmin - u;
  s = u;
  double ll = n * std::log(3.0) + 3.0 * n * std::log(s);
  for (double v : x)
    ll -= 4.0 * std::log(v - c);
  return ll;
}

}  // namespace

DelayFit fitDelay(const SlotTrace& t)
{
  DelayFit d;
  std::vector<double> x;
  x.reserve(t.receipt_order.size());
  for (std::size_t s = 0; s < t.arrived.size(); ++s)
    if (t.arrived[s])
      x.push_back(t.delay[s]);
  d.samples = x.size();
  if (x.empty())
  {
    d.mean = d.sd = d.min = d.p50 = d.p90 = d.p99 = d.max = d.rfc3550_jitter = d.lag1 = kNaN;
    d.p50_lower = d.p50_upper = d.p90_lower = d.p90_upper = d.p99_lower = d.p99_upper = kNaN;
    return d;
  }
  const double n = static_cast<double>(x.size());
  double sum = 0.0;
  for (double v : x)
    sum += v;
  d.mean = sum / n;
  double ss = 0.0;
  for (double v : x)
    ss += (v - d.mean) * (v - d.mean);
  d.sd = std::sqrt(ss / n);
  d.min = *std::min_element(x.begin(), x.end());
  d.max = *std::max_element(x.begin(), x.end());
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  d.p50 = quantile(sorted, 0.5);
  d.p90 = quantile(sorted, 0.9);
  d.p99 = quantile(sorted, 0.99);
  // RFC 3550, 6.4.1: in arrival order, D = the change of transit time, J += (|D| - J) / 16.
  double j = 0.0;
  for (std::size_t i = 1; i < t.receipt_order.size(); ++i)
  {
    const double D = t.delay[t.receipt_order[i]] - t.delay[t.receipt_order[i - 1]];
    j += (std::abs(D) - j) / 16.0;
  }
  d.rfc3550_jitter = j;
  // Lag-1 correlation over consecutive slots that both arrived.
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  std::size_t pairs = 0;
  for (std::size_t s = 1; s < t.arrived.size(); ++s)
    if (t.arrived[s] && t.arrived[s - 1])
    {
      const double a = t.delay[s - 1], b = t.delay[s];
      sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
      ++pairs;
    }
  if (pairs >= 3)
  {
    const double m = static_cast<double>(pairs);
    const double cov = sab / m - (sa / m) * (sb / m);
    const double va = saa / m - (sa / m) * (sa / m), vb = sbb / m - (sb / m) * (sb / m);
    d.lag1 = va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : kNaN;
  }
  else
    d.lag1 = kNaN;
  quantileIntervals(sorted, d);

  // The channel's delay law, each by maximum likelihood; the best one.
  const double spread = d.max - d.min;
  if (!(spread > 1e-9 * std::max(1.0, std::abs(d.max))))
  {
    d.delay = std::max(0.0, d.mean);
    d.jitter = 0.0;
    d.distribution = DelayDistribution::UNIFORM;
    d.law_log_likelihood[0] = d.law_log_likelihood[1] = d.law_log_likelihood[2] = kNaN;
    return d;
  }
  const double two_pi = 6.283185307179586476925286766559;
  d.law_log_likelihood[0] = -n * std::log(spread);  // U[min, max]: delay = mid, jitter = half the range
  d.law_log_likelihood[1] = d.sd > 0 ? -0.5 * n * std::log(two_pi * d.sd * d.sd) - 0.5 * n : kNaN;
  double c = 0.0, s = 0.0;
  d.law_log_likelihood[2] = paretoFit(x, d.min, c, s);
  int best = 0;
  for (int i = 1; i < 3; ++i)
    if (std::isfinite(d.law_log_likelihood[i]) && d.law_log_likelihood[i] > d.law_log_likelihood[best])
      best = i;
  if (best == 0)
  {
    d.distribution = DelayDistribution::UNIFORM;
    d.delay = 0.5 * (d.min + d.max);
    d.jitter = 0.5 * spread;
  }
  else if (best == 1)
  {
    d.distribution = DelayDistribution::NORMAL;
    d.delay = d.mean;
    d.jitter = d.sd;
  }
  else
  {
    // d = delay + jitter (P - 1.5) / sqrt(0.75) = c + s P: jitter = s sqrt(0.75), delay = c + 1.5 s.
    d.distribution = DelayDistribution::PARETO;
    d.delay = c + 1.5 * s;
    d.jitter = s * std::sqrt(0.75);
  }
  d.delay = std::max(0.0, d.delay);
  return d;
}

}  // namespace networked_estimation
