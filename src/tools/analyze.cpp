// analyze: stability analysis of a model with a lossy link per sensor (stability.hpp, sensor_links.hpp);
// the reports are written by the core (analysis_text.hpp, analysis_json.hpp).
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
#include "networked_estimation/stability/analysis_text.hpp"
#include "networked_estimation/stability/excitation.hpp"
#include "networked_estimation/stability/link_design.hpp"
#include "networked_estimation/stability/stability.hpp"

using namespace networked_estimation;

namespace
{

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
  std::cout << designText(model, d, c);
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
  cli::CommandLine cl(
      "analyze",
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
          {"channel", "[NAME=]FILE", "sensor-to-estimator channel settings (YAML): every sensor, or sensor NAME", false,
           true},
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
          {"growth-cap", "G", "--design: the margin, |alpha_k|^2 Phi_k <= G (default 0.9, in (0, 1))", false, false},
          {"verdict-only", "",
           "only the verdict of all sensors, the links' verdict and the rate each sensor needs (the "
           "same numbers as the full analysis, in a fraction of its time)",
           false, false},
          {"bag", "FILE",
           "a recorded ROS bag: the links of --topic / --bag-topic are fitted from it (fit_link's fit) "
           "and the verdict is also taken at the ends of the fits' 95 % intervals",
           false, false},
          {"topic", "T", "--bag: every sensor without a link of its own gets topic T's fitted link", false, false},
          {"bag-topic", "SENSOR=TOPIC", "--bag: sensor SENSOR gets TOPIC's fitted link (repeatable)", false, true},
          {"at", "V1,...,Vn",
           "a model with a built-in motion: the state to linearise it at (default its x0); the "
           "verdicts are local",
           false, false},
      });
  return cli::runTool(
      cl, argc, argv,
      [&]() -> int
      {
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
              throw cli::UsageError(std::string("option '--") + o +
                                    "' is not for --verdict-only (run the full analysis)");
          const VerdictReport v = verdictOnly(model, links.link);
          if (cl.has("json"))
          {
            const std::string json = verdictJson(model.name, v, links.origin);
            std::cout << (measured.empty()
                              ? json
                              : withMember(json, "measured_links", measuredJson(measured, measured_verdict)));
            return 0;
          }
          std::cout << verdictText(model.name, local_note, v);
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
          std::cout << (measured.empty()
                            ? json
                            : withMember(json, "measured_links", measuredJson(measured, measured_verdict)));
          return 0;
        }
        std::cout << analysisText(model, rep, links, traces);
        if (!measured.empty())
          std::cout << measuredText(measured, measured_verdict);
        return 0;
      });
}
