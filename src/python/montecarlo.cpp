// The Python module, part four: Monte Carlo experiments, their shards and the merge
// (docs/python.md); each run without the GIL, a Python progress callback called as blocks finish.
#include <pybind11/stl.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <sstream>
#include <limits>
#include <functional>

#include "bindings.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/config/model_writer.hpp"
#include "networked_estimation/experiments/montecarlo.hpp"
#include "networked_estimation/experiments/montecarlo_shards.hpp"
#include "networked_estimation/experiments/sweep.hpp"

namespace networked_estimation
{
namespace python
{
namespace
{

/// A settings entry: an algorithm name or a settings file (as the tool's --settings), or a dict of
/// settings keys given as text (its label: the dict's "name", else its algorithm, made distinct).
void addSettings(py::handle o, MonteCarloConfig& cfg)
{
  std::string one;
  if (asPath(o, one))
  {
    cfg.settings_paths.push_back(one);
    return;
  }
  if (!py::isinstance<py::dict>(o))
    throw py::type_error(
        "montecarlo(): settings: expected an algorithm name, a settings file, a dict of settings "
        "or a list of them, found " +
        std::string(Py_TYPE(o.ptr())->tp_name));
  py::dict d = py::reinterpret_borrow<py::dict>(o).attr("copy")();
  std::string label;
  if (d.contains("name"))
  {
    label = py::str(d["name"]).cast<std::string>();
    PyDict_DelItemString(d.ptr(), "name");
  }
  const YAML::Node node = toYaml(d, "montecarlo(): settings");
  parseEstimatorSettings(node, "montecarlo(): settings");  // its own errors, naming the key
  if (label.empty())
  {
    label = node["algorithm"] ? node["algorithm"].as<std::string>() : "kfio";
    const std::string base = label;
    for (int i = 2; cfg.inline_inputs.count(label) ||
                    std::find(cfg.settings_paths.begin(), cfg.settings_paths.end(), label) != cfg.settings_paths.end();
         ++i)
      label = base + "_" + std::to_string(i);
  }
  YAML::Emitter e;
  e << node;
  cfg.inline_inputs[label] = std::string(e.c_str()) + "\n";
  cfg.settings_paths.push_back(label);
}

/// A channel argument's FILE: a file path, or a Link given as text (labelled "<Link K: ...>").
std::string channelFile(py::handle o, MonteCarloConfig& cfg, const std::string& what)
{
  std::string path;
  if (asPath(o, path))
    return path;
  const ChannelSettings link = linkOf(o, what);
  YAML::Emitter e;
  e << toYaml(link);
  const std::string text = std::string(e.c_str()) + "\n";
  for (const auto& kv : cfg.inline_inputs)
    if (kv.second == text && kv.first.compare(0, 6, "<Link ") == 0)
      return kv.first;  // the same link twice: one text
  int links = 0;
  for (const auto& kv : cfg.inline_inputs)
    links += kv.first.compare(0, 6, "<Link ") == 0 ? 1 : 0;
  // No '=' in the label: the core splits a --channel argument NAME=FILE at its first '=', and one Link
  // for every sensor has no NAME.
  std::string described = describeLink(link);
  std::replace(described.begin(), described.end(), '=', ' ');
  const std::string label = "<Link " + std::to_string(links + 1) + ": " + described + ">";
  cfg.inline_inputs[label] = text;
  return label;
}

/// channels=: a file or a Link (every sensor), {sensor: file or Link, '*': file or Link} or a list of the
/// tool's --channel arguments ("FILE", "NAME=FILE").
std::vector<std::string> channelArgs(py::handle o, MonteCarloConfig& cfg)
{
  std::vector<std::string> out;
  if (o.is_none())
    return out;
  if (py::isinstance<py::dict>(o))
  {
    for (const auto& item : py::reinterpret_borrow<py::dict>(o))
    {
      const std::string key = item.first.is_none() ? "*" : py::str(item.first).cast<std::string>();
      const std::string file = channelFile(item.second, cfg, "montecarlo(): channels['" + key + "']");
      out.push_back(key == "*" ? file : key + "=" + file);
    }
    return out;
  }
  if (py::isinstance<py::list>(o) || py::isinstance<py::tuple>(o))
  {
    for (const auto& item : o)
    {
      std::string arg;
      if (!asPath(item, arg))
        throw py::type_error(
            "montecarlo(): channels: a list holds the tool's --channel arguments (\"FILE\", "
            "\"NAME=FILE\"); give Link objects as {sensor: Link} or one Link for every sensor");
      out.push_back(arg);
    }
    return out;
  }
  out.push_back(channelFile(o, cfg, "montecarlo(): channels"));
  return out;
}

/// A Python progress callback called from the worker threads (with the GIL); its first exception
/// is kept and raised when the run ends.
struct Progress
{
  py::object callback;
  std::exception_ptr error;

