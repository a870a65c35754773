// Stability analysis, part 3: the top-level report (analyzeStability).
#include "networked_estimation/stability/stability.hpp"

#include <cmath>
#include <functional>
#include <future>
#include <sstream>
#include <stdexcept>

namespace networked_estimation
{

namespace
{

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double v)
{
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

/// Whitened sensor matrices H_i = L_i^{-1} C_i with R_i = L_i L_i'.
std::vector<Eigen::MatrixXd> whitenedSensors(const Model& model)
{
  std::vector<Eigen::MatrixXd> H;
  for (const Sensor& s : model.sensors)
  {
    const Eigen::MatrixXd Ri = model.R.block(s.offset, s.offset, s.size, s.size);
    const Eigen::MatrixXd Ci = model.C.middleRows(s.offset, s.size);
    H.push_back(Eigen::LLT<Eigen::MatrixXd>(Ri).matrixL().solve(Ci));
  }
  return H;
}

struct Context
{
  const Model* model = nullptr;
  Eigen::MatrixXd Qn;                  ///< B Q B'
  std::vector<Eigen::MatrixXd> H;      ///< whitened, all sensors
  double rho = 0.0;
  bool excited = true;                 ///< unstable modes controllable from the noise
  bool has_channel = false;            ///< some sensor has a channel
  std::vector<LinkModel> links;        ///< per sensor (lossless: i.i.d. with arrival 1)
  std::vector<bool> lossless;
  const AnalysisOptions* options = nullptr;
};

bool sameLink(const LinkModel& a, const LinkModel& b)
{
  if (a.kind != b.kind)
    return false;
  if (a.kind == LinkModel::Kind::IID)
    return a.arrival == b.arrival;
  return a.p == b.p && a.r == b.r && a.loss_bad == b.loss_bad && a.loss_good == b.loss_good;
}

/// What the verdict of a set needs besides the links.
struct SetData
{
  std::vector<int> set;
  std::vector<Eigen::MatrixXd> H;
  Eigen::MatrixXd Hs;
  bool stable_A = false;
  bool detectable = true;
  std::vector<BlockStructure> blocks;
  Schedule schedule;  ///< the model's schedule restricted to the set (kind NONE: none)
};

SetData makeSet(const Context& ctx, const std::vector<int>& set)
{
  SetData d;
  d.set = set;
  int rows = 0;
  for (int i : set)
  {
    d.H.push_back(ctx.H[i]);
    rows += static_cast<int>(ctx.H[i].rows());
  }
  d.Hs.resize(rows, ctx.model->n());
  int r0 = 0;
  for (const auto& h : d.H)
  {
    d.Hs.middleRows(r0, h.rows()) = h;
    r0 += static_cast<int>(h.rows());
  }
  d.stable_A = ctx.rho < 1.0;
  d.detectable = modesObservable(ctx.model->A, d.Hs, 1.0, 1e-9);
  d.blocks = analyseBlocks(ctx.model->A, d.H, ctx.options->tol);
  if (ctx.model->schedule.active())
    d.schedule = restrictSchedule(ctx.model->schedule, set);
  return d;
}

/// The verdict of docs/stability.md 2.1 (steps 2-8) for the set with these links (one per member).
Verdict setVerdict(const Context& ctx, const SetData& d, const std::vector<LinkModel>& links)
{
  const AnalysisOptions& opt = *ctx.options;
  Verdict v;
  v.numbers["rho(A)"] = ctx.rho;
  if (d.stable_A)
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = "A is stable (rho(A) = " + num(ctx.rho) + " < 1): the expected error covariance is bounded at every rate";
    return v;
  }
  if (!ctx.excited)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "(A, B Q^1/2) has an uncontrollable mode with |lambda| >= 1; the critical-rate results assume "
               "(A, Q^1/2) controllable";
    return v;
  }
  if (!d.detectable)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "a mode with |lambda| >= 1 is not observable from the sensors: unbounded at every rate";
    return v;
  }
  const Verdict exact = marelliTest(d.blocks, links, opt.tol, &d.schedule);
  if (exact.kind != Verdict::Kind::NOT_APPLICABLE || d.schedule.active())
  {
    // With a schedule only Theorem 14 (cyclostationary) applies: the bounds below assume every
    // sensor transmits at every step.
    v.kind = exact.kind;
    v.reason = exact.reason;
    for (const auto& kv : exact.numbers)
      v.numbers[kv.first] = kv.second;
    return v;
  }
  // Necessary condition: all sensors lost in a window (Yang Theorem 1 for i.i.d. links:
  // prod (1 - lambda_i) rho^2 >= 1; for Markov links the all-lost event of Theorem 14).
  bool markov = false, all_iid = true;
  double persistence = 1.0;
  for (const LinkModel& l : links)
  {
    persistence *= l.lossPersistence();
    if (l.kind == LinkModel::Kind::GILBERT_ELLIOTT)
      markov = true, all_iid = false;
  }
  const double necessary = ctx.rho * ctx.rho * persistence;
  v.numbers["rho^2 prod persistence"] = necessary;
  if (markov ? necessary > 1.0 + opt.tol.decision : necessary >= 1.0 - opt.tol.decision)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    v.reason = "necessary condition fails: rho(A)^2 times the probability growth rate of losing every sensor = " +
               num(necessary) + (markov ? " > 1 (Theorem 14, all-lost event)" : " >= 1 (Yang et al. Theorem 1)") +
               "; " + exact.reason;
    return v;
  }
  if (all_iid)
  {
    std::vector<double> rates;
    for (const LinkModel& l : links)
      rates.push_back(l.arrival);
    const Mare mare(ctx.model->A, ctx.Qn, d.H, rates);
    const MareResult mr = solveMare(mare, opt.mare, true);
    v.numbers["MARE iterations"] = mr.iterations;
    v.numbers["MARE certificate rho(T)"] = mr.certificate;
    if (mr.status == MareResult::Status::CONVERGED)
    {
      v.kind = Verdict::Kind::STABLE;
      v.reason = "the MARE upper bound converges (certificate rho(T) = " + num(mr.certificate) +
                 " < 1, Yang et al. Theorem 4); " + exact.reason;
      return v;
    }
    v.kind = Verdict::Kind::UNDECIDED;
    v.reason = std::string("above the necessary lower bound but the MARE upper bound ") +
               (mr.status == MareResult::Status::DIVERGED ? "diverges" : "is undecided") +
               " (a diverging upper bound does not prove instability); " + exact.reason;
    return v;
  }
  v.kind = Verdict::Kind::UNDECIDED;
  v.reason = "above the necessary condition, no exact test available; " + exact.reason;
  return v;
}

