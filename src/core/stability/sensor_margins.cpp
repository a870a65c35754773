// The rate each sensor needs, the other links fixed (docs/stability.md 4.3): searches along one rate
// and the per-sensor margins.
#include "set_verdict.hpp"
#include "networked_estimation/common/numbers.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace networked_estimation
{
namespace stability_internal
{

/// pred(a) false, pred(b) true: the bracket [a, b] of the change, narrowed to tol.
std::pair<double, double> bisect(const std::function<bool(double)>& pred, double a, double b, double tol)
{
  for (int it = 0; it < 200 && b - a > tol; ++it)
  {
    const double m = 0.5 * (a + b);
    (pred(m) ? b : a) = m;
  }
  return {a, b};
}

/// The stable set along a rate in [0, 1] known to be an upper half-line.
void halfLine(const KindAt& kind, double tol, SensorMargin& out)
{
  out.half_line = true;
  CriticalBand& band = out.band;
  const auto isStable = [&](double x) { return kind(x) == Verdict::Kind::STABLE; };
  const Verdict::Kind k1 = kind(1.0);
  ++band.evaluations;
  if (k1 != Verdict::Kind::STABLE)
  {
    band.diverges_at = k1 == Verdict::Kind::UNSTABLE ? 1.0 : std::numeric_limits<double>::quiet_NaN();
    return;
  }
  const Verdict::Kind k0 = kind(0.0);
  ++band.evaluations;
  // Unstable at 0 and stable just above it: a mode on the unit circle that only this rate covers
  // (docs/stability.md 3.5d): every positive rate is stable.
  const double tiny = 1e-12;
  const bool positive = k0 == Verdict::Kind::UNSTABLE && kind(tiny) == Verdict::Kind::STABLE;
  if (k0 == Verdict::Kind::UNSTABLE)
    ++band.evaluations;
  if (k0 == Verdict::Kind::STABLE)
  {
    band.converges_at = 0.0;
  }
  else if (positive)
  {
    out.any_positive = true;
    band.diverges_at = 0.0;
    band.converges_at = 0.0;
  }
  else if (k0 == Verdict::Kind::UNDECIDED)
  {
    band.undecided_band = true;
    band.converges_at = bisect(isStable, 0.0, 1.0, tol).second;
  }
  else
  {
    double lo = 0.0, hi = 1.0;
    bool done = false;
    while (hi - lo > tol && !done)
    {
      const double m = 0.5 * (lo + hi);
      const Verdict::Kind k = kind(m);
      ++band.evaluations;
      if (k == Verdict::Kind::STABLE)
        hi = m;
      else if (k == Verdict::Kind::UNSTABLE)
        lo = m;
      else
      {
        band.undecided_band = true;
        band.converges_at = bisect(isStable, m, hi, tol).second;
        band.diverges_at = bisect([&](double x) { return kind(x) != Verdict::Kind::UNSTABLE; }, lo, m, tol).first;
        done = true;
      }
    }
    if (!done)
    {
      band.diverges_at = lo;
      band.converges_at = hi;
    }
  }
  RateInterval in;
  in.lower = band.converges_at;
  in.upper = 1.0;
  out.stable.push_back(in);
}

/// The stable set along a rate in [0, 1] by a scan of `points` + 1 grid points and bisection at
/// each change of verdict.
std::vector<RateInterval> scanStable(const KindAt& kind, int points, double tol)
{
  const auto isStable = [&](double x) { return kind(x) == Verdict::Kind::STABLE; };
  std::vector<bool> st(points + 1);
  for (int k = 0; k <= points; ++k)
    st[k] = isStable(static_cast<double>(k) / points);
  std::vector<RateInterval> out;
  for (int k = 0; k <= points; ++k)
  {
    const double x = static_cast<double>(k) / points;
    if (st[k] && (k == 0 || !st[k - 1]))
    {
      RateInterval in;
      in.lower = k == 0 ? 0.0 : bisect(isStable, static_cast<double>(k - 1) / points, x, tol).second;
      out.push_back(in);
    }
    if (st[k] && (k == points || !st[k + 1]))
      out.back().upper =
          k == points
              ? 1.0
              : bisect([&](double y) { return !isStable(y); }, x, static_cast<double>(k + 1) / points, tol).first;
  }
  return out;
}

/// Distance from value to the nearest edge of the stable set (edges at 0 or 1 where the set
/// reaches the end of [0, 1] do not count): positive inside an interval, negative outside.
double intervalMargin(const std::vector<RateInterval>& stable, double value)
{
  if (stable.empty() || !std::isfinite(value))
    return std::numeric_limits<double>::quiet_NaN();
  for (const RateInterval& in : stable)
    if (value >= in.lower && value <= in.upper)
    {
      double m = std::numeric_limits<double>::infinity();
      if (in.lower > 0.0)
        m = std::min(m, value - in.lower);
      if (in.upper < 1.0)
        m = std::min(m, in.upper - value);
      return std::isinf(m) ? value : m;
    }
  double d = std::numeric_limits<double>::infinity();
  for (const RateInterval& in : stable)
    d = std::min(d, std::min(std::abs(value - in.lower), std::abs(value - in.upper)));
  return -d;
}

std::string intervals(const std::vector<RateInterval>& stable)
{
  std::string out;
  for (const RateInterval& in : stable)
    out += (out.empty() ? "" : ", ") + std::string("[") + num(in.lower) + ", " + num(in.upper) + "]";
  return out.empty() ? "none" : out;
}

namespace
{

/// The rate sensor i needs for the modes the set observes (the links' verdict along its rate).
SensorMargin linkMargin(const Context& ctx, const SetData& all, const std::vector<LinkModel>& links, int i)
{
  const AnalysisOptions& opt = *ctx.options;
  SensorMargin m;
  const LinkModel& own = links[i];
  std::function<LinkModel(double)> make;
  if (own.kind == LinkModel::Kind::IID)
  {
    m.quantity = "arrival rate";
    m.value = own.arrival;
    make = [](double x) { return LinkModel::iid(x); };
  }
  else if (own.onOff())
  {
    m.quantity = "recovery rate";
    m.value = own.r;
    const double p = own.p;
    make = [p](double x) { return LinkModel::gilbertElliott(p, x); };
  }
  else
  {
    m.note =
        "not applicable: a hidden Gilbert-Elliott chain (loss_good > 0 or loss_bad < 1): the recovery rate "
        "does not determine its loss persistence";
    return m;
  }
  const KindAt kind = [&](double x)
  {
    std::vector<LinkModel> at = links;
    at[i] = make(x);
    return linkVerdict(ctx, all, at).kind;
  };
  const Verdict now = linkVerdict(ctx, all, links);
  if (now.kind == Verdict::Kind::NOT_APPLICABLE)
  {
    m.quantity.clear();
    m.note = "not applicable: " + now.reason;
    return m;
  }
  const bool exact = exactAvailable(all);
  const double tol = exact ? opt.exact_tolerance : opt.bisection_tolerance;
  const std::string how = exact ? "Theorem 14" : "the verdict (necessary condition and MARE)";
  if (own.kind == LinkModel::Kind::GILBERT_ELLIOTT && latticeOrderAboveOne(all, i) && !all.stable_A)
  {
    m.half_line = false;
    m.scan_points = opt.scan_points;
    m.stable = scanStable(kind, opt.scan_points, tol);
    m.margin = intervalMargin(m.stable, m.value);
    m.note = "p = " + num(own.p) +
             ", others fixed; a lattice block of order > 1 makes the stable set not a "
             "half-line: stable for r in " +
             intervals(m.stable) + " (scan of " + std::to_string(opt.scan_points) +
             " steps, bisection at each change, " + how + ")";
    return m;
  }
  halfLine(kind, tol, m);
  if (m.any_positive)
  {
    m.margin = m.value;
    m.note =
        "others fixed; any positive rate: a mode on the unit circle that only this sensor's link covers, "
        "unbounded at rate 0 (Theorem 14, docs/stability.md 3.5d)";
  }
  else if (m.band.converges_at == 0.0)
  {
    m.margin = m.value;
    m.note = "others fixed; bounded even at rate 0: the other sensors cover every mode this one sees";
  }
  else if (std::isfinite(m.band.converges_at))
  {
    m.margin = m.value - m.band.converges_at;
    m.note = "others fixed; by bisection on " + how +
             (own.kind == LinkModel::Kind::GILBERT_ELLIOTT ? " with p = " + num(own.p) : std::string());
    if (m.band.undecided_band)
      m.note += std::isnan(m.band.diverges_at)
                    ? "; undecided below " + num(m.band.converges_at) + " (no rate of this sensor is unstable)"
                    : "; undecided between " + num(m.band.diverges_at) + " and " + num(m.band.converges_at);
  }
  else
  {
    m.note = std::string("others fixed; ") + (std::isnan(m.band.diverges_at)
                                                  ? "not stable even at rate 1 (undecided there)"
                                                  : "unstable even at rate 1: this sensor cannot make the set stable");
  }
  return m;
}

}  // namespace

SensorMargin sensorMargin(const Context& ctx, const SetData& all, const std::vector<LinkModel>& links, int i,
                          bool links_only)
{
  SensorMargin m = linkMargin(ctx, all, links, i);
  if (links_only || all.dead_reckoned.empty() || m.quantity.empty())
    return m;
  // Dead-reckoned modes grow whatever this link does: no rate keeps E[P] bounded. What the observed
  // modes need is kept apart (converges_at_observed).
  const std::string observed = m.note;
  m.converges_at_observed = !m.half_line ? kNaN : m.any_positive ? 0.0 : m.band.converges_at;
  m.grows_regardless = all.dead_states;
  m.band = CriticalBand();
  m.band.diverges_at = 1.0;
  m.any_positive = false;
  m.half_line = true;
  m.stable.clear();
  m.scan_points = 0;
  m.margin = kNaN;
  if (!all.dead_grow)
  {
    m.quantity.clear();
    m.note = "not applicable: (A, B Q^1/2) has an uncontrollable mode with |lambda| >= 1, and no sensor observes " +
             all.dead_states + " even when every message arrives";
    return m;
  }
  m.note = "none: " + growRegardless(all.dead_states) + " (" + all.dead_modes +
           " that no sensor observes even when every message arrives); the observed modes alone: " + observed;
  return m;
}

}  // namespace stability_internal

using namespace stability_internal;

std::vector<SensorMargin> sensorMargins(const Model& model, const std::vector<LinkModel>& links,
                                        const AnalysisOptions& options)
{
  std::vector<int> every;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
    every.push_back(static_cast<int>(i));
  return SetVerdicts(model, every, options).margins(links);
}

}  // namespace networked_estimation
