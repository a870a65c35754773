// analyze: stability analysis of a model with a lossy link per sensor (stability.hpp, sensor_links.hpp).
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "cli.hpp"
#include "networked_estimation/io/json_writer.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/io/arrival_trace.hpp"
#include "networked_estimation/stability/excitation.hpp"
#include "networked_estimation/stability/link_design.hpp"
#include "networked_estimation/stability/stability.hpp"

using namespace networked_estimation;

namespace
{

std::string jnum(double v)
{
  if (!std::isfinite(v))
    return "null";
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

std::string jverdict(const Verdict& v)
{
  std::string out =
      "{\"kind\": " + jsonString(toString(v.kind)) + ", \"reason\": " + jsonString(v.reason) + ", \"numbers\": {";
  bool first = true;
  for (const auto& kv : v.numbers)
  {
    out += (first ? "" : ", ") + jsonString(kv.first) + ": " + jnum(kv.second);
    first = false;
  }
  return out + "}}";
}

std::string jintervals(const std::vector<RateInterval>& v)
{
  std::string out = "[";
  for (std::size_t i = 0; i < v.size(); ++i)
    out += (i ? ", " : "") + std::string("[") + jnum(v[i].lower) + ", " + jnum(v[i].upper) + "]";
  return out + "]";
}

std::string jlink(const SensorLinkReport& l, const std::string& origin)
{
  std::ostringstream os;
  const SensorMargin& m = l.margin;
  os << "{\"sensor\": " << jsonString(l.sensor) << ", \"origin\": " << jsonString(origin) << ", \"kind\": "
     << jsonString(l.lossless ? "lossless" : l.link.kind == LinkModel::Kind::IID ? "bernoulli" : "gilbert_elliott")
     << ", \"arrival_rate\": " << jnum(l.arrival_rate) << ", \"recovery_rate\": " << jnum(l.recovery_rate);
  if (l.link.kind == LinkModel::Kind::GILBERT_ELLIOTT)
    os << ", \"p\": " << jnum(l.link.p) << ", \"r\": " << jnum(l.link.r);
  else
    os << ", \"p\": null, \"r\": null";
  os << ", \"on_off\": " << (l.link.onOff() ? "true" : "false") << ", \"capacity\": " << jnum(l.capacity)
     << ", \"margin\": {\"quantity\": " << (m.quantity.empty() ? "null" : jsonString(m.quantity))
     << ", \"value\": " << jnum(m.value) << ", \"half_line\": " << (m.half_line ? "true" : "false")
     << ", \"diverges_at\": " << jnum(m.band.diverges_at) << ", \"converges_at\": " << jnum(m.band.converges_at)
     << ", \"undecided_band\": " << (m.band.undecided_band ? "true" : "false")
     << ", \"stable_intervals\": " << jintervals(m.stable) << ", \"scan_points\": " << m.scan_points
     << ", \"margin\": " << jnum(m.margin) << ", \"note\": " << jsonString(m.note) << "}"
     << ", \"markov_threshold\": " << jsonString(l.markov_note) << "}";
  return os.str();
}

std::string jset(const RateAnalysis& r)
{
  std::ostringstream os;
  os << "{\"name\": " << jsonString(r.name) << ", \"sensors\": [";
  for (std::size_t i = 0; i < r.sensors.size(); ++i)
    os << (i ? ", " : "") << r.sensors[i];
  os << "], \"lower_bound\": " << jnum(r.lower_bound) << ", \"closed_form_upper\": " << jnum(r.closed_form_upper)
     << ", \"mare_diverges_at\": " << jnum(r.mare.diverges_at) << ", \"mare_converges_at\": " << jnum(r.mare.converges_at)
     << ", \"mare_undecided_band\": " << (r.mare.undecided_band ? "true" : "false")
     << ", \"exact_rate\": " << jnum(r.exact_rate) << ", \"exact_method\": " << jsonString(r.exact_method)
     << ", \"recovery_lower_bound\": " << jnum(r.recovery_lower_bound) << ", \"recovery_exact\": " << jnum(r.recovery_exact)
     << ", \"recovery_note\": " << jsonString(r.recovery_note)
     << ", \"recovery_stable_intervals\": " << jintervals(r.recovery_stable)
     << ", \"aoe_theorem5\": " << jverdict(r.aoe_theorem5) << ", \"verdict\": " << jverdict(r.verdict)
     << ", \"margin_quantity\": " << jsonString(r.margin_quantity) << ", \"channel_value\": " << jnum(r.channel_value)
     << ", \"necessary_threshold\": " << jnum(r.necessary_threshold)
     << ", \"sufficient_threshold\": " << jnum(r.sufficient_threshold) << ", \"margin\": " << jnum(r.margin)
     << ", \"stable_intervals\": " << jintervals(r.stable_intervals) << "}";
  return os.str();
}

/// Gan and Liu's evidence for one sensor's recorded arrivals (a scalar output only).
struct TraceEvidence
{
  std::string sensor;
  std::size_t samples = 0;
  bool applicable = false;
  std::string reason;  ///< why not applicable
  ExcitationReport report;
};

std::vector<TraceEvidence> traceEvidence(const Model& model, const std::vector<std::string>& specs, int h)
{
  std::vector<TraceEvidence> out;
  for (const std::string& spec : specs)
  {
    const ArrivalTrace trace = readArrivalTrace(spec, model);
    for (std::size_t s = 0; s < model.sensors.size(); ++s)
    {
      if (trace.arrivals[s].empty())
        continue;
      const Sensor& sensor = model.sensors[s];
      TraceEvidence e;
      e.sensor = sensor.name;
      e.samples = trace.arrivals[s].size();
      if (sensor.size != 1)
        e.reason = "not applicable: Gan and Liu treat a scalar output (sensor " + sensor.name + " has " +
                   std::to_string(sensor.size) + " rows)";
      else if (e.samples < static_cast<std::size_t>(h))
        e.reason = "not applicable: the trace of " + sensor.name + " has " + std::to_string(e.samples) +
                   " samples, fewer than one block of h = " + std::to_string(h);
      else
      {
        e.applicable = true;
        e.report = ganLiuTrace(model.A, model.C.middleRows(sensor.offset, 1), model.R(sensor.offset, sensor.offset),
                               trace.arrivals[s], h);
      }
      out.push_back(e);
    }
  }
  return out;
}

std::string jtrace(const TraceEvidence& e)
{
  std::ostringstream os;
  os << "{\"sensor\": " << jsonString(e.sensor) << ", \"samples\": " << e.samples;
  if (!e.applicable)
    return os.str() + ", \"verdict\": {\"kind\": \"not_applicable\", \"reason\": " + jsonString(e.reason) + "}}";
  const ExcitationReport& r = e.report;
  os << ", \"h\": " << r.h << ", \"lambda_block_min\": " << jnum(r.lambda_block) << ", \"lambda\": " << jnum(r.lambda)
     << ", \"norm_A\": " << jnum(r.norm_A) << ", \"a3\": [";
  for (std::size_t i = 0; i < r.a3.size(); ++i)
    os << (i ? ", " : "") << "{\"p\": " << r.a3[i].p << ", \"printed\": " << jnum(r.a3[i].printed)
       << ", \"proof\": " << jnum(r.a3[i].proof) << ", \"holds\": " << (r.a3[i].holds() ? "true" : "false") << "}";
  os << "], \"verdict\": " << jverdict(r.verdict) << ", \"caveat\": " << jsonString(ExcitationReport::caveat()) << "}";
  return os.str();
}

std::string json(const StabilityReport& rep, const SensorLinks& sl, const std::vector<TraceEvidence>& traces)
{
  std::ostringstream os;
  os << "{\n  \"model\": " << jsonString(rep.model_name) << ",\n  \"eigenvalues\": [";
  for (int i = 0; i < rep.eigenvalues.size(); ++i)
    os << (i ? ", " : "") << "{\"re\": " << jnum(rep.eigenvalues[i].real()) << ", \"im\": " << jnum(rep.eigenvalues[i].imag())
       << "}";
  os << "],\n  \"spectral_radius\": " << jnum(rep.spectral_radius) << ",\n  \"mahler_measure\": " << jnum(rep.mahler_measure)
     << ",\n  \"entropy\": " << jnum(rep.entropy) << ",\n  \"diagonalizable\": " << (rep.diagonalizable ? "true" : "false")
     << ",\n  \"strong_observability\": " << jverdict(rep.strong_observability)
     << ",\n  \"noise_excites_unstable_modes\": " << (rep.noise_excites_unstable_modes ? "true" : "false")
     << ",\n  \"detectable\": " << (rep.detectable ? "true" : "false") << ",\n  \"channel\": ";
  if (rep.has_channel)
    os << "{\"kind\": " << jsonString(rep.link.kind == LinkModel::Kind::IID ? "bernoulli" : "gilbert_elliott")
       << ", \"arrival_rate\": " << jnum(rep.arrival_rate) << ", \"recovery_rate\": " << jnum(rep.recovery_rate)
       << ", \"on_off\": " << (rep.link.onOff() ? "true" : "false") << ", \"capacity\": " << jnum(rep.capacity.total)
       << ", \"capacity_lower\": " << jnum(rep.capacity.lower) << ", \"capacity_upper\": " << jnum(rep.capacity.upper)
       << ", \"capacity_note\": " << jsonString(rep.capacity_note)
       << ", \"mare_at_rates\": " << jsonString(rep.mare_at_rates)
       << ", \"mare_at_rates_trace\": " << jnum(rep.mare_at_rates_trace)
       << ", \"mare_at_rates_certificate\": " << jnum(rep.mare_at_rates_certificate)
       << ", \"uniform\": " << (rep.uniform_links ? "true" : "false") << "}";
  else
    os << "null";
  os << ",\n  \"links\": [";
  for (std::size_t i = 0; i < rep.links.size(); ++i)
    os << (i ? ",\n    " : "\n    ") << jlink(rep.links[i], i < sl.origin.size() ? sl.origin[i] : "");
  os << (rep.links.empty() ? "]" : "\n  ]");
  os << ",\n  \"estimator\": " << jsonString(rep.estimator)
     << ",\n  \"estimator_note\": " << jsonString(rep.estimator_note)
     << ",\n  \"rseio\": " << jverdict(rep.rseio) << ",\n  \"all_sensors\": " << jset(rep.model) << ",\n  \"sensors\": [";
  for (std::size_t i = 0; i < rep.sensors.size(); ++i)
    os << (i ? ",\n    " : "\n    ") << jset(rep.sensors[i]);
  os << "\n  ],\n  \"gan_liu\": [";
  for (std::size_t i = 0; i < traces.size(); ++i)
    os << (i ? ",\n    " : "\n    ") << jtrace(traces[i]);
  os << (traces.empty() ? "]" : "\n  ]") << "\n}\n";
  return os.str();
}

std::string txt(double v)
{
  if (std::isnan(v))
    return "n/a";
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

std::string intervals(const std::vector<RateInterval>& v)
{
  std::string out;
  for (const RateInterval& in : v)
    out += (out.empty() ? "" : ", ") + std::string("[") + txt(in.lower) + ", " + txt(in.upper) + "]";
  return out.empty() ? "none" : out;
}

void printSet(std::ostream& os, const RateAnalysis& r)
{
  os << "[" << r.name << "]\n";
  os << "  lower bound (necessary)         " << txt(r.lower_bound) << "\n";
  os << "  MARE upper bound                diverges at " << txt(r.mare.diverges_at) << ", converges at "
     << txt(r.mare.converges_at) << (r.mare.undecided_band ? " (undecided band between)" : "") << "\n";
  os << "  closed-form upper bound         " << txt(r.closed_form_upper) << "\n";
  os << "  exact critical arrival rate     " << txt(r.exact_rate) << "  (" << r.exact_method << ")\n";
  os << "  Markov: critical recovery rate  ";
  if (!r.recovery_stable.empty())
    os << "none (not a half-line): stable for r in " << intervals(r.recovery_stable);
  else
    os << txt(r.recovery_exact);
  os << " (necessary " << txt(r.recovery_lower_bound) << "; " << r.recovery_note << ")\n";
  os << "  Lin et al.'s Theorem 5          " << describe(r.aoe_theorem5) << "\n";
  os << "  verdict                         " << describe(r.verdict) << "\n";
  if (r.margin_quantity.rfind("per-sensor", 0) == 0)
    os << "  margin                          per sensor, the other links fixed: see [per-sensor links]\n";
  else if (!r.stable_intervals.empty())
    os << "  margin                          " << r.margin_quantity << " " << txt(r.channel_value) << ", stable for "
       << intervals(r.stable_intervals) << ": distance to the nearest edge " << txt(r.margin)
       << (r.margin > 0 ? " (inside)" : " (outside)") << "\n";
  else
    os << "  margin                          " << r.margin_quantity << " " << txt(r.channel_value) << " - critical "
       << txt(r.sufficient_threshold) << " = " << txt(r.margin) << "\n";
}

void printLinks(std::ostream& os, const StabilityReport& rep)
{
  os << "[per-sensor links: the rate each sensor needs, the other sensors' links fixed]\n";
  for (const SensorLinkReport& l : rep.links)
  {
    const SensorMargin& m = l.margin;
    os << "  " << l.sensor << ": ";
    if (m.quantity.empty())
      os << m.note << "\n";
    else if (!m.half_line)
      os << m.quantity << " " << txt(m.value) << ", stable for " << intervals(m.stable) << ", distance to the nearest edge "
         << txt(m.margin) << "\n    (" << m.note << ")\n";
    else if (std::isnan(m.band.converges_at))
      os << m.quantity << " " << txt(m.value) << ", no stable rate: " << m.note << "\n";
    else
      os << m.quantity << " " << txt(m.value) << ", needs " << txt(m.band.converges_at) << " (diverges at "
         << txt(m.band.diverges_at) << ", converges at " << txt(m.band.converges_at)
         << (m.band.undecided_band ? ", undecided band between" : "") << "), margin " << txt(m.margin) << "\n    ("
         << m.note << ")\n";
    os << "    Markov threshold: " << l.markov_note << "\n";
  }
}

int printDesign(const Model& model, const cli::CommandLine& cl)
{
  const std::string c = cl.get("design");
  if (c != "total_rate" && c != "capacity")
    throw cli::UsageError("--design: expected total_rate or capacity, found '" + c + "'");
  const std::string gtext = cl.has("growth-cap") ? cl.get("growth-cap") : "0.9";
  char* end = nullptr;
  const double g = std::strtod(gtext.c_str(), &end);
  if (end == gtext.c_str() || *end != '\0' || !(g > 0.0 && g < 1.0))
    throw cli::UsageError("--growth-cap: expected a number in (0, 1), found '" + gtext + "'");
  const LinkDesign d = designLinks(model, c == "capacity" ? DesignCost::CAPACITY : DesignCost::TOTAL_RATE, g);
  std::cout << "link design for model " << model.name << " (i.i.d. links; cost: "
            << (c == "capacity" ? "sum of -ln(1 - rate)" : "sum of the arrival rates") << ")\n";
  if (!d.applicable)
  {
    std::cout << "  " << d.note << "\n";
    return 0;
  }
  std::cout << "  " << d.note << "\n";
  std::cout << "  least-cost rates (cost " << txt(d.cost_value) << "), verdict " << describe(d.check) << ":\n";
  for (std::size_t j = 0; j < model.sensors.size(); ++j)
    std::cout << "    " << model.sensors[j].name << ": arrival rate " << txt(d.rates[j])
              << " (alone, the others lossless: " << txt(d.alone[j]) << ")\n";
  std::cout << "  For a Gilbert-Elliott link give it with --channel NAME=FILE (without --design): the per-sensor\n"
               "  margins then give the least recovery rate at its failure rate p, the other links fixed.\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv)
{
  cli::CommandLine cl("analyze",
                      "Stability analysis of a model over lossy sensor links: eigenvalues and rho(A), the\n"
                      "necessary lower bound, the MARE upper bound, the exact critical rate when available, the\n"
                      "Markov threshold on the recovery rate, the capacity, the verdict for the links and the\n"
                      "margin, for the model and for each sensor alone, and per sensor the rate it needs with the\n"
                      "other links fixed. Every sensor has its own link: --channel FILE for every sensor without one\n"
                      "of its own, --channel NAME=FILE for sensor NAME (repeatable); a sensor with neither is lossless.",
                      {
                          {"model", "FILE", "model (YAML)", true, false},
                          {"channel", "[NAME=]FILE",
                           "sensor-to-estimator channel settings (YAML): every sensor, or sensor NAME", false, true},
                          {"estimator", "FILE", "estimator settings (YAML; default kfio)", false, false},
                          {"trace", "[NAME=]FILE",
                           "a recorded arrival pattern: a replay input CSV (every sensor), or NAME=FILE, a `rostopic "
                           "echo -p` of a LossyChannel's ~events for sensor NAME (repeatable): Gan and Liu's "
                           "excitation evidence, for any loss pattern",
                           false, true},
                          {"block", "H", "block length h of the excitation evidence (default n)", false, false},
                          {"json", "", "print JSON", false, false},
                          {"design", "COST",
                           "link design instead of analysis: the i.i.d. arrival rates that keep E[P] bounded at least "
                           "cost, COST = total_rate (sum of the rates) or capacity (sum of -ln(1 - rate)), with "
                           "|alpha|^2 Phi <= --growth-cap, and each sensor's least rate with the others lossless",
                           false, false},
                          {"growth-cap", "G", "--design: the margin, |alpha_k|^2 Phi_k <= G (default 0.9, in (0, 1))",
                           false, false},
                      });
  return cli::runTool(cl, argc, argv, [&]() -> int {
    const Model model = loadModel(cl.get("model"));
    const SensorLinks links = resolveSensorLinks(model, cl.getAll("channel"));
    EstimatorSettings est;
    const bool has_est = cl.has("estimator");
    if (has_est)
      est = loadEstimatorSettings(cl.get("estimator"));
    const int h = static_cast<int>(cl.getLong("block", model.n(), 1, 10000));
    const std::vector<TraceEvidence> traces = traceEvidence(model, cl.getAll("trace"), h);
    if (cl.has("design"))
      return printDesign(model, cl);
    if (cl.has("growth-cap"))
      throw cli::UsageError("--growth-cap is only for --design");
    const StabilityReport rep = analyzeStability(model, links.link, has_est ? &est : nullptr);
    if (cl.has("json"))
    {
      std::cout << json(rep, links, traces);
      return 0;
    }
    std::cout << "model " << rep.model_name << ": n = " << model.n() << ", " << model.sensors.size() << " sensor(s)\n";
    std::cout << "eigenvalues:";
    for (int i = 0; i < rep.eigenvalues.size(); ++i)
    {
      const auto& e = rep.eigenvalues[i];
      std::cout << " " << txt(e.real());
      if (e.imag() != 0.0)
        std::cout << (e.imag() > 0 ? "+" : "-") << txt(std::abs(e.imag())) << "i";
    }
    std::cout << "\nrho(A) = " << txt(rep.spectral_radius) << ", M(A) = " << txt(rep.mahler_measure)
              << ", diagonalizable: " << (rep.diagonalizable ? "yes" : "no") << "\n";
    std::cout << "strong observability: " << describe(rep.strong_observability) << "\n";
    if (model.schedule.active())
    {
      std::vector<std::string> names;
      for (const Sensor& sn : model.sensors)
        names.push_back(sn.name);
      std::cout << "schedule: " << model.schedule.describe(names)
                << " (verdicts by the cyclostationary Theorem 14; links advance every step)\n";
    }
    if (rep.has_channel)
    {
      std::cout << "links:\n";
      std::istringstream lines(links.describe());
      for (std::string line; std::getline(lines, line);)
        std::cout << "  " << line << "\n";
      if (rep.uniform_links)
        std::cout << "channel: arrival rate " << txt(rep.arrival_rate) << ", recovery rate " << txt(rep.recovery_rate)
                  << "\n";
      else
        for (const SensorLinkReport& l : rep.links)
          std::cout << "channel " << l.sensor << ": arrival rate " << txt(l.arrival_rate) << ", recovery rate "
                    << txt(l.recovery_rate) << "\n";
      std::cout << "capacity c = " << txt(rep.capacity.total) << " (c_lower = ln rho(A) = " << txt(rep.capacity.lower)
                << ", c_upper = h(A) = " << txt(rep.capacity.upper) << "): " << rep.capacity_note << "\n";
      std::cout << "MARE bound at these rates: " << rep.mare_at_rates << "\n";
    }
    std::cout << "estimator " << rep.estimator << ": " << rep.estimator_note << "\n";
    if (rep.estimator == "rseio")
      std::cout << "rseio: " << describe(rep.rseio) << "\n";
    printSet(std::cout, rep.model);
    if (rep.has_channel)
      printLinks(std::cout, rep);
    if (model.sensors.size() > 1)
      for (const RateAnalysis& r : rep.sensors)
        printSet(std::cout, r);
    if (!traces.empty())
    {
      std::cout << "Gan and Liu, from the recorded arrivals (any loss pattern; " << ExcitationReport::caveat() << "):\n";
      for (const TraceEvidence& e : traces)
      {
        std::cout << "  " << e.sensor << " (" << e.samples << " samples): ";
        if (!e.applicable)
        {
          std::cout << e.reason << "\n";
          continue;
        }
        const ExcitationReport& r = e.report;
        std::cout << "h = " << r.h << ", smallest block excitation " << txt(r.lambda_block) << ", lambda = "
                  << txt(r.lambda) << ", ||A|| = " << txt(r.norm_A) << "\n    A3 (printed / proof form):";
        for (const ExcitationA3& a : r.a3)
          std::cout << " p = " << a.p << ": " << txt(a.printed) << " / " << txt(a.proof) << (a.holds() ? " holds;" : " fails;");
        std::cout << "\n    verdict: " << describe(r.verdict) << "\n";
      }
    }
    return 0;
  });
}
