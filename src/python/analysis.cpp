// The Python module, part three: stability analysis and link design (docs/python.md). analyze() and
// design() return what `analyze --json` and `analyze --design --json` print, parsed.
#include <pybind11/stl.h>

#include <cmath>

#include "bindings.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/io/atomic_file.hpp"
#include "networked_estimation/link/link_fit.hpp"
#include "networked_estimation/link/link_report.hpp"
#include "networked_estimation/link/link_trace.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/stability/analysis_json.hpp"

namespace networked_estimation
{
namespace python
{
namespace
{

/// estimator=: None (kfio), an algorithm name, a dict of settings keys, or a settings file.
bool estimatorSettings(py::handle o, EstimatorSettings& out)
{
  if (o.is_none())
    return false;
  if (py::isinstance<py::dict>(o))
  {
    out = parseEstimatorSettings(toYaml(o, "analyze(): estimator"), "analyze(): estimator");
    return true;
  }
  std::string text;
  if (!asPath(o, text))
    throw py::type_error("analyze(): estimator: expected an algorithm name, a dict of settings or a settings file");
  std::string names;
  for (const char* name : {"kf", "kfio", "rseio", "aoe", "oe", "ack_kf", "ekfio"})
  {
    if (text == name)
    {
      YAML::Node node;
      node["algorithm"] = text;
      out = parseEstimatorSettings(node, "analyze(): estimator");
      return true;
    }
    names += (names.empty() ? "" : ", ") + std::string(name);
  }
  if (!isSettingsFile(text) && !py::hasattr(o, "__fspath__"))
    throw py::value_error("analyze(): estimator: '" + text + "' is neither an algorithm (" + names +
                          ") nor an estimator settings file (.yaml)");
  out = loadEstimatorSettings(text);
  return true;
}

/// analysedModel with the state `at` from Python (None: x0; the note says "at"); `fn` names the
/// function in the errors of a malformed `at`.
Model analysedAt(const Model& loaded, py::handle at, const std::string& fn, std::string& local_note)
{
  if (at.is_none())
    return analysedModel(loaded, nullptr, "at", local_note);
  const DoubleArray a = asArray(at, 1, fn + ": at");
  const Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(a.data(), a.shape(0));
  const std::string problem = linearisationStateProblem(loaded, x, loaded.period);
  if (!problem.empty())
    throw py::value_error(fn + ": at: " + problem);
  return analysedModel(loaded, &x, "at", local_note);
}

/// What analyze() and verdict() analyse: the model (a built-in motion linearised at `at`) and its
/// sensors' links; `fn` ("analyze()") names the function in errors.
struct Analysed
{
  Model model;
  std::string local_note;
  SensorLinks links;
};

Analysed analysed(py::handle model, py::handle at, py::handle links, const std::string& fn)
{
  const std::shared_ptr<Model> loaded = modelOf(model, fn + ": model");
  Analysed a;
  a.model = analysedAt(*loaded, at, fn, a.local_note);
  a.links = sensorLinks(a.model, links, fn + ": links");
  return a;
}

py::object analyze(py::handle loaded, py::handle links, py::handle estimator, py::handle at, py::handle traces,
                   int block)
{
  const Analysed an = analysed(loaded, at, links, "analyze()");
  const Model& model = an.model;
  const std::string& local_note = an.local_note;
  const SensorLinks& sl = an.links;
  EstimatorSettings est;
  const bool has_est = estimatorSettings(estimator, est);
  // traces: {sensor: arrivals (0/1 per step)}
  std::vector<std::vector<std::vector<bool>>> arrivals;
  std::vector<std::string> labels;
  if (!traces.is_none())
  {
    if (!py::isinstance<py::dict>(traces))
      throw py::type_error("analyze(): traces: expected a dict {sensor name: arrivals (0 or 1 per step)}");
    for (const auto& item : py::reinterpret_borrow<py::dict>(traces))
    {
      const std::string name = py::str(item.first).cast<std::string>();
      const std::string what = "analyze(): traces['" + name + "']";
      const std::size_t s = sensorIndex(model, name, "analyze(): traces");
      const DoubleArray a = asArray(item.second, 1, what);
      std::vector<std::vector<bool>> per(model.sensors.size());
      for (Py_ssize_t k = 0; k < a.shape(0); ++k)
      {
        const double v = a.data()[k];
        if (v != 0.0 && v != 1.0)
          throw py::value_error(what + "[" + std::to_string(k) + "]: expected 0 or 1, found " + std::to_string(v));
        per[s].push_back(v != 0.0);
      }
      arrivals.push_back(per);
      labels.push_back(what);
    }
  }
  if (block < 0)
    block = model.n();
  if (block < 1 || block > 10000)
    throw py::value_error("analyze(): block: expected 1 ... 10000, found " + std::to_string(block));
  std::vector<TraceEvidence> evidence;
  StabilityReport rep;
  {
    py::gil_scoped_release release;
    evidence = traceEvidence(model, arrivals, labels, block);
    rep = analyzeStability(model, sl.link, has_est ? &est : nullptr);
  }
  rep.estimator_note += local_note;
  return parseJson(analysisJson(rep, sl.origin, evidence));
}

py::object verdict(py::handle loaded, py::handle links, py::handle at)
{
  const Analysed an = analysed(loaded, at, links, "verdict()");
  VerdictReport rep;
  {
    py::gil_scoped_release release;
    rep = verdictOnly(an.model, an.links.link);
  }
  return parseJson(verdictJson(an.model.name, rep, an.links.origin));
}

py::object design(py::handle model_arg, const std::string& cost, double growth_cap, py::handle at)
{
  const std::shared_ptr<Model> loaded = modelOf(model_arg, "design(): model");
  if (cost != "total_rate" && cost != "capacity")
    throw py::value_error("design(): cost: expected 'total_rate' or 'capacity', found '" + cost + "'");
  if (!(growth_cap > 0.0 && growth_cap < 1.0))
    throw py::value_error("design(): growth_cap: expected a number in (0, 1), found " + std::to_string(growth_cap));
  std::string local_note;
  const Model model = analysedAt(*loaded, at, "design()", local_note);
  LinkDesign d;
  {
    py::gil_scoped_release release;
    d = designLinks(model, cost == "capacity" ? DesignCost::CAPACITY : DesignCost::TOTAL_RATE, growth_cap);
  }
  return parseJson(designJson(model, d, cost));
}

/// fit_link(): the tool's fit and JSON, one link (a topic name, csv, events) or a list (a list of topics).
py::object fitLink(py::handle bag, py::handle topic, py::handle csv, py::handle events, py::handle rate,
                   const std::string& clock, py::handle output, bool series, int starts, std::uint64_t seed)
{
  const std::string fn = "fit_link()";
  const int sources = (bag.is_none() ? 0 : 1) + (csv.is_none() ? 0 : 1) + (events.is_none() ? 0 : 1);
  if (sources != 1)
    throw py::value_error(fn + ": give exactly one of bag, csv and events (found " + std::to_string(sources) + ")");
  if (bag.is_none() != topic.is_none())
    throw py::value_error(fn + (bag.is_none() ? ": topic is for bag (a CSV or events file holds one link)"
                                              : ": bag needs topic (a topic name or a list of them)"));
  std::string path;
  if (!asPath(bag.is_none() ? (csv.is_none() ? events : csv) : bag, path))
    throw py::type_error(fn + ": " + (bag.is_none() ? (csv.is_none() ? "events" : "csv") : "bag") +
                         ": expected a file path");
  std::vector<std::string> topics;
  const bool one = topic.is_none() || py::isinstance<py::str>(topic);
  if (!topic.is_none())
  {
    if (py::isinstance<py::str>(topic))
      topics.push_back(topic.cast<std::string>());
    else if (py::isinstance<py::list>(topic) || py::isinstance<py::tuple>(topic))
      for (const auto& t : topic)
      {
        if (!py::isinstance<py::str>(t))
          throw py::type_error(fn + ": topic: expected a topic name or a list of them");
        topics.push_back(t.cast<std::string>());
      }
    else
      throw py::type_error(fn + ": topic: expected a topic name or a list of them");
    if (topics.empty())
      throw py::value_error(fn + ": topic: an empty list");
  }
  TraceOptions options;
  if (!rate.is_none())
  {
    options.rate = rate.cast<double>();
    if (!(options.rate > 0.0) || !std::isfinite(options.rate))
      throw py::value_error(fn + ": rate: expected a positive number of Hz, found " + std::to_string(options.rate));
    if (!events.is_none())
      throw py::value_error(fn + ": rate is not for events (one slot per event)");
  }
  options.clock = clockModeOf(clock, fn + ": clock");
  if (starts < 1 || starts > 1000)
    throw py::value_error(fn + ": starts: expected 1 ... 1000, found " + std::to_string(starts));
  std::string out;
  if (!output.is_none() && !asPath(output, out))
    throw py::type_error(fn + ": output: expected a file path");
  if (!out.empty() && topics.size() > 1)
    throw py::value_error(fn + ": output writes one link: give one topic");
  FitOptions fit_options;
  fit_options.ge_starts = starts;
  fit_options.seed = seed;
  std::string json;
  {
    py::gil_scoped_release release;
    std::vector<SlotTrace> traces;
    if (!events.is_none())
      traces.push_back(readEventSlots(path));
    else
    {
      const std::vector<LinkRecord> records =
          bag.is_none() ? std::vector<LinkRecord>{readLinkCsv(path)} : readBagLinks(path, topics);
      for (const LinkRecord& r : records)
        traces.push_back(analyseLink(r, options));
    }
    std::vector<LinkFit> fits;
    for (const SlotTrace& t : traces)
      fits.push_back(networked_estimation::fitLink(t, fit_options));
    if (!out.empty())
    {
      AtomicFile file(out);
      file.stream() << fittedChannelYaml(fits.front());
      file.commit();
    }
    json = linkFitsJson(fits, series);
  }
  py::object links = parseJson(json)["links"];
  return one ? py::object(links[py::int_(0)]) : links;
}

}  // namespace

void bindAnalysis(py::module& m)
{
  m.def("fit_link", &fitLink, py::arg("bag") = py::none(), py::arg("topic") = py::none(), py::arg("csv") = py::none(),
        py::arg("events") = py::none(), py::arg("rate") = py::none(), py::arg("clock") = "auto",
        py::arg("output") = py::none(), py::arg("series") = false, py::arg("starts") = 5, py::arg("seed") = 1,
        "The loss and delay models of a recorded link, as `fit_link --json` prints them (a dict; a list of "
        "them for a list of topics): from a ROS bag's topic (bag=, topic=), a trace CSV (csv=: stamp, receipt "
        "and optionally seq) or a LossyChannel's ~events (events=). rate: the expected rate in Hz (None: learnt); "
        "clock: 'auto', 'same' or 'different'; output: write the fitted channel file; series: add the slots "
        "(arrived, delay).");
  m.def("analyze", &analyze, py::arg("model"), py::arg("links") = py::none(), py::arg("estimator") = py::none(),
        py::arg("at") = py::none(), py::arg("traces") = py::none(), py::arg("block") = -1,
        "Stability analysis of `model` over its sensors' links, as `analyze --json` prints it (a dict): "
        "links as simulate()'s; estimator an algorithm name, a dict of settings or a settings file (None: "
        "kfio); at the state a built-in motion is linearised at (None: x0); traces {sensor: arrivals} for "
        "Gan and Liu's evidence in blocks of `block` steps (-1: n).");
  m.def("verdict", &verdict, py::arg("model"), py::arg("links") = py::none(), py::arg("at") = py::none(),
        "The verdict only, as `analyze --verdict-only --json` prints it (a dict): whether E[P] stays bounded "
        "('verdict'), the links' verdict on the observed modes ('links_verdict'), the dead-reckoned states and per "
        "sensor the rate it needs ('links'); the same numbers as analyze(), in a fraction of its time.");
  m.def("design", &design, py::arg("model"), py::arg("cost") = "total_rate", py::arg("growth_cap") = 0.9,
        py::arg("at") = py::none(),
        "Link design, as `analyze --design COST --json` prints it (a dict): the i.i.d. arrival rates that "
        "keep E[P] bounded at least cost ('total_rate' or 'capacity') with |alpha|^2 Phi <= growth_cap.");
}

}  // namespace python
}  // namespace networked_estimation
