// analyze's text report (analysis_text.hpp): the verdicts, bounds and margins in words.
#include "networked_estimation/stability/analysis_text.hpp"

#include <cmath>
#include <sstream>

#include "networked_estimation/stability/excitation.hpp"

namespace networked_estimation
{

namespace
{

/// A number with 6 significant digits, NaN as n/a and infinity as unbounded.
std::string textNumber(double v)
{
  if (std::isnan(v))
    return "n/a";
  if (std::isinf(v))
    return v > 0.0 ? "unbounded" : "-unbounded";
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

/// A critical rate, +infinity in words.
std::string textRate(double v)
{
  return unboundedAtEveryRate(v) ? "none (unbounded at every rate)" : textNumber(v);
}

std::string textIntervals(const std::vector<RateInterval>& v)
{
  std::string out;
  for (const RateInterval& in : v)
    out += (out.empty() ? "" : ", ") + std::string("[") + textNumber(in.lower) + ", " + textNumber(in.upper) + "]";
  return out.empty() ? "none" : out;
}

void writeRateSet(std::ostream& os, const RateAnalysis& r, const std::string& in = "  ")
{
  if (in == "  ")
    os << "[" << r.name << "]\n";
  os << in << "lower bound (necessary)         " << textRate(r.lower_bound) << "\n";
  if (!r.mare_note.empty())
    os << in << "MARE upper bound                " << r.mare_note << "\n";
  else
    os << in << "MARE upper bound                diverges at " << textRate(r.mare.diverges_at) << ", converges at "
       << textRate(r.mare.converges_at) << (r.mare.undecided_band ? " (undecided band between)" : "") << "\n";
  os << in << "closed-form upper bound         " << textRate(r.closed_form_upper) << "\n";
  os << in << "exact critical arrival rate     " << textRate(r.exact_rate) << "  (" << r.exact_method << ")\n";
  os << in << "Markov: critical recovery rate  ";
  if (!r.recovery_stable.empty())
    os << "none (not a half-line): stable for r in " << textIntervals(r.recovery_stable);
  else
    os << textRate(r.recovery_exact);
  os << " (necessary " << textRate(r.recovery_lower_bound) << "; " << r.recovery_note << ")\n";
  os << in << "Lin et al.'s Theorem 5          " << describe(r.aoe_theorem5) << "\n";
  os << in << "verdict                         " << describe(r.verdict) << "\n";
  if (!r.observed.empty())
    os << in << "links' verdict                  " << describe(r.links_verdict) << "\n";
  if (r.margin_quantity.rfind("per-sensor", 0) == 0)
    os << in << "margin                          per sensor, the other links fixed: see [per-sensor links]\n";
  else if (!r.stable_intervals.empty())
    os << in << "margin                          " << r.margin_quantity << " " << textNumber(r.channel_value)
       << ", stable for " << textIntervals(r.stable_intervals) << ": distance to the nearest edge "
       << textNumber(r.margin) << (r.margin > 0 ? " (inside)" : " (outside)") << "\n";
  else if (unboundedAtEveryRate(r.sufficient_threshold))
    os << in << "margin                          none: no " << r.margin_quantity << " keeps E[P] bounded\n";
  else
    os << in << "margin                          " << r.margin_quantity << " " << textNumber(r.channel_value)
       << " - critical " << textNumber(r.sufficient_threshold) << " = " << textNumber(r.margin) << "\n";
  if (!r.observed.empty())
  {
    os << in << "observed modes only (what the links can change; " << growRegardless(r.dead_states) << "):\n";
    writeRateSet(os, r.observed.front(), in + "  ");
  }
}

void writeLinkNeeds(std::ostream& os, const std::vector<SensorLinkReport>& links)
{
  os << "[per-sensor links: the rate each sensor needs, the other sensors' links fixed]\n";
  for (const SensorLinkReport& l : links)
  {
    const SensorMargin& m = l.margin;
    os << "  " << l.sensor << ": ";
    if (m.quantity.empty())
      os << m.note << "\n";
    else if (!m.half_line)
      os << m.quantity << " " << textNumber(m.value) << ", stable for " << textIntervals(m.stable)
         << ", distance to the nearest edge " << textNumber(m.margin) << "\n    (" << m.note << ")\n";
    else if (!m.grows_regardless.empty())
      os << m.quantity << " " << textNumber(m.value) << ", needs: none (" << growRegardless(m.grows_regardless)
         << "); the observed modes alone need " << textRate(m.converges_at_observed) << "\n    (" << m.note << ")\n";
    else if (std::isnan(m.band.converges_at))
      os << m.quantity << " " << textNumber(m.value) << ", no stable rate: " << m.note << "\n";
    else if (m.any_positive)
      os << m.quantity << " " << textNumber(m.value) << ", needs > 0 (any positive rate; unbounded at 0), margin "
         << textNumber(m.margin) << "\n    (" << m.note << ")\n";
    else if (m.band.converges_at == 0.0)
      os << m.quantity << " " << textNumber(m.value) << ", needs 0 (bounded even without it), margin "
         << textNumber(m.margin) << "\n    (" << m.note << ")\n";
    else
      os << m.quantity << " " << textNumber(m.value) << ", needs " << textRate(m.band.converges_at) << " (diverges at "
         << textRate(m.band.diverges_at) << ", converges at " << textRate(m.band.converges_at)
         << (m.band.undecided_band ? ", undecided band between" : "") << "), margin " << textNumber(m.margin)
         << "\n    (" << m.note << ")\n";
    os << "    Markov threshold: " << l.markov_note << "\n";
  }
}

}  // namespace

std::string analysisText(const Model& model, const StabilityReport& rep, const SensorLinks& links,
                         const std::vector<TraceEvidence>& traces)
{
  std::ostringstream out;
  out << "model " << rep.model_name << ": n = " << model.n() << ", " << model.sensors.size() << " sensor(s)\n";
  out << "eigenvalues:";
  for (int i = 0; i < rep.eigenvalues.size(); ++i)
  {
    const auto& e = rep.eigenvalues[i];
    out << " " << textNumber(e.real());
    if (e.imag() != 0.0)
      out << (e.imag() > 0 ? "+" : "-") << textNumber(std::abs(e.imag())) << "i";
  }
  out << "\nrho(A) = " << textNumber(rep.spectral_radius) << ", M(A) = " << textNumber(rep.mahler_measure)
      << ", diagonalizable: " << (rep.diagonalizable ? "yes" : "no") << "\n";
  out << "strong observability: " << describe(rep.strong_observability) << "\n";
  if (!rep.dead_reckoned.empty())
    out << "dead-reckoned: " << rep.dead_reckoned
        << " (no rate keeps E[P] bounded: the verdict is unstable; the links' verdict and the 'observed "
           "modes only' lines concern what the links can change)\n";
  if (model.schedule.active())
  {
    std::vector<std::string> names;
    for (const Sensor& sn : model.sensors)
      names.push_back(sn.name);
    out << "schedule: " << model.schedule.describe(names)
        << " (verdicts by the cyclostationary Theorem 14; links advance every step)\n";
  }
  if (rep.has_channel)
  {
    out << "links:\n";
    std::istringstream lines(links.describe());
    for (std::string line; std::getline(lines, line);)
      out << "  " << line << "\n";
    if (rep.uniform_links)
      out << "channel: arrival rate " << textNumber(rep.arrival_rate) << ", recovery rate "
          << textNumber(rep.recovery_rate) << "\n";
    else
      for (const SensorLinkReport& l : rep.links)
        out << "channel " << l.sensor << ": arrival rate " << textNumber(l.arrival_rate) << ", recovery rate "
            << textNumber(l.recovery_rate) << "\n";
    out << "capacity c = " << textNumber(rep.capacity.total)
        << " (c_lower = ln rho(A) = " << textNumber(rep.capacity.lower)
        << ", c_upper = h(A) = " << textNumber(rep.capacity.upper) << "): " << rep.capacity_note << "\n";
    out << "MARE bound at these rates: " << rep.mare_at_rates << "\n";
  }
  out << "estimator " << rep.estimator << ": " << rep.estimator_note << "\n";
  if (rep.estimator == "rseio")
    out << "rseio: " << describe(rep.rseio) << "\n";
  writeRateSet(out, rep.model);
  if (rep.has_channel)
    writeLinkNeeds(out, rep.links);
  if (model.sensors.size() > 1)
    for (const RateAnalysis& r : rep.sensors)
      writeRateSet(out, r);
  if (!traces.empty())
  {
    out << "Gan and Liu, from the recorded arrivals (any loss pattern; " << ExcitationReport::caveat() << "):\n";
    for (const TraceEvidence& e : traces)
    {
      out << "  " << e.sensor << " (" << e.samples << " samples): ";
      if (!e.applicable)
      {
        out << e.reason << "\n";
        continue;
      }
      const ExcitationReport& r = e.report;
      out << "h = " << r.h << ", smallest block excitation " << textNumber(r.lambda_block)
          << ", lambda = " << textNumber(r.lambda) << ", ||A|| = " << textNumber(r.norm_A)
          << "\n    A3 (printed / proof form):";
      for (const ExcitationA3& a : r.a3)
        out << " p = " << a.p << ": " << textNumber(a.printed) << " / " << textNumber(a.proof)
            << (a.holds() ? " holds;" : " fails;");
      out << "\n    verdict: " << describe(r.verdict) << "\n";
    }
  }
  return out.str();
}

std::string verdictText(const std::string& model_name, const std::string& local_note, const VerdictReport& v)
{
  std::ostringstream out;
  out << "model " << model_name << local_note << "\n";
  if (!v.dead_reckoned.empty())
    out << "dead-reckoned: " << v.dead_reckoned << "\n";
  out << "verdict: " << describe(v.verdict) << "\n";
  out << "links' verdict: " << describe(v.links_verdict) << "\n";
  if (v.has_channel)
    writeLinkNeeds(out, v.links);
  return out.str();
}

std::string designText(const Model& model, const LinkDesign& d, const std::string& cost)
{
  std::ostringstream out;
  out << "link design for model " << model.name
      << " (i.i.d. links; cost: " << (cost == "capacity" ? "sum of -ln(1 - rate)" : "sum of the arrival rates")
      << ")\n";
  out << "  " << d.note << "\n";
  if (!d.applicable)
    return out.str();
  out << "  least-cost rates (cost " << textNumber(d.cost_value) << "), verdict " << describe(d.check) << ":\n";
  for (std::size_t j = 0; j < model.sensors.size(); ++j)
    out << "    " << model.sensors[j].name << ": arrival rate " << textRate(d.rates[j])
        << " (alone, the others lossless: " << textRate(d.alone[j]) << ")\n";
  out << "  For a Gilbert-Elliott link give it with --channel NAME=FILE (without --design): the per-sensor\n"
         "  margins then give the least recovery rate at its failure rate p, the other links fixed.\n";
  return out.str();
}

}  // namespace networked_estimation