  void operator()(long done, long total)
  {
    py::gil_scoped_acquire gil;
    if (error)
      return;
    try
    {
      callback(done, total);
    }
    catch (...)
    {
      error = std::current_exception();
    }
  }
};

MonteCarloConfig config(const std::string& experiment, long runs, long steps, std::uint64_t seed, int threads,
                        py::handle model, py::handle channels, py::handle actuator_channel, py::handle settings,
                        py::handle axes, bool covariance_only, py::handle thresholds)
{
  MonteCarloConfig cfg;
  if (!thresholds.is_none())
  {
    try
    {
      cfg.thresholds = thresholds.cast<std::vector<double>>();
    }
    catch (const py::cast_error&)
    {
      throw py::type_error("montecarlo(): thresholds: expected a list of numbers");
    }
  }
  try
  {
    checkExperimentName(experiment);
  }
  catch (const ConfigError& e)
  {
    throw ConfigError(std::string("montecarlo(): experiment: ") + e.what());
  }
  cfg.experiment = experiment;
  try
  {
    canonicalConfig(cfg);  // the thresholds
  }
  catch (const ConfigError& e)
  {
    throw ConfigError(std::string("montecarlo(): thresholds: ") + e.what());
  }
  if (runs < 0 || steps < 0 || threads < 0)
    throw py::value_error("montecarlo(): runs, steps and threads: expected >= 0 (0: the default), found " +
                          std::to_string(runs) + ", " + std::to_string(steps) + ", " + std::to_string(threads));
  cfg.runs = runs;
  cfg.steps = steps;
  cfg.seed = seed;
  cfg.threads = threads;
  const bool sweep = experiment == "sweep", custom = takesCustomInputs(experiment);
  const std::pair<const char*, py::handle> custom_only[] = {
      {"model", model}, {"channels", channels}, {"actuator_channel", actuator_channel}, {"settings", settings}};
  for (const auto& kv : custom_only)
    if (!custom && !kv.second.is_none())
      throw py::value_error(std::string("montecarlo(): ") + kv.first +
                            " is only for the experiments custom, covariance and sweep");
  if (!custom && covariance_only)
    throw py::value_error("montecarlo(): covariance_only is only for the experiments custom, covariance and sweep");
  cfg.covariance_only = covariance_only;
  if (!sweep && !axes.is_none())
    throw py::value_error("montecarlo(): axes is only for the experiment sweep");
  if (!custom)
    return cfg;
  if (model.is_none() || settings.is_none())
    throw py::value_error("montecarlo(): experiment " + experiment + " needs model= and settings=");
  // Objects go in as their canonical text, which the shards hash and carry (MonteCarloConfig::inline_inputs).
  if (!asPath(model, cfg.model_path))
  {
    const std::shared_ptr<Model> m = modelOf(model, "montecarlo(): model");
    std::ostringstream os;
    writeModelYaml(os, *m, "montecarlo() model");
    cfg.model_path = "<Model '" + m->name + "'>";
    cfg.inline_inputs[cfg.model_path] = os.str();
  }
  cfg.channel_args = channelArgs(channels, cfg);
  if (!actuator_channel.is_none() && !asPath(actuator_channel, cfg.actuator_channel_path))
    throw py::type_error("montecarlo(): actuator_channel: expected a channel file");
  if (py::isinstance<py::list>(settings) || py::isinstance<py::tuple>(settings))
    for (const auto& item : settings)
      addSettings(item, cfg);
  else
    addSettings(settings, cfg);
  if (cfg.settings_paths.empty())
    throw py::value_error("montecarlo(): settings: expected one or more estimators");
  if (sweep)
  {
    if (axes.is_none())
      throw py::value_error("montecarlo(): experiment sweep needs axes=['NAME=LO:HI:N', ...] (one or two)");
    if (py::isinstance<py::str>(axes))
      cfg.axis_args = {axes.cast<std::string>()};
    else
      cfg.axis_args = axes.cast<std::vector<std::string>>();
    if (cfg.axis_args.empty() || cfg.axis_args.size() > 2)
      throw py::value_error("montecarlo(): axes: expected one or two axes, found " +
                            std::to_string(cfg.axis_args.size()));
  }
  return cfg;
}

py::array_t<double> array(const std::vector<double>& v, std::size_t size)
{
  if (v.size() == size)
    return py::array_t<double>(static_cast<Py_ssize_t>(v.size()), v.data());
  const std::vector<double> nan(size, std::numeric_limits<double>::quiet_NaN());  // not computed
  return py::array_t<double>(static_cast<Py_ssize_t>(size), nan.data());
}

py::dict caseDict(const CaseResult& c, const std::vector<double>& thresholds)
{
  py::dict d;
  d["name"] = c.name;
  d["title"] = c.title;
  d["x"] = py::array_t<double>(static_cast<Py_ssize_t>(c.x.size()), c.x.data());
  py::dict series;
  for (const SeriesResult& s : c.series)
  {
    py::dict e;
    const std::size_t nx = s.mean.size();
    e["mean"] = py::array_t<double>(static_cast<Py_ssize_t>(s.mean.size()), s.mean.data());
    e["sd"] = py::array_t<double>(static_cast<Py_ssize_t>(s.sd.size()), s.sd.data());
    e["n"] = s.n;
    std::vector<double> se;
    for (double sd : s.sd)
      se.push_back(s.n > 0 ? sd / std::sqrt(static_cast<double>(s.n)) : std::nan(""));
    e["se"] = array(se, nx);
    e["p5"] = array(s.p5, nx);
    e["p25"] = array(s.p25, nx);
    e["median"] = array(s.median, nx);
    e["p75"] = array(s.p75, nx);
    e["p95"] = array(s.p95, nx);
    py::dict tail;
    for (std::size_t t = 0; t < thresholds.size(); ++t)
      tail[py::float_(thresholds[t])] = array(t < s.exceed.size() ? s.exceed[t] : std::vector<double>(), nx);
    e["tail"] = tail;
    e["window"] = py::make_tuple(s.window0, s.window1);
    e["time_average"] = s.time_average;
    e["time_average_se"] = s.n > 0 ? s.time_average_sd / std::sqrt(static_cast<double>(s.n)) : std::nan("");
    e["final_value"] = s.final_value;
    const double half = s.n > 0 ? 1.96 * s.growth_sd / std::sqrt(static_cast<double>(s.n)) : std::nan("");
    e["growth"] = std::isfinite(s.growth) ? py::object(py::make_tuple(s.growth, s.growth - half, s.growth + half))
                                          : py::object(py::none());
    e["mean_estimable"] = s.mean_estimable;
    e["mean_note"] = s.mean_note;
    e["bound"] = s.bound;
    series[py::str(s.name)] = e;
  }
  d["series"] = series;
  return d;
}

/// Runs body(progress counter or nullptr) without the GIL, the Python callback `progress` (or None)
/// called as blocks finish; its first exception is raised after the run.
template <class T>
std::shared_ptr<T> runWithProgress(const std::function<T(ProgressCounter*)>& body, py::handle progress)
{
  Progress p;
  std::unique_ptr<ProgressCounter> counter;
  if (!progress.is_none())
  {
    p.callback = py::reinterpret_borrow<py::object>(progress);
    counter.reset(new ProgressCounter([&p](long done, long total) { p(done, total); }));
  }
  std::shared_ptr<T> result;
  {
    py::gil_scoped_release release;
    result = std::make_shared<T>(body(counter.get()));
  }
  if (p.error)
    std::rethrow_exception(p.error);
  return result;
}

/// A sweep's grid as arrays: the axes, the points' values (P x axes), per estimator the cells'
/// statistics (P values each), the verdicts; None for another experiment.
py::object sweepDict(const ExperimentResult& r)
{
  if (!r.sweep)
    return py::none();
  const SweepResult& sw = *r.sweep;
  const Py_ssize_t P = sw.points, A = static_cast<Py_ssize_t>(sw.axes.size());
  py::dict d;
  std::vector<std::string> axes;
  for (const SweepAxis& a : sw.axes)
    axes.push_back(a.name());
  d["axes"] = axes;
  py::array_t<double> values({P, A});
  for (Py_ssize_t i = 0; i < P; ++i)
    for (Py_ssize_t j = 0; j < A; ++j)
      values.mutable_data()[i * A + j] = sw.point_values[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
  d["values"] = values;
  d["verdicts"] = sw.analysis.verdicts;
  const std::pair<const char*, double SweepCell::*> stats[] = {{"trP_mean", &SweepCell::trP_mean},
                                                               {"trP_sd", &SweepCell::trP_sd},
                                                               {"err_mean", &SweepCell::err_mean},
                                                               {"err_sd", &SweepCell::err_sd},
                                                               {"trP_avg_mean", &SweepCell::trP_avg_mean},
                                                               {"trP_avg_sd", &SweepCell::trP_avg_sd},
                                                               {"err_avg_mean", &SweepCell::err_avg_mean},
                                                               {"err_avg_sd", &SweepCell::err_avg_sd},
                                                               {"trP_p5", &SweepCell::trP_p5},
                                                               {"trP_p25", &SweepCell::trP_p25},
                                                               {"trP_median", &SweepCell::trP_median},
                                                               {"trP_p75", &SweepCell::trP_p75},
                                                               {"trP_p95", &SweepCell::trP_p95},
                                                               {"err_median", &SweepCell::err_median},
                                                               {"growth", &SweepCell::growth},
                                                               {"growth_sd", &SweepCell::growth_sd}};
  const std::pair<const char*, long SweepCell::*> counts[] = {
      {"n", &SweepCell::n}, {"diverged", &SweepCell::diverged}, {"floored", &SweepCell::floored}};
  const std::size_t E = sw.estimators.size();
  py::dict estimators;
  for (std::size_t j = 0; j < E; ++j)
  {
    py::dict e;
    for (const auto& st : stats)
    {
      py::array_t<double> a({P});
      for (Py_ssize_t i = 0; i < P; ++i)
        a.mutable_data()[i] = sw.cells[static_cast<std::size_t>(i) * E + j].*(st.second);
      e[st.first] = a;
    }
    for (const auto& c : counts)
    {
      py::array_t<long long> a({P});
      for (Py_ssize_t i = 0; i < P; ++i)
        a.mutable_data()[i] = sw.cells[static_cast<std::size_t>(i) * E + j].*(c.second);
      e[c.first] = a;
    }
    py::dict tail;
    for (std::size_t t = 0; t < sw.thresholds.size(); ++t)
    {
      py::array_t<double> a({P});
      for (Py_ssize_t i = 0; i < P; ++i)
      {
        const SweepCell& cell = sw.cells[static_cast<std::size_t>(i) * E + j];
        a.mutable_data()[i] = t < cell.trP_exceed.size() ? cell.trP_exceed[t] : std::nan("");
      }
      tail[py::float_(sw.thresholds[t])] = a;
    }
    e["trP_tail"] = tail;
    estimators[py::str(sw.estimators[j])] = e;
  }
  d["estimators"] = estimators;
  return d;
}

/// How a shard held in memory (not read from a file) is named in the merge's messages.
std::string memoryLabel(const ShardFile& s)
{
  return "<Shard " + std::to_string(s.shard) + " of " + std::to_string(s.shards) + " of " + s.config.experiment + ">";
}

}  // namespace

void bindMonteCarlo(py::module& m)
{
  py::class_<ExperimentResult, std::shared_ptr<ExperimentResult>>(m, "MonteCarloResult", R"doc(
The result of montecarlo() or merge(): the montecarlo tool's outputs in memory. `cases` holds one dict
per case: name, title, x and per series (by name) mean, sd, n, se, p5, p25, median, p75, p95, tail
{M: P(value > M)}, window, time_average, time_average_se, final_value, growth (rate, low, high) or None,
mean_estimable, mean_note, bound.)doc")
      .def_readonly("thresholds", &ExperimentResult::thresholds)
      .def_readonly("experiment", &ExperimentResult::experiment)
      .def_readonly("runs", &ExperimentResult::runs)
      .def_readonly("steps", &ExperimentResult::steps)
      .def_readonly("seed", &ExperimentResult::seed)
      .def_readonly("threads", &ExperimentResult::threads)
      .def_readonly("wall_seconds", &ExperimentResult::wall_seconds)
      .def_readonly("x_label", &ExperimentResult::x_label)
      .def_readonly("y_label", &ExperimentResult::y_label)
      .def_readonly("log_x", &ExperimentResult::log_x)
      .def_readonly("log_y", &ExperimentResult::log_y)
      .def_readonly("assumptions", &ExperimentResult::assumptions)
      .def_readonly("notes", &ExperimentResult::notes)
      .def_property_readonly("cases",
                             [](const ExperimentResult& r)
                             {
                               py::list out;
                               for (const CaseResult& c : r.cases)
                                 out.append(caseDict(c, r.thresholds));
                               return out;
                             })
      .def(
          "case",
          [](const ExperimentResult& r, const std::string& name)
          {
            std::string names;
            for (const CaseResult& c : r.cases)
            {
              if (c.name == name)
                return caseDict(c, r.thresholds);
              names += (names.empty() ? "" : ", ") + c.name;
            }
            throw py::key_error("case '" + name + "' is not a case of " + r.experiment + " (cases: " + names + ")");
          },
          py::arg("name"))
      .def_property_readonly(
          "samples",
          [](const ExperimentResult& r)
          {
            py::dict out;
            const Py_ssize_t cols = static_cast<Py_ssize_t>(r.sample_columns.size());
            for (const SampleSet& s : r.samples)
            {
              const Py_ssize_t rows = cols ? static_cast<Py_ssize_t>(s.values.size()) / cols : 0;
              out[py::str(s.case_name)] = py::array_t<double>({rows, cols}, s.values.data());
            }
            return out;
          },
          "per case, the per-run values (runs x sample_columns), e.g. zhou_fig2's P_{T|T}")
      .def_readonly("sample_columns", &ExperimentResult::sample_columns)
      .def_property_readonly("sweep", &sweepDict,
                             "the sweep experiment's grid (None for the others): axes (names), values (points x "
                             "axes), verdicts (one per point), estimators {name: {trP_mean, trP_sd, err_mean, "
                             "err_sd, trP_avg_mean, trP_avg_sd, err_avg_mean, err_avg_sd, trP_p5, trP_p25, "
                             "trP_median, trP_p75, trP_p95, err_median, growth, growth_sd, n, diverged, floored, "
                             "trP_tail {M: P(tr P_T > M)}}}, each an array over the points (sweep.csv's rows)")
      .def(
          "csv", [](const ExperimentResult& r) { return experimentCsv(r); }, "NAME.csv's text")
      .def(
          "json", [](const ExperimentResult& r) { return experimentJson(r); }, "NAME.json's text")
      .def(
          "to_dict", [](const ExperimentResult& r) { return parseJson(experimentJson(r)); },
          "NAME.json parsed (with a sweep's grid, verdicts and critical curve)")
      .def(
          "write",
          [](const ExperimentResult& r, py::handle dir)
          {
            std::string d;
            if (!asPath(dir, d))
              throw py::type_error("write(): expected a directory path");
            writeExperiment(r, d);
          },
          py::arg("dir"), "Writes DIR/NAME.csv, .json (and _samples.csv) as the tool does.")
      .def("__repr__",
           [](const ExperimentResult& r)
           {
             return "<networked_estimation.MonteCarloResult " + r.experiment + ": " + std::to_string(r.runs) +
                    " runs x " + std::to_string(r.steps) + " steps, " + std::to_string(r.cases.size()) + " case(s)>";
           });

  py::class_<ShardFile, std::shared_ptr<ShardFile>>(m, "Shard", R"doc(
One shard of a Monte Carlo experiment (montecarlo(..., shard=(k, n))): picklable (it travels as the
shard file's JSON), json() is the file's text, write(dir) writes it as the tool does; merge() takes
them all.)doc")
      .def_property_readonly("experiment", [](const ShardFile& s) { return s.config.experiment; })
      .def_readonly("index", &ShardFile::shard)
      .def_readonly("count", &ShardFile::shards)
      .def_readonly("threads", &ShardFile::threads)
      .def_readonly("wall_seconds", &ShardFile::wall_seconds)
      .def("json", [](const ShardFile& s) { return shardJson(s); })
      .def(
          "write",
          [](const ShardFile& s, py::handle dir)
          {
            std::string d;
            if (!asPath(dir, d))
              throw py::type_error("write(): expected a directory path");
            return writeShard(s, d);
          },
          py::arg("dir"), "Writes DIR/NAME.shard-K-of-N.json; returns its path.")
      .def(py::pickle([](const ShardFile& s) { return shardJson(s); },
                      [](const std::string& text)
                      {
                        auto s = std::make_shared<ShardFile>(parseShard(text, "a pickled Shard"));
                        s->path = memoryLabel(*s);
                        return s;
                      }))
      .def("__repr__",
           [](const ShardFile& s)
           {
             return "<networked_estimation.Shard " + s.config.experiment + " " + std::to_string(s.shard) + " of " +
                    std::to_string(s.shards) + ">";
           });

  m.def(
      "montecarlo",
      [](const std::string& experiment, long runs, long steps, std::uint64_t seed, int threads, py::handle model,
         py::handle channels, py::handle actuator_channel, py::handle settings, py::handle axes, py::handle progress,
         py::handle shard, bool covariance_only, py::handle thresholds) -> py::object
      {
        const MonteCarloConfig cfg = config(experiment, runs, steps, seed, threads, model, channels, actuator_channel,
                                            settings, axes, covariance_only, thresholds);
        if (shard.is_none())
          return py::cast(runWithProgress<ExperimentResult>(
              [&cfg](ProgressCounter* p) { return runExperiment(cfg, p); }, progress));
        int k = 0, n = 0;
        try
        {
          const auto kn = shard.cast<std::pair<int, int>>();
          k = kn.first;
          n = kn.second;
        }
        catch (const py::cast_error&)
        {
          throw py::type_error("montecarlo(): shard: expected (k, n), two integers");
        }
        if (!(n >= 1 && n <= kMaxShards && k >= 1 && k <= n))
          throw py::value_error(
              "montecarlo(): shard: expected (k, n) with 1 <= k <= n <= " + std::to_string(kMaxShards) + ", found (" +
              std::to_string(k) + ", " + std::to_string(n) + ")");
        std::shared_ptr<ShardFile> shard_file =
            runWithProgress<ShardFile>([&cfg, k, n](ProgressCounter* p) { return runShard(cfg, k, n, p); }, progress);
        shard_file->path = memoryLabel(*shard_file);
        return py::cast(shard_file);
      },
      py::arg("experiment"), py::arg("runs") = 0, py::arg("steps") = 0, py::arg("seed") = 1, py::arg("threads") = 0,
      py::arg("model") = py::none(), py::arg("channels") = py::none(), py::arg("actuator_channel") = py::none(),
      py::arg("settings") = py::none(), py::arg("axes") = py::none(), py::arg("progress") = py::none(),
      py::arg("shard") = py::none(), py::arg("covariance_only") = false, py::arg("thresholds") = py::none(),
      "Runs a Monte Carlo experiment (experiment_names()) exactly as the montecarlo tool with the same "
      "arguments: runs, steps (0: the experiment's default), seed, threads (0: all cores); custom, covariance "
      "and sweep take model (a Model or a file), channels (a Link or file, {sensor: Link or file} or the tool's "
      "--channel arguments), actuator_channel (a file) and settings (an algorithm name, a settings file, a dict "
      "of settings with an optional 'name', or a list of them; objects go in as their text, which shards hash "
      "and carry), sweep also axes ['NAME=LO:HI:N'] (a link's, an estimator's or the model's parameter). "
      "covariance_only=True "
      "(custom, sweep; the experiment covariance always) runs the estimators' covariance recursion on the links' "
      "arrivals alone, without the plant (the tool's --covariance-only). thresholds=[M, ...] adds the tail "
      "probabilities P(value > M) (the tool's --threshold). progress(done, total) is called as blocks finish. "
      "Returns a MonteCarloResult, or with shard=(k, n) a Shard for merge().");
  m.def(
      "merge",
      [](py::handle shards)
      {
        std::vector<ShardFile> files;
        for (const auto& item : shards)
        {
          std::string path;
          if (asPath(item, path))
            files.push_back(readShard(path));
          else
          {
            try
            {
              files.push_back(item.cast<const ShardFile&>());
            }
            catch (const py::cast_error&)
            {
              throw py::type_error("merge(): expected Shard objects or shard file paths");
            }
          }
        }
        if (files.empty())
          throw py::value_error("merge(): expected the shards of an experiment, found none");
        std::shared_ptr<ExperimentResult> result;
        {
          py::gil_scoped_release release;
          result = std::make_shared<ExperimentResult>(mergeShards(std::move(files)));
        }
        return result;
      },
      py::arg("shards"),
      "Merges the shards of an experiment (Shard objects or shard files) into the result of the unsharded "
      "run, bit for bit (threads and wall_seconds aside).");
  m.def("experiment_names", &experimentNames, "The experiments montecarlo() runs.");
}

}  // namespace python
}  // namespace networked_estimation
