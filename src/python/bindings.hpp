// The Python module's shared pieces (docs/python.md): Python values to YAML nodes, so that the
// module's constructors go through the very parsers and checks of the files (the same errors,
// naming the same keys); numpy arrays in; the links of a call.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <yaml-cpp/yaml.h>

#include <memory>
#include <string>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/sensor_links.hpp"

namespace networked_estimation
{
namespace python
{

namespace py = pybind11;

/// A C-contiguous float64 array (a view of `o` when it already is one, else a converted copy).
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// Python value -> YAML node: None, bool, int, float (written round-trip exact), str, dicts,
/// lists and tuples, and anything with tolist() (numpy arrays and scalars). `what` names the value
/// in the TypeError of anything else, e.g. "Model(): key 'A'".
YAML::Node toYaml(py::handle value, const std::string& what);

/// An array's shape as numpy prints it: "(3,)", "(2, 4)".
std::string shapeText(const py::array& a);

/// Whether `name` names an estimator settings file (.yaml or .yml) rather than an algorithm.
bool isSettingsFile(const std::string& name);

/// `o` as a float64 array of `ndim` dimensions; ValueError "<what>: expected ..." otherwise.
DoubleArray asArray(py::handle o, int ndim, const std::string& what);

/// Whether `o` names a file: a str or an os.PathLike. `path` receives it.
bool asPath(py::handle o, std::string& path);

/// A Link, or a channel file read with its own checks; TypeError naming `what` for anything else.
ChannelSettings linkOf(py::handle link, const std::string& what);

/// A Model, or a model file read with its own checks; TypeError naming `what` for anything else.
std::shared_ptr<Model> modelOf(py::handle model, const std::string& what);

/// A Link in words: "GilbertElliott(p=0.05, r=0.3, loss_good=0, loss_bad=1, seed=0)".
std::string describeLink(const ChannelSettings& s);

/// The links of the model's sensors (simulate, analyze): None (every sensor lossless), a Link or a
/// channel file for every sensor, or a dict {sensor name: Link or file}, the key "*" for every
/// sensor without its own. Files only: exactly the tools' --channel rule (resolveSensorLinks), so
/// the origins read as the tools'. `what` names the argument in errors.
SensorLinks sensorLinks(const Model& model, py::handle links, const std::string& what);

/// json.loads(text): the tools' JSON documents as Python dicts.
py::object parseJson(const std::string& text);

/// Registered by each part of the module (module.cpp calls them in order).
void bindModel(py::module& m);
void bindEstimators(py::module& m);
void bindSimulation(py::module& m);
void bindAnalysis(py::module& m);
void bindMonteCarlo(py::module& m);

}  // namespace python
}  // namespace networked_estimation
