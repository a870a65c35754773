// The Python module networked_estimation._core (docs/python.md): thin bindings over the ROS-free
// core. This part: the module, the errors, the conversions every part uses, Model and Link.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <sstream>

#include "bindings.hpp"
#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/model_writer.hpp"

namespace networked_estimation
{
namespace python
{

using detail::formatNumber;

YAML::Node toYaml(py::handle value, const std::string& what)
{
  if (value.is_none())
    return YAML::Node(YAML::NodeType::Null);
  if (py::isinstance<py::bool_>(value))
    return YAML::Node(value.cast<bool>() ? "true" : "false");
  if (py::isinstance<py::int_>(value))
    return YAML::Node(py::str(value).cast<std::string>());  // any size, exactly
  if (py::isinstance<py::float_>(value))
  {
    const double v = value.cast<double>();
    if (std::isnan(v))
      return YAML::Node(".nan");
    if (std::isinf(v))
      return YAML::Node(v > 0 ? ".inf" : "-.inf");
    return YAML::Node(formatNumber(v));  // round-trip exact
  }
  if (py::isinstance<py::str>(value))
    return YAML::Node(value.cast<std::string>());
  if (py::isinstance<py::dict>(value))
  {
    YAML::Node node(YAML::NodeType::Map);
    for (const auto& item : py::reinterpret_borrow<py::dict>(value))
    {
      const std::string key = py::str(item.first).cast<std::string>();
      const bool top = what.size() >= 2 && what.compare(what.size() - 2, 2, "()") == 0;
      node[key] = toYaml(item.second, what + (top ? ": " : ".") + key);  // "Model(): sensors[0].C"
    }
    return node;
  }
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value))
  {
    YAML::Node node(YAML::NodeType::Sequence);
    std::size_t i = 0;
    for (const auto& item : value)
      node.push_back(toYaml(item, what + "[" + std::to_string(i++) + "]"));
    return node;
  }
  if (py::hasattr(value, "tolist"))  // numpy arrays and scalars
    return toYaml(value.attr("tolist")(), what);
  if (py::hasattr(value, "__fspath__"))
    return YAML::Node(py::module::import("os").attr("fspath")(value).cast<std::string>());
  throw py::type_error(what + ": expected a number, a string, a list, a dict or a numpy array, found " +
                       std::string(Py_TYPE(value.ptr())->tp_name));
}

std::string shapeText(const py::array& a)
{
  std::string out = "(";
  for (Py_ssize_t i = 0; i < a.ndim(); ++i)
    out += (i ? ", " : "") + std::to_string(a.shape(i));
  return out + (a.ndim() == 1 ? ",)" : ")");
}

bool isSettingsFile(const std::string& name)
{
  for (const std::string tail : {".yaml", ".yml"})
    if (name.size() >= tail.size() && name.compare(name.size() - tail.size(), tail.size(), tail) == 0)
      return true;
  return false;
}

DoubleArray asArray(py::handle o, int ndim, const std::string& what)
{
  DoubleArray a = DoubleArray::ensure(o);
  if (!a)
    throw py::value_error(what + ": expected an array of numbers");
  if (a.ndim() != ndim)
    throw py::value_error(what + ": expected a " + std::to_string(ndim) + "-D array, found shape " + shapeText(a));
  return a;
}

py::object parseJson(const std::string& text)
{
  return py::module::import("json").attr("loads")(text);
}

bool asPath(py::handle o, std::string& path)
{
  if (py::isinstance<py::str>(o))
  {
    path = o.cast<std::string>();
    return true;
  }
  if (py::hasattr(o, "__fspath__"))
  {
    path = py::module::import("os").attr("fspath")(o).cast<std::string>();
    return true;
  }
  return false;
}

namespace
{

}  // namespace

std::string describeLink(const ChannelSettings& s)
{
  std::ostringstream os;
  if (s.model == LossModelKind::BERNOULLI)
    os << "Bernoulli(loss=" << formatNumber(s.loss);
  else if (s.model == LossModelKind::TRACE)
    os << "Trace(trace=" << s.trace << (s.trace_topic.empty() ? "" : ", trace_topic=" + s.trace_topic);
  else
    os << "GilbertElliott(p=" << formatNumber(s.p) << ", r=" << formatNumber(s.r)
       << ", loss_good=" << formatNumber(s.loss_good) << ", loss_bad=" << formatNumber(s.loss_bad);
  os << ", seed=" << s.seed;
  if (s.delay != 0.0 || s.jitter != 0.0)
    os << ", delay=" << formatNumber(s.delay) << ", jitter=" << formatNumber(s.jitter);
  os << ")";
  return os.str();
}