bool exactAvailable(const SetData& d)
{
  for (const BlockStructure& b : d.blocks)
    if (b.method == BlockStructure::Method::UNAVAILABLE)
      return false;
  return true;
}

/// Some lattice block of order > 1 is seen by member j of the set (j < 0: by any member): along a
/// Markov recovery rate the stable set need not be a half-line.
bool latticeOrderAboveOne(const SetData& d, int j)
{
  for (const BlockStructure& b : d.blocks)
    if (b.method == BlockStructure::Method::LATTICE && b.block.order > 1)
      for (std::size_t k = 0; k < b.relevant.size(); ++k)
        if (b.relevant[k] && (j < 0 || static_cast<int>(k) == j))
          return true;
  return false;
}

using KindAt = std::function<Verdict::Kind(double)>;

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
  if (k0 == Verdict::Kind::STABLE)
  {
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
          k == points ? 1.0
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

/// With a sensor schedule only Theorem 14 (cyclostationary form) applies: the common arrival rate
/// at which the scheduled set turns stable (bisection on the verdict, which is monotone in a common
/// i.i.d. rate); the bounds that assume every sensor transmits at every step are not computed.
void scheduledRates(const Context& ctx, const SetData& d, RateAnalysis& ra)
{
  const double kNaNv = std::numeric_limits<double>::quiet_NaN();
  const std::string na = "not applicable: a sensor schedule (the bound assumes every sensor transmits at every step)";
  ra.lower_bound = kNaNv;
  ra.recovery_lower_bound = kNaNv;
  ra.closed_form_upper = kNaNv;
  ra.mare = CriticalBand();
  const std::size_t N = d.set.size();
  SensorMargin common;
  halfLine([&](double lambda) { return setVerdict(ctx, d, std::vector<LinkModel>(N, LinkModel::iid(lambda))).kind; },
           ctx.options->exact_tolerance, common);
  ra.exact_rate = common.band.undecided_band || std::isnan(common.band.converges_at) ? kNaNv : common.band.converges_at;
  if (std::isnan(common.band.converges_at) && common.band.diverges_at == 1.0)
    ra.exact_rate = std::numeric_limits<double>::infinity();
  std::vector<std::string> names;
  for (int i : d.set)
    names.push_back(ctx.model->sensors[static_cast<std::size_t>(i)].name);
  ra.exact_method = "Theorem 14 of Marelli et al. with the sensor schedule (" + d.schedule.describe(names) +
                    "): bisection on the verdict at a common i.i.d. rate; " + na;
  ra.recovery_note = "not computed with a sensor schedule (see the per-sensor margins)";
  ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
  ra.aoe_theorem5.reason = "a sensor schedule; Lin et al.'s Theorem 5 covers one packet sent at every step";
}

RateAnalysis analyseSet(const Context& ctx, const std::vector<int>& set, const std::string& name)
{
  const Model& model = *ctx.model;
  const AnalysisOptions& opt = *ctx.options;
  RateAnalysis ra;
  ra.name = name;
  ra.sensors = set;
  const int N = static_cast<int>(set.size());
  const SetData d = makeSet(ctx, set);
  const std::vector<Eigen::MatrixXd>& H = d.H;
  const bool stable_A = d.stable_A;
  const bool detectable = d.detectable;
  std::vector<LinkModel> links;
  for (int i : set)
    links.push_back(ctx.links[i]);
  bool uniform = true;
  for (const LinkModel& l : links)
    uniform = uniform && sameLink(l, links.front());
  const LinkModel link = links.front();

  ra.blocks = d.blocks;
  if (d.schedule.active())
  {
    scheduledRates(ctx, d, ra);
  }
  else
  {
    ra.lower_bound = sinopoliLowerBound(ctx.rho, N);
    ra.recovery_lower_bound = ra.lower_bound;  // rho^2 (1 - r)^N >= 1: all sensors lost (same formula)
    ra.exact_rate = exactCriticalArrivalRate(ra.blocks);
    if (stable_A)
      ra.exact_method = "A is stable: bounded at every rate";
    else if (std::isnan(ra.exact_rate))
    {
      for (const BlockStructure& b : ra.blocks)
        if (b.method == BlockStructure::Method::UNAVAILABLE)
          ra.exact_method = "unavailable: " + b.reason;
    }
    else if (std::isinf(ra.exact_rate))
      ra.exact_method = "an eigenvalue with |lambda| >= 1 is seen by no sensor of the set: unbounded at every rate";
    else
    {
      ra.exact_method = "Theorem 14 of Marelli et al.:";
      for (const BlockStructure& b : ra.blocks)
        ra.exact_method += " " + b.reason + ";";
      ra.exact_method.pop_back();
    }
    const EntropySplit split = entropySplit(model.A, H);
    ra.closed_form_upper = stable_A ? 0.0 : split.common_rate;

    if (stable_A)
    {
      ra.mare.converges_at = 0.0;
    }
    else if (detectable && ctx.excited)
    {
      ra.mare = mareCriticalRate(model.A, ctx.Qn, H, ra.lower_bound, 1.0, opt.bisection_tolerance, opt.mare);
    }

    // Markov threshold on a common recovery rate. It depends on the failure rate p only through
    // lattice blocks of order > 1; p is then the set's common Gilbert-Elliott p, never assumed.
    bool common_ge = ctx.has_channel;
    for (const LinkModel& l : links)
      common_ge = common_ge && l.kind == LinkModel::Kind::GILBERT_ELLIOTT && l.p == link.p;
    const bool p_dependent = !stable_A && latticeOrderAboveOne(d, -1);
    if (stable_A)
    {
      ra.recovery_exact = 0.0;
      ra.recovery_note = "A is stable";
    }
    else if (!p_dependent)
    {
      ra.recovery_exact = exactCriticalRecoveryRate(ra.blocks, 0.5);
      ra.recovery_note = "independent of the failure rate p (no lattice block of order > 1)";
    }
    else if (!common_ge)
    {
      ra.recovery_note = ctx.has_channel && link.kind == LinkModel::Kind::GILBERT_ELLIOTT
                             ? "not applicable: the sensors' Gilbert-Elliott links have different failure rates p "
                               "(see the per-sensor margins)"
                             : "not applicable: no Gilbert-Elliott link (failure rate p unknown)";
    }
    else if (!exactAvailable(d))
    {
      ra.recovery_note = "Theorem 14 not computable for this set";
    }
    else
    {
      const double p = link.p;
      const KindAt kind = [&](double r) {
        return marelliTest(d.blocks, std::vector<LinkModel>(N, LinkModel::gilbertElliott(p, r)), opt.tol).kind;
      };
      ra.recovery_stable = scanStable(kind, opt.scan_points, opt.exact_tolerance);
      if (ra.recovery_stable.empty())
      {
        ra.recovery_exact = std::numeric_limits<double>::infinity();
        ra.recovery_note = "p = " + num(p) + "; no stable recovery rate found (scan of " +
                           std::to_string(opt.scan_points) + " steps on [0, 1])";
      }
      else if (ra.recovery_stable.size() == 1 && ra.recovery_stable[0].upper == 1.0)
      {
        ra.recovery_exact = ra.recovery_stable[0].lower;
        ra.recovery_note = "p = " + num(p);
        ra.recovery_stable.clear();
      }
      else
      {
        ra.recovery_note = "p = " + num(p) + "; the stable set is not a half-line";
      }
    }

    // Lin et al.'s Theorem 5: one packet carrying the whole measurement of the set.
    if (!ctx.has_channel)
    {
      ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
      ra.aoe_theorem5.reason = "no channel given";
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(ctx.rho);
    }
    else if (N != 1)
    {
      ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
      ra.aoe_theorem5.reason =
          std::to_string(N) + " sensors on independent links; Lin et al.'s Theorem 5 covers one packet";
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(ctx.rho);
    }
    else if (link.kind == LinkModel::Kind::GILBERT_ELLIOTT && !link.onOff())
    {
      ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
      ra.aoe_theorem5.reason = "the arrivals of a Gilbert-Elliott chain with loss_good > 0 or loss_bad < 1 are not "
                               "the two-state Markov chain of Lin et al.";
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(ctx.rho);
    }
    else
    {
      // An i.i.d. link is the Markov chain with recovery = arrival and failure = 1 - arrival.
      const double rec = link.kind == LinkModel::Kind::IID ? link.arrival : link.r;
      const double fail = link.kind == LinkModel::Kind::IID ? 1.0 - link.arrival : link.p;
      const Sensor& s = model.sensors[set[0]];
      ra.aoe_theorem5 = aoeTheorem5(model.A, model.C.middleRows(s.offset, s.size), ctx.Qn,
                                    model.R.block(s.offset, s.offset, s.size, s.size), rec, fail, opt.tol);
    }
  }

  // Thresholds and margin of a common link (per-sensor links: SensorLinkReport::margin).
  const bool markov = ctx.has_channel && link.kind == LinkModel::Kind::GILBERT_ELLIOTT;
  if (ctx.has_channel && !uniform)
  {
    ra.margin_quantity = "per-sensor rates (see the sensors' links)";
  }
  else if (!markov)
  {
    ra.margin_quantity = "arrival rate";
    const bool exact = std::isfinite(ra.exact_rate);
    ra.necessary_threshold = exact ? ra.exact_rate : ra.lower_bound;
    ra.sufficient_threshold = exact ? ra.exact_rate : ra.mare.converges_at;
    if (ctx.has_channel)
      ra.channel_value = link.arrival;
  }
  else
  {
    ra.margin_quantity = "recovery rate";
    if (link.onOff())
    {
      ra.channel_value = link.r;
      if (!ra.recovery_stable.empty())
      {
        ra.stable_intervals = ra.recovery_stable;
      }
      else
      {
        const bool exact = std::isfinite(ra.recovery_exact);
        ra.necessary_threshold = exact ? ra.recovery_exact : ra.recovery_lower_bound;
        ra.sufficient_threshold = ra.recovery_exact;
      }
    }
  }
  ra.margin = ra.stable_intervals.empty() ? ra.channel_value - ra.sufficient_threshold
                                          : intervalMargin(ra.stable_intervals, ra.channel_value);

  // Verdict for the links.
  Verdict& v = ra.verdict;
  if (!ctx.has_channel)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "no channel given";
    return ra;
  }
  v = setVerdict(ctx, d, links);
  if (uniform)
    v.numbers[ra.margin_quantity] = ra.channel_value;
  else
    for (std::size_t j = 0; j < links.size(); ++j)
      v.numbers["arrival rate[" + model.sensors[set[j]].name + "]"] = links[j].arrivalRate();
  if (uniform && v.numbers.count("max |alpha|^2 Phi"))
  {
    std::ostringstream os;
    if (std::isfinite(ra.sufficient_threshold))
      os << " (" << ra.margin_quantity << " " << num(ra.channel_value) << " vs critical " << num(ra.sufficient_threshold)
         << ")";
    else if (!ra.stable_intervals.empty())
      os << " (" << ra.margin_quantity << " " << num(ra.channel_value) << "; stable for " << intervals(ra.stable_intervals)
         << ")";
    v.reason += os.str();
  }
  return ra;
}

