// The stability report of a model and its links (analyzeStability; docs/stability.md 2-4).
#include "set_verdict.hpp"
#include "networked_estimation/common/numbers.hpp"

#include <cmath>
#include <future>
#include <tuple>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace networked_estimation
{
using namespace stability_internal;

namespace
{

/// With a sensor schedule only Theorem 14 (cyclostationary form) applies: the common arrival rate
/// at which the scheduled set turns stable (bisection on the verdict, which is monotone in a common
/// i.i.d. rate); the bounds that assume every sensor transmits at every step are not computed.
void scheduledRates(const Context& ctx, const SetData& d, RateAnalysis& ra)
{
  const std::string na = "not applicable: a sensor schedule (the bound assumes every sensor transmits at every step)";
  ra.lower_bound = kNaN;
  ra.recovery_lower_bound = kNaN;
  ra.closed_form_upper = kNaN;
  ra.mare = CriticalBand();
  const std::size_t N = d.set.size();
  SensorMargin common;
  halfLine([&](double lambda) { return linkVerdict(ctx, d, std::vector<LinkModel>(N, LinkModel::iid(lambda))).kind; },
           ctx.options->exact_tolerance, common);
  ra.exact_rate = common.band.undecided_band || std::isnan(common.band.converges_at) ? kNaN : common.band.converges_at;
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

/// The Markov (recovery-rate) threshold of one sensor's link (SensorLinkReport::markov_note).
std::string markovNote(const LinkModel& link)
{
  if (link.kind != LinkModel::Kind::GILBERT_ELLIOTT)
    return "not applicable: no Gilbert-Elliott link (failure rate p unknown)";
  if (!link.onOff())
    return "not applicable: a hidden Gilbert-Elliott chain; the recovery rate does not determine the loss persistence";
  return "the recovery rate this sensor needs is its margin (p = " + num(link.p) + ")";
}

/// A set with dead-reckoned modes (docs/stability.md 2.2): no rate keeps E[P] bounded, so every
/// threshold of `ra` becomes +infinity (none) and its margin none; the analysis of the observed modes
/// (what the links can change) moves to ra.observed.
void setApartObserved(const SetData& d, RateAnalysis& ra)
{
  RateAnalysis obs = ra;
  obs.verdict = ra.links_verdict;
  ra.observed.assign(1, obs);
  const std::string why = growRegardless(d.dead_states) + " (" + d.dead_modes +
                          " that no sensor of the set observes even when every message arrives)";
  ra.lower_bound = kInf;
  ra.recovery_lower_bound = kInf;
  ra.closed_form_upper = kInf;
  ra.mare = CriticalBand();
  ra.mare.diverges_at = 1.0;
  ra.mare.converges_at = kInf;
  ra.exact_rate = kInf;
  ra.exact_method = why + ": unbounded at every rate";
  ra.recovery_exact = kInf;
  ra.recovery_note = why;
  ra.recovery_stable.clear();
  ra.aoe_theorem5 = Verdict();
  ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
  ra.aoe_theorem5.reason = "Lin et al.'s Theorem 5 assumes every mode with |lambda| >= 1 observed; " + why;
  if (ra.margin_quantity.rfind("per-sensor", 0) != 0)
  {
    ra.necessary_threshold = kInf;
    ra.sufficient_threshold = kInf;
  }
  ra.stable_intervals.clear();
  ra.margin = kNaN;
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
  ra.dead_reckoned = d.dead_reckoned;
  ra.dead_states = d.dead_states;
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
    ra.lower_bound = sinopoliLowerBound(d.rho, N);
    ra.recovery_lower_bound = ra.lower_bound;  // rho^2 (1 - r)^N >= 1: all sensors lost (same formula)
    ra.exact_rate = exactCriticalArrivalRate(ra.blocks);
    if (stable_A)
      ra.exact_method = d.dead_reckoned.empty() ? "A is stable: bounded at every rate"
                                                : "A is stable on the observed modes: bounded at every rate";
    else if (std::isnan(ra.exact_rate))
    {
      for (const BlockStructure& b : ra.blocks)
        if (b.method == BlockStructure::Method::UNAVAILABLE)
          ra.exact_method = "unavailable: " + b.reason;
    }
    else if (std::isinf(ra.exact_rate))
      ra.exact_method = "an eigenvalue with |lambda| >= 1 is seen by no sensor of the set: unbounded at every rate";
    else if (ra.exact_rate == 0.0)
    {
      ra.exact_method =
          "Theorem 14 of Marelli et al. with every block on the unit circle: any positive rate is "
          "stable, rate 0 is not (docs/stability.md 3.5d):";
      for (const BlockStructure& b : ra.blocks)
        ra.exact_method += " " + b.reason + ";";
      ra.exact_method.pop_back();
    }
    else
    {
      ra.exact_method = "Theorem 14 of Marelli et al.:";
      for (const BlockStructure& b : ra.blocks)
        ra.exact_method += " " + b.reason + ";";
      ra.exact_method.pop_back();
    }
    // A stable A has no entropy to split (and its closed form is 0 at every size).
    ra.closed_form_upper = stable_A ? 0.0 : entropySplit(d.A, H).common_rate;

    if (stable_A)
    {
      ra.mare.converges_at = 0.0;
    }
    else if (d.excited && d.A.rows() > opt.mare_max_states)
    {
      ra.mare_note = "not computed: " + std::to_string(d.A.rows()) + " states > " +
                     std::to_string(opt.mare_max_states) + " (AnalysisOptions::mare_max_states)";
    }
    else if (d.excited)
    {
      ra.mare = mareCriticalRate(d.A, d.Qn, H, ra.lower_bound, 1.0, opt.bisection_tolerance, opt.mare);
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
      const KindAt kind = [&](double r)
      { return marelliTest(d.blocks, std::vector<LinkModel>(N, LinkModel::gilbertElliott(p, r)), opt.tol).kind; };
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
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(d.rho);
    }
    else if (N != 1)
    {
      ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
      ra.aoe_theorem5.reason =
          std::to_string(N) + " sensors on independent links; Lin et al.'s Theorem 5 covers one packet";
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(d.rho);
    }
    else if (d.A.rows() == 0)
    {
      ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
      ra.aoe_theorem5.reason = "the set observes no mode";
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(d.rho);
    }
    else if (link.kind == LinkModel::Kind::GILBERT_ELLIOTT && !link.onOff())
    {
      ra.aoe_theorem5.kind = Verdict::Kind::NOT_APPLICABLE;
      ra.aoe_theorem5.reason =
          "the arrivals of a Gilbert-Elliott chain with loss_good > 0 or loss_bad < 1 are not "
          "the two-state Markov chain of Lin et al.";
      ra.aoe_theorem5.numbers["p_t"] = aoeRecoveryThreshold(d.rho);
    }
    else
    {
      // An i.i.d. link is the Markov chain with recovery = arrival and failure = 1 - arrival.
      const double rec = link.kind == LinkModel::Kind::IID ? link.arrival : link.r;
      const double fail = link.kind == LinkModel::Kind::IID ? 1.0 - link.arrival : link.p;
      const Sensor& s = model.sensors[set[0]];
      const Eigen::MatrixXd Cs = model.C.middleRows(s.offset, s.size);
      ra.aoe_theorem5 = aoeTheorem5(d.A, d.unobserved > 0 ? Eigen::MatrixXd(Cs * d.observed_basis) : Cs, d.Qn,
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

  // Verdict for the links (the observed modes), then whether E[P] is bounded.
  Verdict& v = ra.links_verdict;
  if (!ctx.has_channel)
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "no channel given";
  }
  else
  {
    v = linkVerdict(ctx, d, links);
    if (uniform)
      v.numbers[ra.margin_quantity] = ra.channel_value;
    else
      for (std::size_t j = 0; j < links.size(); ++j)
        v.numbers["arrival rate[" + model.sensors[set[j]].name + "]"] = links[j].arrivalRate();
    if (uniform && v.numbers.count("max |alpha|^2 Phi"))
    {
      std::ostringstream os;
      if (std::isfinite(ra.sufficient_threshold))
        os << " (" << ra.margin_quantity << " " << num(ra.channel_value) << " vs critical "
           << num(ra.sufficient_threshold) << ")";
      else if (!ra.stable_intervals.empty())
        os << " (" << ra.margin_quantity << " " << num(ra.channel_value) << "; stable for "
           << intervals(ra.stable_intervals) << ")";
      v.reason += os.str();
    }
  }
  ra.verdict = setVerdictFrom(d, v);
  if (!d.dead_reckoned.empty())
    setApartObserved(d, ra);
  return ra;
}

std::string capacityNote(const StabilityReport& rep, bool any_markov, const SetData& all)
{
  const Capacity& c = rep.capacity;
  std::string out;
  if (!all.dead_reckoned.empty())
    out = "no allocation of rates keeps E[P] bounded: " + growRegardless(all.dead_states) +
          " (the capacities here are of the observed modes)";
  else if (c.total <= c.lower)
    out = "c <= c_lower: E[P] diverges for every allocation of rates with this capacity (Yang et al. Theorem 2)";
  else if (c.total > c.upper)
    out =
        "c > c_upper: SOME allocation of rates with this capacity keeps E[P] bounded (Yang et al. Theorem 6); "
        "this does NOT make this rate vector stable (see the verdict)";
  else
    out = "c_lower < c <= c_upper: the capacity alone decides nothing for this rate vector";
  if (any_markov)
    out += "; the capacity is an i.i.d. notion (stationary arrival rates are used for the Gilbert-Elliott links)";
  return out;
}

/// Yang et al.'s MARE at the report's rate vector (i.i.d. links only), on the modes every sensor
/// together observes (`all`).
void mareAtRates(const Context& ctx, const SetData& all, const std::vector<double>& rates, bool any_markov,
                 StabilityReport& rep)
{
  if (any_markov)
  {
    rep.mare_at_rates = "not applicable: a Gilbert-Elliott link (the MARE bound assumes i.i.d. arrivals)";
    return;
  }
  if (ctx.model->schedule.active())
  {
    rep.mare_at_rates =
        "not applicable: a sensor schedule (the MARE bound assumes every sensor transmits at every step)";
    return;
  }
  if (!all.excited)
  {
    rep.mare_at_rates = "not applicable: the noise does not excite every unstable mode";
    return;
  }
  if (all.A.rows() > ctx.options->mare_max_states)
  {
    rep.mare_at_rates = "not computed: " + std::to_string(all.A.rows()) + " states > " +
                        std::to_string(ctx.options->mare_max_states) + " (AnalysisOptions::mare_max_states)";
    return;
  }
  const Mare mare(all.A, all.Qn, all.H, rates);
  const MareResult mr = solveMare(mare, ctx.options->mare, true);
  rep.mare_at_rates_certificate = mr.certificate;
  if (mr.status == MareResult::Status::CONVERGED && !all.dead_reckoned.empty())
  {
    // On the quotient by the unobservable subspace: a bound for the observed modes only.
    rep.mare_at_rates_trace = mr.X.trace();
    rep.mare_at_rates = "converges on the observed modes only (certificate rho(T) = " + num(mr.certificate) +
                        " < 1): their E[P] is bounded with trace <= " + num(rep.mare_at_rates_trace) + ", but " +
                        growRegardless(all.dead_states);
  }
  else if (mr.status == MareResult::Status::CONVERGED)
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

}  // namespace

VerdictReport verdictOnly(const Model& model, const std::vector<std::optional<ChannelSettings>>& sensor_links,
                          const AnalysisOptions& options)
{
  if (sensor_links.size() != model.sensors.size())
    throw std::invalid_argument("verdictOnly: " + std::to_string(sensor_links.size()) + " links for " +
                                std::to_string(model.sensors.size()) + " sensors");
  VerdictReport out;
  std::vector<int> all;
  std::vector<LinkModel> links;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    all.push_back(static_cast<int>(i));
    links.push_back(sensor_links[i] ? LinkModel::fromSettings(*sensor_links[i]) : LinkModel::iid(1.0));
    out.has_channel = out.has_channel || sensor_links[i].has_value();
  }
  const SetVerdicts sv(model, all, options);
  out.dead_reckoned = sv.deadReckoned();
  out.dead_states = sv.deadStates();
  if (!out.has_channel)
  {
    Verdict none;
    none.reason = "no channel given";
    out.links_verdict = none;
    out.verdict = sv.verdictGiven(none);  // unstable when some mode grows regardless of the links
    return out;
  }
  std::tie(out.verdict, out.links_verdict) = sv.verdicts(links);
  const std::vector<SensorMargin> margins = sv.margins(links);
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    SensorLinkReport lr;
    lr.sensor = model.sensors[i].name;
    lr.lossless = !sensor_links[i].has_value();
    lr.link = links[i];
    lr.arrival_rate = lr.link.arrivalRate();
    lr.recovery_rate = lr.link.recoveryRate();
    lr.capacity = kNaN;  // not computed here (analyze's report has it)
    lr.margin = margins[i];
    lr.markov_note = markovNote(lr.link);
    out.links.push_back(lr);
  }
  return out;
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
  std::vector<int> all;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
    all.push_back(static_cast<int>(i));
  const SetData all_set = makeSet(ctx, all);
  rep.dead_reckoned = all_set.dead_reckoned;
  rep.dead_states = all_set.dead_states;
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
    rep.capacity = transmissionCapacity(all_set.A, rates, rows);
    rep.capacity_note = capacityNote(rep, any_markov, all_set);
    if (model.schedule.active())
      rep.capacity_note += "; it ignores the sensor schedule";
    mareAtRates(ctx, all_set, rates, any_markov, rep);
  }
  if (!all_set.stable_A)
    rep.entropy_split = entropySplit(all_set.A, all_set.H);

  // The sets are independent (analyseSet reads ctx only): the per-sensor analyses run in parallel
  // with the model's, a thread each (the MARE bisections dominate for unstable models).
  std::vector<std::future<RateAnalysis>> per_sensor;
  if (options.per_sensor && model.sensors.size() > 1)
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
      per_sensor.push_back(std::async(std::launch::async, [&ctx, &model, i]
                                      { return analyseSet(ctx, {static_cast<int>(i)}, model.sensors[i].name); }));
  rep.model = analyseSet(ctx, all, "model");
  for (auto& f : per_sensor)
    rep.sensors.push_back(f.get());
  if (options.per_sensor && model.sensors.size() == 1)
    rep.sensors.push_back(rep.model), rep.sensors.back().name = model.sensors[0].name;

  if (ctx.has_channel)
  {
    std::vector<std::future<SensorMargin>> margins;
    if (options.per_sensor)
      for (std::size_t i = 0; i < S; ++i)
        margins.push_back(std::async(i + 1 == S ? std::launch::deferred : std::launch::async, [&ctx, &all_set, i]
                                     { return sensorMargin(ctx, all_set, ctx.links, static_cast<int>(i)); }));
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
      lr.markov_note = markovNote(lr.link);
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
    case Algorithm::EKFIO:
      rep.estimator_note =
          "the verdicts concern E[P] of the Kalman filter with intermittent observations of this "
          "linear model (ekfio's linearisation): for a built-in motion a local verdict";
      break;
    case Algorithm::AOE:
    case Algorithm::OE:
    case Algorithm::ACK_KF:
      rep.estimator_note =
          "OE, AOE and the ACK Kalman filter are stable together (Lin et al.'s Theorem 4); the "
          "verdicts concern that Kalman filter with intermittent observations";
      break;
    case Algorithm::RSEIO:
      rep.estimator_note =
          "the rate verdicts concern the Kalman filter with intermittent observations (rseio with mu "
          "= 1); the rseio verdict is Zhou's Theorem 5";
      break;
    case Algorithm::KF:
      rep.estimator_note =
          "kf treats lost samples as measurements: its covariance is that of a Kalman filter without "
          "losses, and these verdicts do not describe its error";
      break;
  }
  if (alg == Algorithm::RSEIO && ctx.has_channel && rep.uniform_links)
    rep.rseio = rseioTheorem5(model, estimator->mu, rep.link, options.tol);
  else
  {
    rep.rseio.kind = Verdict::Kind::NOT_APPLICABLE;
    rep.rseio.reason = alg != Algorithm::RSEIO ? "the estimator is not rseio"
                       : !ctx.has_channel      ? "no channel given"
                                               : "the sensors have different links; Zhou's Theorem 5 takes one link "
                                                 "for the whole measurement";
  }
  return rep;
}

}  // namespace networked_estimation