namespace
{

}  // namespace

ChannelSettings linkOf(py::handle o, const std::string& what)
{
  std::string path;
  if (asPath(o, path))
    return loadChannelSettings(path);
  try
  {
    return o.cast<ChannelSettings>();
  }
  catch (const py::cast_error&)
  {
    throw py::type_error(what + ": expected a Link (Bernoulli, GilbertElliott, Link) or a channel file, found " +
                         std::string(Py_TYPE(o.ptr())->tp_name));
  }
}

std::shared_ptr<Model> modelOf(py::handle o, const std::string& what)
{
  std::string path;
  if (asPath(o, path))
    return std::make_shared<Model>(loadModel(path));
  try
  {
    std::shared_ptr<Model> m = o.cast<std::shared_ptr<Model>>();
    if (m)
      return m;
  }
  catch (const py::cast_error&)
  {
  }
  throw py::type_error(what + ": expected a Model or a model file, found " + std::string(Py_TYPE(o.ptr())->tp_name));
}

SensorLinks sensorLinks(const Model& model, py::handle links, const std::string& what)
{
  // (sensor name or "" for every sensor, value)
  std::vector<std::pair<std::string, py::handle>> entries;
  if (py::isinstance<py::dict>(links))
  {
    for (const auto& item : py::reinterpret_borrow<py::dict>(links))
    {
      const std::string key = item.first.is_none() ? "*" : py::str(item.first).cast<std::string>();
      entries.emplace_back(key == "*" ? "" : key, item.second);
    }
  }
  else if (!links.is_none())
    entries.emplace_back("", links);

  std::vector<std::string> args;  // the tools' --channel arguments, when every link is a file
  bool files = true;
  for (const auto& e : entries)
  {
    std::string path;
    if (!asPath(e.second, path))
      files = false;
    else
      args.push_back(e.first.empty() ? path : e.first + "=" + path);
  }
  if (files)
    return resolveSensorLinks(model, args);

  const std::size_t S = model.sensors.size();
  SensorLinks out;
  out.link.assign(S, std::nullopt);
  out.origin.assign(S, "");
  std::vector<bool> own(S, false);
  std::string common;
  for (const auto& e : entries)
  {
    const std::string label = e.first.empty() ? what : what + "['" + e.first + "']";
    const ChannelSettings settings = linkOf(e.second, label);
    std::string path;
    const std::string text = asPath(e.second, path) ? path : describeLink(settings);
    if (e.first.empty())
    {
      if (out.common)
        throw ConfigError(what + ": more than one link for every sensor");
      out.common = settings;
      common = text + " (" + label + ")";
      continue;
    }
    const std::size_t i = sensorIndex(model, e.first, what);
    out.link[i] = settings;
    out.origin[i] = e.first + ": " + text + " (" + label + ")";
    own[i] = true;
  }
  for (std::size_t i = 0; i < S; ++i)
  {
    if (own[i])
      continue;
    out.link[i] = out.common;
    out.origin[i] = model.sensors[i].name + ": " + (out.common ? common : "lossless (no link for it)");
  }
  return out;
}

namespace
{

py::object matrixOrNone(const Eigen::MatrixXd& M)
{
  return py::cast(M);
}

ChannelSettings linkFromKwargs(const py::dict& kwargs, const std::string& what)
{
  return parseChannelSettings(toYaml(kwargs, what), what);
}

}  // namespace