/// The rate sensor i needs in the set of all sensors, the others' links fixed.
SensorMargin sensorMargin(const Context& ctx, const SetData& all, int i)
{
  const AnalysisOptions& opt = *ctx.options;
  SensorMargin m;
  const LinkModel& own = ctx.links[i];
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
    m.note = "not applicable: a hidden Gilbert-Elliott chain (loss_good > 0 or loss_bad < 1): the recovery rate "
             "does not determine its loss persistence";
    return m;
  }
  const KindAt kind = [&](double x) {
    std::vector<LinkModel> links = ctx.links;
    links[i] = make(x);
    return setVerdict(ctx, all, links).kind;
  };
  const Verdict now = setVerdict(ctx, all, ctx.links);
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
    m.note = "p = " + num(own.p) + ", others fixed; a lattice block of order > 1 makes the stable set not a "
             "half-line: stable for r in " + intervals(m.stable) + " (scan of " + std::to_string(opt.scan_points) +
             " steps, bisection at each change, " + how + ")";
    return m;
  }
  halfLine(kind, tol, m);
  if (std::isfinite(m.band.converges_at))
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
    m.note = std::string("others fixed; ") +
             (std::isnan(m.band.diverges_at) ? "not stable even at rate 1 (undecided there)"
                                             : "unstable even at rate 1: this sensor cannot make the set stable");
  }
  return m;
}

