// analyze: stability analysis of a model with a lossy link per sensor (stability.hpp, sensor_links.hpp).
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "cli.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/sensor_links.hpp"
#include "networked_estimation/io/arrival_trace.hpp"
#include "networked_estimation/link/measured_links.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/stability/analysis_json.hpp"
#include "networked_estimation/stability/excitation.hpp"
#include "networked_estimation/stability/link_design.hpp"
#include "networked_estimation/stability/stability.hpp"

using namespace networked_estimation;

namespace
{

std::string txt(double v)
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
std::string rate(double v)
{
  return unboundedAtEveryRate(v) ? "none (unbounded at every rate)" : txt(v);
}

std::string intervals(const std::vector<RateInterval>& v)
{
  std::string out;
  for (const RateInterval& in : v)
    out += (out.empty() ? "" : ", ") + std::string("[") + txt(in.lower) + ", " + txt(in.upper) + "]";
  return out.empty() ? "none" : out;
}

void printSet(std::ostream& os, const RateAnalysis& r, const std::string& in = "  ")
{
  if (in == "  ")
    os << "[" << r.name << "]\n";
  os << in << "lower bound (necessary)         " << rate(r.lower_bound) << "\n";
  if (!r.mare_note.empty())
    os << in << "MARE upper bound                " << r.mare_note << "\n";
  else
    os << in << "MARE upper bound                diverges at " << rate(r.mare.diverges_at) << ", converges at "
       << rate(r.mare.converges_at) << (r.mare.undecided_band ? " (undecided band between)" : "") << "\n";
  os << in << "closed-form upper bound         " << rate(r.closed_form_upper) << "\n";
  os << in << "exact critical arrival rate     " << rate(r.exact_rate) << "  (" << r.exact_method << ")\n";
  os << in << "Markov: critical recovery rate  ";
  if (!r.recovery_stable.empty())
    os << "none (not a half-line): stable for r in " << intervals(r.recovery_stable);
  else
    os << rate(r.recovery_exact);
  os << " (necessary " << rate(r.recovery_lower_bound) << "; " << r.recovery_note << ")\n";
  os << in << "Lin et al.'s Theorem 5          " << describe(r.aoe_theorem5) << "\n";
  os << in << "verdict                         " << describe(r.verdict) << "\n";
  if (!r.observed.empty())
    os << in << "links' verdict                  " << describe(r.links_verdict) << "\n";
  if (r.margin_quantity.rfind("per-sensor", 0) == 0)
    os << in << "margin                          per sensor, the other links fixed: see [per-sensor links]\n";
  else if (!r.stable_intervals.empty())
    os << in << "margin                          " << r.margin_quantity << " " << txt(r.channel_value)
       << ", stable for " << intervals(r.stable_intervals) << ": distance to the nearest edge " << txt(r.margin)
       << (r.margin > 0 ? " (inside)" : " (outside)") << "\n";
  else if (unboundedAtEveryRate(r.sufficient_threshold))
    os << in << "margin                          none: no " << r.margin_quantity << " keeps E[P] bounded\n";
  else
    os << in << "margin                          " << r.margin_quantity << " " << txt(r.channel_value)
       << " - critical " << txt(r.sufficient_threshold) << " = " << txt(r.margin) << "\n";
  if (!r.observed.empty())
  {
    os << in << "observed modes only (what the links can change; " << growRegardless(r.dead_states) << "):\n";
    printSet(os, r.observed.front(), in + "  ");
  }
}

void printLinks(std::ostream& os, const std::vector<SensorLinkReport>& links)
{
  os << "[per-sensor links: the rate each sensor needs, the other sensors' links fixed]\n";
  for (const SensorLinkReport& l : links)
  {
    const SensorMargin& m = l.margin;
    os << "  " << l.sensor << ": ";
    if (m.quantity.empty())
      os << m.note << "\n";
    else if (!m.half_line)
      os << m.quantity << " " << txt(m.value) << ", stable for " << intervals(m.stable) << ", distance to the nearest edge "
         << txt(m.margin) << "\n    (" << m.note << ")\n";
    else if (!m.grows_regardless.empty())
      os << m.quantity << " " << txt(m.value) << ", needs: none (" << growRegardless(m.grows_regardless)
         << "); the observed modes alone need " << rate(m.converges_at_observed)
         << "\n    (" << m.note << ")\n";
    else if (std::isnan(m.band.converges_at))
      os << m.quantity << " " << txt(m.value) << ", no stable rate: " << m.note << "\n";
    else if (m.any_positive)
      os << m.quantity << " " << txt(m.value) << ", needs > 0 (any positive rate; unbounded at 0), margin "
         << txt(m.margin) << "\n    (" << m.note << ")\n";
    else if (m.band.converges_at == 0.0)
      os << m.quantity << " " << txt(m.value) << ", needs 0 (bounded even without it), margin " << txt(m.margin)
         << "\n    (" << m.note << ")\n";
    else
      os << m.quantity << " " << txt(m.value) << ", needs " << rate(m.band.converges_at) << " (diverges at "
         << rate(m.band.diverges_at) << ", converges at " << rate(m.band.converges_at)
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
  if (cl.has("json"))
  {
    std::cout << designJson(model, d, c);
    return 0;
  }
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
    std::cout << "    " << model.sensors[j].name << ": arrival rate " << rate(d.rates[j])
              << " (alone, the others lossless: " << rate(d.alone[j]) << ")\n";
  std::cout << "  For a Gilbert-Elliott link give it with --channel NAME=FILE (without --design): the per-sensor\n"
               "  margins then give the least recovery rate at its failure rate p, the other links fixed.\n";
  return 0;
}

}  // namespace

namespace
{

/// "1,2.5,-3" -> {1, 2.5, -3}; UsageError naming `what` and the entry otherwise.
std::vector<double> numberList(const std::string& text, const std::string& what)
{
  std::vector<double> out;
  std::stringstream in(text);
  std::string cell;
  while (std::getline(in, cell, ','))
  {
    char* end = nullptr;
    const double v = std::strtod(cell.c_str(), &end);
    if (cell.empty() || end != cell.c_str() + cell.size() || !std::isfinite(v))
      throw cli::UsageError(what + ": entry " + std::to_string(out.size()) + ": expected a finite number, found '" +
                            cell + "'");
    out.push_back(v);
  }
  return out;
}

/// A JSON object's text with one more member at its end.
std::string withMember(const std::string& object, const std::string& key, const std::string& value)
{
  std::string head = object.substr(0, object.find_last_of('}'));
  while (!head.empty() && (head.back() == '\n' || head.back() == ' '))
    head.pop_back();
  return head + ",\n  \"" + key + "\": " + value + "\n}\n";
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
                      "of its own, --channel NAME=FILE for sensor NAME (repeatable); a sensor with neither is lossless.\n"
                      "The link a robot has: --bag FILE --topic T (or --bag-topic SENSOR=TOPIC) fits it from a recorded\n"
                      "bag (as fit_link does) and gives the verdict at the fit and at the ends of its 95 % intervals.",
                      {
                          {"model", "FILE", "model (YAML)", true, false},
                          {"channel", "[NAME=]FILE",
                           "sensor-to-estimator channel settings (YAML): every sensor, or sensor NAME", false, true},
                          {"estimator", "FILE", "estimator settings (YAML) or an algorithm name (default kfio)", false, false},
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
                          {"verdict-only", "",
                           "only the verdict of all sensors, the links' verdict and the rate each sensor needs (the "
                           "same numbers as the full analysis, in a fraction of its time)",
                           false, false},
                          {"bag", "FILE",
                           "a recorded ROS bag: the links of --topic / --bag-topic are fitted from it (fit_link's fit) "
                           "and the verdict is also taken at the ends of the fits' 95 % intervals",
                           false, false},
                          {"topic", "T", "--bag: every sensor without a link of its own gets topic T's fitted link",
                           false, false},
                          {"bag-topic", "SENSOR=TOPIC", "--bag: sensor SENSOR gets TOPIC's fitted link (repeatable)",
                           false, true},
                          {"at", "V1,...,Vn",
                           "a model with a built-in motion: the state to linearise it at (default its x0); the "
                           "verdicts are local",
                           false, false},
                      });
  return cli::runTool(cl, argc, argv, [&]() -> int {
    const Model loaded = loadModel(cl.get("model"));
    // A built-in motion: the verdicts of its linearisation at one state (a local verdict)
    Eigen::VectorXd at;
    if (cl.has("at"))
    {
      if (!loaded.nonlinear())
        throw cli::UsageError("option '--at' is only for a model with a built-in motion (model '" + loaded.name +
                              "' is linear)");
      const std::vector<double> v = numberList(cl.get("at"), "option '--at'");
      at = Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
      const std::string problem = linearisationStateProblem(loaded, at, loaded.period);
      if (!problem.empty())
        throw cli::UsageError("option '--at': " + problem);
    }
    std::string local_note;
    const Model model = analysedModel(loaded, cl.has("at") ? &at : nullptr, "--at", local_note);
    if (cl.has("design"))
    {
      for (const char* o : {"channel", "estimator", "trace", "block", "verdict-only", "bag", "topic", "bag-topic"})
        if (cl.has(o))
          throw cli::UsageError(std::string("option '--") + o +
                                "' is not for --design (the design chooses i.i.d. links for every sensor: analyze "
                                "the links it gives without --design)");
      return printDesign(model, cl);
    }
    if (cl.has("growth-cap"))
      throw cli::UsageError("--growth-cap is only for --design");
    SensorLinks links = resolveSensorLinks(model, cl.getAll("channel"));
    // Measured links: fitted from the bag, in place of typed channel files.
    std::vector<MeasuredLink> measured;
    if (cl.has("bag"))
      measured = fitBagLinks(model, cl.get("bag"), cl.get("topic"), cl.getAll("bag-topic"), links);
    else if (cl.has("topic") || cl.has("bag-topic"))
      throw cli::UsageError(std::string("option '--") + (cl.has("topic") ? "topic" : "bag-topic") +
                            "' is for --bag (the bag whose topics give the links)");
    const MeasuredVerdict measured_verdict =
        measured.empty() ? MeasuredVerdict() : measuredVerdict(model, links, measured);
    if (cl.has("verdict-only"))
    {
      for (const char* o : {"estimator", "trace", "block"})
        if (cl.has(o))
          throw cli::UsageError(std::string("option '--") + o + "' is not for --verdict-only (run the full analysis)");
      const VerdictReport v = verdictOnly(model, links.link);
      if (cl.has("json"))
      {
        const std::string json = verdictJson(model.name, v, links.origin);
        std::cout << (measured.empty() ? json
                                       : withMember(json, "measured_links", measuredJson(measured, measured_verdict)));
        return 0;
      }
      std::cout << "model " << model.name << local_note << "\n";
      if (!v.dead_reckoned.empty())
        std::cout << "dead-reckoned: " << v.dead_reckoned << "\n";
      std::cout << "verdict: " << describe(v.verdict) << "\n";
      std::cout << "links' verdict: " << describe(v.links_verdict) << "\n";
      if (v.has_channel)
        printLinks(std::cout, v.links);
      if (!measured.empty())
        std::cout << measuredText(measured, measured_verdict);
      return 0;
    }
    EstimatorSettings est;
    const bool has_est = cl.has("estimator");
    if (has_est)
      est = estimatorSettingsArgument(cl.get("estimator"));
    const int h = static_cast<int>(cl.getLong("block", model.n(), 1, 10000));
    std::vector<std::vector<std::vector<bool>>> arrivals;
    std::vector<std::string> labels;
    for (const std::string& spec : cl.getAll("trace"))
    {
      arrivals.push_back(readArrivalTrace(spec, model).arrivals);
      labels.push_back("--trace " + spec);
    }
    std::vector<TraceEvidence> traces;
    try
    {
      traces = traceEvidence(model, arrivals, labels, h);
    }
    catch (const InputError& e)
    {
      throw cli::UsageError(std::string("option '--trace': ") + e.what());
    }
    StabilityReport rep = analyzeStability(model, links.link, has_est ? &est : nullptr);
    rep.estimator_note += local_note;
    if (cl.has("json"))
    {
      const std::string json = analysisJson(rep, links.origin, traces);
      std::cout << (measured.empty() ? json
                                     : withMember(json, "measured_links", measuredJson(measured, measured_verdict)));
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
    if (!rep.dead_reckoned.empty())
      std::cout << "dead-reckoned: " << rep.dead_reckoned
                << " (no rate keeps E[P] bounded: the verdict is unstable; the links' verdict and the 'observed "
                   "modes only' lines concern what the links can change)\n";
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
      printLinks(std::cout, rep.links);
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
    if (!measured.empty())
      std::cout << measuredText(measured, measured_verdict);
    return 0;
  });
}