void bindModel(py::module& m)
{
  py::class_<Model, std::shared_ptr<Model>>(m, "Model", R"doc(
A plant and its sensors, as a model file describes it (docs/formats.md, "Model file"):
x_k = A x_{k-1} + Bu u_k + B w_{k-1}, y_k = C x_k + v_k, or a built-in motion (motion="omni_2d").

Model(**keys) takes the keys of a model file (numpy arrays for matrices, sensors as a list of
Sensor(name, C, R) or dicts) and checks them exactly as a file is checked: a ValueError names the key.
Model.from_yaml(path) reads a file.)doc")
      .def(py::init(
               [](py::kwargs keys)
               {
                 if (!keys.contains("name"))
                   keys["name"] = "model";
                 return std::make_shared<Model>(parseModel(toYaml(keys, "Model()"), "Model()"));
               }),
           "Builds a model from the keys of a model file (A, Q, sensors, B, Bu, x0, P0, period, states, "
           "angles, schedule, uncertainty, motion, ...).")
      .def_static(
          "from_yaml",
          [](py::handle path)
          {
            std::string p;
            if (!asPath(path, p))
              throw py::type_error("Model.from_yaml(): expected a file path");
            return std::make_shared<Model>(loadModel(p));
          },
          py::arg("path"), "Reads and checks a model file.")
      .def_readonly("name", &Model::name)
      .def_readonly("period", &Model::period)
      .def_property_readonly("n", &Model::n, "number of states")
      .def_property_readonly("m", &Model::m, "number of stacked outputs")
      .def_property_readonly("p", &Model::p, "number of control inputs (0 without control)")
      .def_property_readonly("A", [](const Model& mo) { return matrixOrNone(mo.A); })
      .def_property_readonly("B", [](const Model& mo) { return matrixOrNone(mo.B); })
      .def_property_readonly("Q", [](const Model& mo) { return matrixOrNone(mo.Q); })
      .def_property_readonly("C", [](const Model& mo) { return matrixOrNone(mo.C); })
      .def_property_readonly("R", [](const Model& mo) { return matrixOrNone(mo.R); })
      .def_property_readonly("Bu", [](const Model& mo) { return matrixOrNone(mo.Bu); })
      .def_property_readonly("x0", [](const Model& mo) { return Eigen::VectorXd(mo.x0); })
      .def_property_readonly("P0", [](const Model& mo) { return matrixOrNone(mo.P0); })
      .def_property_readonly(
          "sensors",
          [](const Model& mo)
          {
            py::list out;
            for (const Sensor& s : mo.sensors)
              out.append(py::make_tuple(s.name, s.offset, s.size));
            return out;
          },
          "(name, first row, rows) of every sensor, in the stacked y's order")
      .def_property_readonly("states",
                             [](const Model& mo)
                             {
                               std::vector<std::string> names;
                               for (int i = 0; i < mo.n(); ++i)
                                 names.push_back(stateName(mo, i));
                               return names;
                             })
      .def_readonly("angles", &Model::angles, "indices of the angular states")
      .def_property_readonly("motion", [](const Model& mo) { return toString(mo.motion); })
      .def_property_readonly("nonlinear", &Model::nonlinear)
      .def(
          "to_yaml",
          [](const Model& mo)
          {
            std::ostringstream os;
            writeModelYaml(os, mo, "written by networked_estimation.Model.to_yaml()");
            return os.str();
          },
          "The model as a model file's text.")
      .def(py::pickle(
          [](const Model& mo)
          {
            std::ostringstream os;
            writeModelYaml(os, mo, "");
            return os.str();
          },
          [](const std::string& text)
          { return std::make_shared<Model>(parseModel(YAML::Load(text), "a pickled Model")); }))
      .def("__repr__",
           [](const Model& mo)
           {
             return "<networked_estimation.Model '" + mo.name + "': n = " + std::to_string(mo.n()) +
                    ", m = " + std::to_string(mo.m()) + ", " + std::to_string(mo.sensors.size()) + " sensor(s)>";
           });

  m.def(
      "Sensor",
      [](const std::string& name, py::object C, py::object R, py::kwargs more)
      {
        py::dict d;
        d["name"] = name;
        d["C"] = C;
        d["R"] = R;
        for (const auto& item : more)
          d[item.first] = item.second;
        return d;
      },
      py::arg("name"), py::arg("C"), py::arg("R"),
      "One sensor of Model(sensors=[...]): its rows C and noise covariance R (and any other key of a "
      "model file's sensor entry). Returns the entry as a dict.");

  py::class_<ChannelSettings>(m, "Link", R"doc(
A lossy link: the keys of a channel file (docs/formats.md, "Channel settings"), checked as a file
is. Bernoulli(loss) and GilbertElliott(p, r, loss_good, loss_bad) are the usual ways to build one;
Link.from_yaml(path) reads a file.)doc")
      .def(py::init([](py::kwargs keys) { return linkFromKwargs(keys, "Link()"); }))
      .def_static(
          "from_yaml",
          [](py::handle path)
          {
            std::string p;
            if (!asPath(path, p))
              throw py::type_error("Link.from_yaml(): expected a file path");
            return loadChannelSettings(p);
          },
          py::arg("path"))
      .def_property_readonly("model",
                             [](const ChannelSettings& s)
                             {
                               return std::string(s.model == LossModelKind::BERNOULLI ? "bernoulli"
                                                  : s.model == LossModelKind::TRACE   ? "trace"
                                                                                      : "gilbert_elliott");
                             })
      .def_readonly("loss", &ChannelSettings::loss)
      .def_readonly("p", &ChannelSettings::p)
      .def_readonly("r", &ChannelSettings::r)
      .def_readonly("loss_good", &ChannelSettings::loss_good)
      .def_readonly("loss_bad", &ChannelSettings::loss_bad)
      .def_readonly("seed", &ChannelSettings::seed)
      .def_readonly("delay", &ChannelSettings::delay)
      .def_readonly("jitter", &ChannelSettings::jitter)
      .def(
          "to_yaml",
          [](const ChannelSettings& s)
          {
            YAML::Emitter e;
            e << toYaml(s);
            return std::string(e.c_str()) + "\n";
          },
          "The link as a channel file's text.")
      .def("__repr__", [](const ChannelSettings& s) { return describeLink(s); })
      .def(py::pickle(
          [](const ChannelSettings& s)
          {
            YAML::Emitter e;
            e << toYaml(s);
            return std::string(e.c_str());
          },
          [](const std::string& text) { return parseChannelSettings(YAML::Load(text), "Link"); }));

  m.def(
      "Bernoulli",
      [](py::object p, py::kwargs more)
      {
        py::dict d;
        d["model"] = "bernoulli";
        if (!p.is_none())
        {
          if (more.contains("loss"))
            throw py::value_error("Bernoulli(): give the loss probability once (p or loss)");
          d["loss"] = p;
        }
        for (const auto& item : more)
          d[item.first] = item.second;
        return linkFromKwargs(d, "Bernoulli()");
      },
      py::arg("p") = py::none(),
      "An i.i.d. link losing each message with probability p (the channel file's key loss; arrival "
      "rate 1 - p); more keys of a channel file (seed, delay, jitter, ...) as keywords.");
  m.def(
      "GilbertElliott",
      [](double p, double r, double loss_good, double loss_bad, py::kwargs more)
      {
        py::dict d;
        d["model"] = "gilbert_elliott";
        d["p"] = p;
        d["r"] = r;
        d["loss_good"] = loss_good;
        d["loss_bad"] = loss_bad;
        for (const auto& item : more)
          d[item.first] = item.second;
        return linkFromKwargs(d, "GilbertElliott()");
      },
      py::arg("p"), py::arg("r"), py::arg("loss_good") = 0.0, py::arg("loss_bad") = 1.0,
      "A two-state Markov link: p = P(good -> bad), r = P(bad -> good) (the recovery rate), and the "
      "loss probabilities in each state; more keys of a channel file as keywords.");
}

}  // namespace python
}  // namespace networked_estimation

PYBIND11_MODULE(_core, m)
{
  namespace ne = networked_estimation;
  namespace py = pybind11;
  m.doc() = "networked_estimation's ROS-free core from Python (docs/python.md).";
  static py::exception<ne::DivergenceError> divergence(m, "DivergenceError", PyExc_RuntimeError);
  py::register_exception_translator(
      [](std::exception_ptr p)
      {
        try
        {
          if (p)
            std::rethrow_exception(p);
        }
        catch (const ne::ConfigError& e)
        {
          PyErr_SetString(PyExc_ValueError, e.what());
        }
        catch (const ne::InputError& e)
        {
          PyErr_SetString(PyExc_ValueError, e.what());
        }
        catch (const ne::DivergenceError& e)
        {
          divergence(e.what());
        }
      });
  ne::python::bindModel(m);
  ne::python::bindEstimators(m);
  ne::python::bindSimulation(m);
  ne::python::bindAnalysis(m);
  ne::python::bindMonteCarlo(m);
}