std::string capacityNote(const StabilityReport& rep, bool any_markov)
{
  const Capacity& c = rep.capacity;
  std::string out;
  if (c.total <= c.lower)
    out = "c <= c_lower: E[P] diverges for every allocation of rates with this capacity (Yang et al. Theorem 2)";
  else if (c.total > c.upper)
    out = "c > c_upper: SOME allocation of rates with this capacity keeps E[P] bounded (Yang et al. Theorem 6); "
          "this does NOT make this rate vector stable (see the verdict)";
  else
    out = "c_lower < c <= c_upper: the capacity alone decides nothing for this rate vector";
  if (any_markov)
    out += "; the capacity is an i.i.d. notion (stationary arrival rates are used for the Gilbert-Elliott links)";
  return out;
}

/// Yang et al.'s MARE at the report's rate vector (i.i.d. links only).
void mareAtRates(const Context& ctx, const std::vector<double>& rates, bool any_markov, StabilityReport& rep)
{
  if (any_markov)
  {
    rep.mare_at_rates = "not applicable: a Gilbert-Elliott link (the MARE bound assumes i.i.d. arrivals)";
    return;
  }
  if (ctx.model->schedule.active())
  {
    rep.mare_at_rates = "not applicable: a sensor schedule (the MARE bound assumes every sensor transmits at every step)";
    return;
  }
  if (!ctx.excited)
  {
    rep.mare_at_rates = "not applicable: the noise does not excite every unstable mode";
    return;
  }
  const Mare mare(ctx.model->A, ctx.Qn, ctx.H, rates);
  const MareResult mr = solveMare(mare, ctx.options->mare, true);
  rep.mare_at_rates_certificate = mr.certificate;
  if (mr.status == MareResult::Status::CONVERGED)
  {
    rep.mare_at_rates_trace = mr.X.trace();
    rep.mare_at_rates = "converges (certificate rho(T) = " + num(mr.certificate) +
                        " < 1): E[P] is bounded, lim E[P_k|k-1] <= V with trace V = " + num(rep.mare_at_rates_trace) +
                        " (Yang et al. Theorem 4)";
  }
  else if (mr.status == MareResult::Status::DIVERGED)
    rep.mare_at_rates = "diverges after " + std::to_string(mr.iterations) +
                        " iterations: the upper bound says nothing here (it does not prove instability)";
  else
    rep.mare_at_rates = "undecided after " + std::to_string(mr.iterations) + " iterations (no certificate)";
}

/// The model's quantities every verdict uses (links are filled in by the caller).
Context modelContext(const Model& model, const AnalysisOptions& options)
{
  Context ctx;
  ctx.model = &model;
  ctx.options = &options;
  ctx.Qn = model.B * model.Q * model.B.transpose();
  ctx.Qn = 0.5 * (ctx.Qn + ctx.Qn.transpose());
  ctx.H = whitenedSensors(model);
  ctx.rho = spectralRadius(model.A);
  const Eigen::MatrixXd G = model.B * Eigen::LLT<Eigen::MatrixXd>(model.Q).matrixL().toDenseMatrix();
  ctx.excited = modesControllable(model.A, G, 1.0, 1e-9);
  return ctx;
}

}  // namespace

std::vector<SensorMargin> sensorMargins(const Model& model, const std::vector<LinkModel>& links,
                                        const AnalysisOptions& options)
{
  if (links.size() != model.sensors.size())
    throw std::invalid_argument("sensorMargins: " + std::to_string(links.size()) + " links for " +
                                std::to_string(model.sensors.size()) + " sensors");
  Context ctx = modelContext(model, options);
  ctx.links = links;
  std::vector<int> every;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
    every.push_back(static_cast<int>(i));
  const SetData all = makeSet(ctx, every);
  std::vector<SensorMargin> out;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
    out.push_back(sensorMargin(ctx, all, static_cast<int>(i)));
  return out;
}

Verdict stabilityVerdict(const Model& model, const std::vector<int>& set, const std::vector<LinkModel>& links,
                         const AnalysisOptions& options)
{
  const Context ctx = modelContext(model, options);
  return setVerdict(ctx, makeSet(ctx, set), links);
}

StabilityReport analyzeStability(const Model& model, const ChannelSettings* sensor_link,
                                 const EstimatorSettings* estimator, const AnalysisOptions& options)
{
  std::vector<std::optional<ChannelSettings>> links(model.sensors.size());
  if (sensor_link)
    for (auto& l : links)
      l = *sensor_link;
  return analyzeStability(model, links, estimator, options);
}

StabilityReport analyzeStability(const Model& model, const std::vector<std::optional<ChannelSettings>>& sensor_links,
                                 const EstimatorSettings* estimator, const AnalysisOptions& options)
{
  if (sensor_links.size() != model.sensors.size())
    throw std::invalid_argument("analyzeStability: " + std::to_string(sensor_links.size()) + " links for " +
                                std::to_string(model.sensors.size()) + " sensors");
  StabilityReport rep;
  rep.model_name = model.name;
  rep.eigenvalues = eigenvalues(model.A);
  rep.spectral_radius = spectralRadius(model.A);
  rep.entropy = topologicalEntropy(model.A);
  rep.mahler_measure = std::exp(rep.entropy);
  rep.log_abs_det = std::log(std::abs(model.A.determinant()));
  rep.diagonalizable = isDiagonalizable(model.A, options.tol);
  rep.strong_observability = strongObservability(model.A, model.C, options.tol);

  Context ctx = modelContext(model, options);
  rep.noise_excites_unstable_modes = ctx.excited;
  rep.detectable = modesObservable(model.A, model.C, 1.0, 1e-9);
  const std::size_t S = model.sensors.size();
  for (std::size_t i = 0; i < S; ++i)
  {
    ctx.lossless.push_back(!sensor_links[i].has_value());
    ctx.links.push_back(sensor_links[i] ? LinkModel::fromSettings(*sensor_links[i]) : LinkModel::iid(1.0));
    ctx.has_channel = ctx.has_channel || sensor_links[i].has_value();
  }
  bool any_markov = false;
  for (std::size_t i = 0; i < S; ++i)
  {
    rep.uniform_links = rep.uniform_links && sameLink(ctx.links[i], ctx.links[0]);
    any_markov = any_markov || ctx.links[i].kind == LinkModel::Kind::GILBERT_ELLIOTT;
  }
  if (ctx.has_channel)
  {
    rep.has_channel = true;
    rep.link = ctx.links[0];
    rep.arrival_rate = rep.link.arrivalRate();
    rep.recovery_rate = rep.link.recoveryRate();
    std::vector<double> rates;
    std::vector<int> rows;
    for (std::size_t i = 0; i < S; ++i)
    {
      rates.push_back(ctx.links[i].arrivalRate());
      rows.push_back(model.sensors[i].size);
    }
    rep.capacity = transmissionCapacity(model.A, rates, rows);
    rep.capacity_note = capacityNote(rep, any_markov);
    if (model.schedule.active())
      rep.capacity_note += "; it ignores the sensor schedule";
    mareAtRates(ctx, rates, any_markov, rep);
  }
  rep.entropy_split = entropySplit(model.A, ctx.H);

  std::vector<int> all;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
    all.push_back(static_cast<int>(i));
  // The sets are independent (analyseSet reads ctx only): the per-sensor analyses run in parallel
  // with the model's, a thread each (the MARE bisections dominate for unstable models).
  std::vector<std::future<RateAnalysis>> per_sensor;
  if (options.per_sensor && model.sensors.size() > 1)
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
      per_sensor.push_back(std::async(std::launch::async, [&ctx, &model, i] {
        return analyseSet(ctx, {static_cast<int>(i)}, model.sensors[i].name);
      }));
  rep.model = analyseSet(ctx, all, "model");
  for (auto& f : per_sensor)
    rep.sensors.push_back(f.get());
  if (options.per_sensor && model.sensors.size() == 1)
    rep.sensors.push_back(rep.model), rep.sensors.back().name = model.sensors[0].name;

  if (ctx.has_channel)
  {
    const SetData all_set = makeSet(ctx, all);
    std::vector<std::future<SensorMargin>> margins;
    if (options.per_sensor)
      for (std::size_t i = 0; i < S; ++i)
        margins.push_back(std::async(i + 1 == S ? std::launch::deferred : std::launch::async,
                                     [&ctx, &all_set, i] { return sensorMargin(ctx, all_set, static_cast<int>(i)); }));
    for (std::size_t i = 0; i < S; ++i)
    {
      SensorLinkReport lr;
      lr.sensor = model.sensors[i].name;
      lr.lossless = ctx.lossless[i];
      lr.link = ctx.links[i];
      lr.arrival_rate = lr.link.arrivalRate();
      lr.recovery_rate = lr.link.recoveryRate();
      lr.capacity = i < rep.capacity.individual.size() ? rep.capacity.individual[i] : kNaN;
      if (options.per_sensor)
        lr.margin = margins[i].get();
      if (lr.link.kind != LinkModel::Kind::GILBERT_ELLIOTT)
        lr.markov_note = "not applicable: no Gilbert-Elliott link (failure rate p unknown)";
      else if (!lr.link.onOff())
        lr.markov_note = "not applicable: a hidden Gilbert-Elliott chain; the recovery rate does not determine the "
                         "loss persistence";
      else
        lr.markov_note = "the recovery rate this sensor needs is its margin (p = " + num(lr.link.p) + ")";
      rep.links.push_back(lr);
    }
  }

  const Algorithm alg = estimator ? estimator->algorithm : Algorithm::KFIO;
  rep.estimator = toString(alg);
  switch (alg)
  {
    case Algorithm::KFIO:
      rep.estimator_note = "the verdicts concern E[P] of the Kalman filter with intermittent observations";
      break;
    case Algorithm::AOE:
    case Algorithm::OE:
    case Algorithm::ACK_KF:
      rep.estimator_note = "OE, AOE and the ACK Kalman filter are stable together (Lin et al.'s Theorem 4); the "
                           "verdicts concern that Kalman filter with intermittent observations";
      break;
    case Algorithm::RSEIO:
      rep.estimator_note = "the rate verdicts concern the Kalman filter with intermittent observations (rseio with mu "
                           "= 1); the rseio verdict is Zhou's Theorem 5";
      break;
    case Algorithm::KF:
      rep.estimator_note = "kf treats lost samples as measurements: its covariance is that of a Kalman filter without "
                           "losses, and these verdicts do not describe its error";
      break;
  }
  if (alg == Algorithm::RSEIO && ctx.has_channel && rep.uniform_links)
    rep.rseio = rseioTheorem5(model, estimator->mu, rep.link, options.tol);
  else
  {
    rep.rseio.kind = Verdict::Kind::NOT_APPLICABLE;
    rep.rseio.reason = alg != Algorithm::RSEIO ? "the estimator is not rseio"
                       : !ctx.has_channel     ? "no channel given"
                                              : "the sensors have different links; Zhou's Theorem 5 takes one link "
                                                "for the whole measurement";
  }
  return rep;
}

}  // namespace networked_estimation
