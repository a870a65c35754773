// The Python module, part two: estimators (one step at a time and whole sequences), the simulator,
// the replay input reader and the score (docs/python.md).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <limits>
#include <memory>

#include "bindings.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/io/replay_csv.hpp"
#include "networked_estimation/io/score.hpp"
#include "networked_estimation/simulation/lossy_run.hpp"

namespace networked_estimation
{
namespace python
{
namespace
{

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// An estimator with its own copy of the model (so it outlives the Model object it was made from)
/// and one Sample reused across steps.
struct PyEstimator
{
  std::shared_ptr<const Model> model;
  EstimatorSettings settings;
  std::unique_ptr<Estimator> estimator;
  Sample sample;
};

/// `o` as an array of exactly `shape` (-1: any); ValueError naming `what`, expected and found.
DoubleArray shaped(py::handle o, std::vector<Py_ssize_t> shape, const std::string& what, const std::string& meaning)
{
  DoubleArray a = DoubleArray::ensure(o);
  if (!a)
    throw py::value_error(what + ": expected an array of numbers of shape " + meaning);
  bool ok = a.ndim() == static_cast<Py_ssize_t>(shape.size());
  for (std::size_t i = 0; ok && i < shape.size(); ++i)
    ok = shape[i] < 0 || a.shape(static_cast<Py_ssize_t>(i)) == shape[i];
  if (!ok)
    throw py::value_error(what + ": expected shape " + meaning + ", found " + shapeText(a));
  return a;
}

std::shared_ptr<PyEstimator> makePyEstimator(const std::shared_ptr<Model>& model, const std::string& algorithm,
                                             py::dict settings)
{
  if (!model)
    throw py::type_error("make_estimator(): expected a Model");
  auto e = std::make_shared<PyEstimator>();
  e->model = std::make_shared<const Model>(*model);
  if (isSettingsFile(algorithm))
  {
    if (!settings.empty())
      throw py::value_error("make_estimator(): settings come from the file '" + algorithm +
                            "': give no keywords with it");
    e->settings = loadEstimatorSettings(algorithm);
  }
  else
  {
    settings["algorithm"] = algorithm;
    e->settings = parseEstimatorSettings(toYaml(settings, "make_estimator()"), "make_estimator()");
  }
  try
  {
    e->estimator = makeEstimator(*e->model, e->settings);
  }
  catch (const ConfigError& err)
  {
    throw ConfigError(std::string("make_estimator(): ") + err.what());
  }
  return e;
}

/// step()'s gamma as run() takes Gamma: a bool (Python's or numpy's) or a number that is 0 or 1;
/// anything else (2, 0.5, NaN, a string) is a ValueError rather than Python's truth value.
bool gammaFlag(py::handle g)
{
  if (py::isinstance<py::bool_>(g))
    return g.cast<bool>();
  double v = std::numeric_limits<double>::quiet_NaN();
  if (!py::isinstance<py::str>(g) && !py::isinstance<py::bytes>(g))
  {
    PyObject* f = PyNumber_Float(g.ptr());  // numpy's bool_ and numeric scalars, Python's int and float
    if (f)
    {
      v = PyFloat_AsDouble(f);
      Py_DECREF(f);
    }
    else
      PyErr_Clear();
  }
  if (v != 0.0 && v != 1.0)
    throw py::value_error("step(): gamma: expected 0 or 1 (or a bool), found " + py::repr(g).cast<std::string>());
  return v == 1.0;
}

/// Whether y (m > 0 values) is NaN everywhere: no sensor arrived, which gamma = 1 contradicts.
bool allMissing(const double* y, int m)
{
  for (int i = 0; i < m; ++i)
    if (!std::isnan(y[i]))
      return false;
  return m > 0;
}

/// The refusal of a sample said to have arrived (gamma 1) whose y is NaN everywhere.
std::string arrivedButEmpty(const std::string& y, const std::string& gamma)
{
  return y + ": every value is NaN (NaN marks a sensor that did not arrive) but " + gamma +
         " is 1 (the sample arrived); give 0 for a sample of which no sensor arrived";
}

void step(PyEstimator& e, py::handle y, py::handle gamma_arg, py::handle u, int nu, py::handle R, double dt)
{
  Sample& s = e.sample;
  const Model& model = *e.model;
  const bool gamma = gammaFlag(gamma_arg);
  s.gamma = gamma;
  if (y.is_none())
    s.y.resize(0);
  else
  {
    const DoubleArray a = shaped(y, {model.m()}, "step(): y", "(m,) = (" + std::to_string(model.m()) + ",)");
    if (gamma && allMissing(a.data(), model.m()))
      throw py::value_error("step(): step " + std::to_string(e.estimator->steps() + 1) + ": " +
                            arrivedButEmpty("y", "gamma"));
    s.y = Eigen::Map<const Eigen::VectorXd>(a.data(), model.m());
  }
  if (u.is_none())
    s.u.resize(0);
  else
  {
    const DoubleArray a = shaped(u, {model.p()}, "step(): u", "(p,) = (" + std::to_string(model.p()) + ",)");
    s.u = Eigen::Map<const Eigen::VectorXd>(a.data(), model.p());
  }
  if (R.is_none())
    s.R.resize(0, 0);
  else
  {
    const DoubleArray a = shaped(R, {model.m(), model.m()}, "step(): R",
                                 "(m, m) = (" + std::to_string(model.m()) + ", " + std::to_string(model.m()) + ")");
    s.R = Eigen::Map<const RowMajor>(a.data(), model.m(), model.m());
  }
  s.nu = nu;
  s.dt = dt;
  try
  {
    checkStepCovariance(model, s);
    e.estimator->step(s);
  }
  catch (const InputError& err)
  {
    throw InputError(std::string("step(): ") + err.what());
  }
}

/// run(): steps the whole sequence in C++ without the GIL; returns (x, P, trace).
py::tuple run(PyEstimator& e, py::handle Y, py::handle Gamma, py::handle U, py::handle nu, py::handle R, py::handle dt)
{
  const Model& model = *e.model;
  const int n = model.n(), m = model.m(), p = model.p();
  const DoubleArray y = shaped(Y, {-1, m}, "run(): Y", "(N, m) with m = " + std::to_string(m));
  const Py_ssize_t N = y.shape(0);
  const std::string Ntext = "N = " + std::to_string(N) + " (the rows of Y)";
  const DoubleArray gamma = shaped(Gamma, {N}, "run(): Gamma", "(N,) with " + Ntext);
  const bool has_u = !U.is_none(), has_nu = !nu.is_none(), has_r = !R.is_none(), has_dt = !dt.is_none();
  DoubleArray u, nus, r, dts;
  if (has_u)
    u = shaped(U, {N, p}, "run(): U", "(N, p) with " + Ntext + " and p = " + std::to_string(p));
  if (has_nu)
    nus = shaped(nu, {N}, "run(): nu", "(N,) with " + Ntext);
  if (has_r)
    r = shaped(R, {N, m, m}, "run(): R", "(N, m, m) with " + Ntext + " and m = " + std::to_string(m));
  if (has_dt)
    dts = shaped(dt, {N}, "run(): dt", "(N,) with " + Ntext);
  for (Py_ssize_t k = 0; k < N; ++k)
  {
    const double g = gamma.data()[k];
    if (g != 0.0 && g != 1.0)
      throw py::value_error("run(): Gamma[" + std::to_string(k) + "]: expected 0 or 1 (or a bool), found " +
                            std::to_string(g));
    if (has_nu && nus.data()[k] != -1.0 && nus.data()[k] != 0.0 && nus.data()[k] != 1.0)
      throw py::value_error("run(): nu[" + std::to_string(k) + "]: expected -1 (unknown), 0 or 1, found " +
                            std::to_string(nus.data()[k]));
  }

  py::array_t<double> x({N, static_cast<Py_ssize_t>(n)});
  py::array_t<double> P({N, static_cast<Py_ssize_t>(n), static_cast<Py_ssize_t>(n)});
  py::array_t<double> trace({N});
  double* xo = x.mutable_data();
  double* Po = P.mutable_data();
  double* to = trace.mutable_data();
  {
    py::gil_scoped_release release;
    Sample& s = e.sample;
    s.R.resize(0, 0);
    s.u.resize(0);
    s.nu = -1;
    s.dt = 0.0;
    for (Py_ssize_t k = 0; k < N; ++k)
    {
      s.gamma = gamma.data()[k] != 0.0;
      if (s.gamma && allMissing(y.data() + k * m, m))
      {
        const std::string row = "[" + std::to_string(k) + "]";
        throw InputError("run(): step " + std::to_string(k) + ": " + arrivedButEmpty("Y" + row, "Gamma" + row));
      }
      s.y = Eigen::Map<const Eigen::VectorXd>(y.data() + k * m, m);
      if (has_u)
        s.u = Eigen::Map<const Eigen::VectorXd>(u.data() + k * p, p);
      if (has_nu)
        s.nu = static_cast<int>(nus.data()[k]);
      if (has_r)
        s.R = Eigen::Map<const RowMajor>(r.data() + k * m * m, m, m);
      if (has_dt)
        s.dt = dts.data()[k];
      try
      {
        checkStepCovariance(model, s);
        e.estimator->step(s);
      }
      catch (const InputError& err)
      {
        throw InputError("run(): step " + std::to_string(k) + ": " + err.what());
      }
      catch (const DivergenceError& err)
      {
        throw DivergenceError("run(): " + toString(e.settings.algorithm) + " diverged at step " + std::to_string(k) +
                              ": " + err.what());
      }
      const Eigen::VectorXd& xe = e.estimator->state();
      const Eigen::MatrixXd& Pe = e.estimator->covariance();
      for (int i = 0; i < n; ++i)
      {
        xo[k * n + i] = xe[i];
        for (int j = 0; j < n; ++j)
          Po[(k * n + i) * n + j] = Pe(i, j);
      }
      to[k] = Pe.trace();
    }
  }
  return py::make_tuple(x, P, trace);
}

/// Truth, estimate -> the score tool's numbers.
py::dict score(py::handle truth, py::handle x, py::handle P, py::handle gamma, long from, py::handle model,
               const std::string& name)
{
  py::handle truth_x = truth;
  if (py::isinstance<py::dict>(truth))
  {
    truth_x = truth["x"];
    if (gamma.is_none() && truth.contains("gamma"))
      gamma = truth["gamma"];
  }
  const DoubleArray t = shaped(truth_x, {-1, -1}, "score(): truth", "(N, n)");
  const Py_ssize_t N = t.shape(0), n = t.shape(1);
  const std::string dims = "N = " + std::to_string(N) + " and n = " + std::to_string(n) + " (the truth's)";
  const DoubleArray xe = shaped(x, {N, n}, "score(): x", "(N, n) with " + dims);
  const DoubleArray Pe = shaped(P, {N, n, n}, "score(): P", "(N, n, n) with " + dims);
  const bool has_gamma = !gamma.is_none();
  DoubleArray g;
  if (has_gamma)
    g = shaped(gamma, {N}, "score(): gamma", "(N,) with " + dims);
  std::vector<int> angles;
  if (!model.is_none())
  {
    const Model& mo = model.cast<const Model&>();
    if (mo.n() != n)
      throw py::value_error("score(): the truth has n = " + std::to_string(n) + " states but the model '" + mo.name +
                            "' has n = " + std::to_string(mo.n()));
    angles = mo.angles;
  }
  Truth tr;
  tr.path = "score(): truth";
  tr.n = static_cast<int>(n);
  ReplayOutput est;
  est.path = "score(): estimate";
  est.n = static_cast<int>(n);
  for (Py_ssize_t k = 0; k < N; ++k)
  {
    TruthRow row;
    row.k = k + 1;
    row.x = Eigen::Map<const Eigen::VectorXd>(t.data() + k * n, n);
    tr.rows.push_back(row);
    ReplayOutputRow out;
    out.k = k + 1;
    out.gamma = has_gamma ? g.data()[k] != 0.0 : true;
    out.x = Eigen::Map<const Eigen::VectorXd>(xe.data() + k * n, n);
    out.P = Eigen::Map<const RowMajor>(Pe.data() + k * n * n, n, n);
    out.trace = out.P.trace();
    est.rows.push_back(out);
  }
  const Score s = scoreEstimate(name, tr, est, from, angles);
  py::dict d;
  d["name"] = s.name;
  d["steps"] = s.steps;
  d["arrival_rate"] = s.arrival_rate;
  d["mse"] = s.mse;
  d["mean_trace"] = s.mean_trace;
  d["ratio"] = s.ratio;
  return d;
}

py::dict simulate(const std::shared_ptr<Model>& model_ptr, py::handle links, long steps, std::uint64_t seed,
                  py::handle control, py::handle actuator_link, const std::string& loss_output)
{
  if (!model_ptr)
    throw py::type_error("simulate(): expected a Model");
  const Model& model = *model_ptr;
  if (steps < 1)
    throw py::value_error("simulate(): steps: expected at least 1, found " + std::to_string(steps));
  if (loss_output != "noise" && loss_output != "empty")
    throw py::value_error("simulate(): loss_output: expected 'noise' or 'empty', found '" + loss_output + "'");
  const SensorLinks sl = sensorLinks(model, links, "simulate(): links");
  LossyRunOptions options;
  options.sensor_links = sl.link;
  options.noise_on_loss = loss_output == "noise";
  if (model.hasControl())
  {
    options.control =
        ControlSequence::parse(control.is_none() ? "paper" : control.cast<std::string>(), "simulate(): control");
    if (!actuator_link.is_none())
      options.actuator_link = linkOf(actuator_link, "simulate(): actuator_link");
  }
  else if (!control.is_none() || !actuator_link.is_none())
    throw py::value_error(std::string("simulate(): ") + (control.is_none() ? "actuator_link" : "control") +
                          ": model '" + model.name + "' has no control");

  const Py_ssize_t N = steps, n = model.n(), m = model.m(), p = model.p(),
                   S = static_cast<Py_ssize_t>(model.sensors.size());
  const bool scheduled = model.schedule.active();
  py::array_t<long long> k_out({N});
  py::array_t<double> x_out({N, n}), y_out({N, m}), u_out({N, p});
  py::array_t<bool> gamma_out({N}), nu_out({N}), sched_out({scheduled ? N : 0, S});
  long long* ko = k_out.mutable_data();
  double *xo = x_out.mutable_data(), *yo = y_out.mutable_data(), *uo = u_out.mutable_data();
  bool *go = gamma_out.mutable_data(), *no = nu_out.mutable_data(), *so = sched_out.mutable_data();
  {
    py::gil_scoped_release release;
    LossyRun run(model, seed, options);
    for (Py_ssize_t k = 0; k < N; ++k)
    {
      const SimulatedSample* sample = nullptr;
      try
      {
        sample = &run.step();
      }
      catch (const DivergenceError& e)
      {
        throw DivergenceError(std::string("simulate(): ") + e.what());
      }
      const Sample& received = run.received();
      ko[k] = sample->k;
      go[k] = received.gamma;
      no[k] = sample->nu;
      for (Py_ssize_t i = 0; i < n; ++i)
        xo[k * n + i] = sample->x[i];
      for (Py_ssize_t i = 0; i < m; ++i)
        yo[k * m + i] = received.y[i];
      for (Py_ssize_t i = 0; i < p; ++i)
        uo[k * p + i] = sample->u[i];
      if (scheduled)
        for (Py_ssize_t s = 0; s < S; ++s)
          so[k * S + s] = run.scheduled()[static_cast<std::size_t>(s)];
    }
  }
  py::dict d;
  d["k"] = k_out;
  d["x"] = x_out;
  d["nu"] = nu_out;
  d["y"] = y_out;
  d["gamma"] = gamma_out;
  d["u"] = u_out;
  d["scheduled"] = scheduled ? py::object(sched_out) : py::object(py::none());
  d["links"] = sl.origin;
  return d;
}

py::dict loadReplayInput(py::handle path_obj, const std::shared_ptr<Model>& model)
{
  std::string path;
  if (!asPath(path_obj, path))
    throw py::type_error("load_replay_input(): expected a file path");
  if (!model)
    throw py::type_error("load_replay_input(): expected a Model");
  const ReplayInput in = readReplayInput(path, *model);
  const Py_ssize_t N = static_cast<Py_ssize_t>(in.rows.size()), m = model->m(), p = in.has_u ? model->p() : 0;
  py::array_t<long long> k({N});
  py::array_t<bool> gamma({N});
  py::array_t<double> Y({N, m}), U({N, p}), nu({N}), R({in.has_R ? N : 0, m, m});
  for (Py_ssize_t i = 0; i < N; ++i)
  {
    const ReplayRow& row = in.rows[static_cast<std::size_t>(i)];
    k.mutable_data()[i] = row.k;
    gamma.mutable_data()[i] = row.gamma;
    nu.mutable_data()[i] = row.nu;
    for (Py_ssize_t j = 0; j < m; ++j)
      Y.mutable_data()[i * m + j] = row.y[j];
    for (Py_ssize_t j = 0; j < p; ++j)
      U.mutable_data()[i * p + j] = row.u[j];
    if (in.has_R)
    {
      const Eigen::MatrixXd& Ri = row.R.size() ? row.R : model->R;
      for (Py_ssize_t a = 0; a < m; ++a)
        for (Py_ssize_t b = 0; b < m; ++b)
          R.mutable_data()[(i * m + a) * m + b] = Ri(a, b);
    }
  }
  py::dict d;
  d["k"] = k;
  d["gamma"] = gamma;
  d["Y"] = Y;
  d["U"] = in.has_u ? py::object(U) : py::object(py::none());
  d["nu"] = in.has_nu ? py::object(nu) : py::object(py::none());
  d["R"] = in.has_R ? py::object(R) : py::object(py::none());
  return d;
}

}  // namespace

void bindEstimators(py::module& m)
{
  py::class_<PyEstimator, std::shared_ptr<PyEstimator>>(m, "Estimator", R"doc(
One of the package's estimators (kf, kfio, rseio, aoe, oe, ack_kf, ekfio) for a model: make one with
make_estimator(model, algorithm, **settings). It keeps its own copy of the model.)doc")
      .def("step", &step, py::arg("y"), py::arg("gamma") = true, py::arg("u") = py::none(), py::arg("nu") = -1,
           py::arg("R") = py::none(), py::arg("dt") = 0.0,
           "One step k-1 -> k: y (m,) with NaN for the sensors that did not arrive, gamma whether the "
           "sample arrived (0/1 or a bool; with gamma 1 some sensor's values are not NaN), u (p,) the "
           "command, nu whether it reached the actuator (ack_kf; -1 unknown), R (m, m) this step's noise "
           "covariance (None: the model's), dt the step's duration (ekfio; 0: the model's period). A "
           "ValueError leaves the estimate untouched; DivergenceError needs reset().")
      .def("run", &run, py::arg("Y"), py::arg("Gamma"), py::arg("U") = py::none(), py::arg("nu") = py::none(),
           py::arg("R") = py::none(), py::arg("dt") = py::none(),
           "Steps the whole sequence from the current estimate in C++ (the GIL released): Y (N, m), Gamma "
           "(N,) of 0/1 or bools, optionally U (N, p), nu (N,), R (N, m, m), dt (N,). Returns (x (N, n), "
           "P (N, n, n), trace (N,)), the estimate after every step.")
      .def_property_readonly(
          "x", [](const PyEstimator& e) { return Eigen::VectorXd(e.estimator->state()); }, "x_{k|k} (a copy)")
      .def_property_readonly(
          "P", [](const PyEstimator& e) { return Eigen::MatrixXd(e.estimator->covariance()); }, "P_{k|k} (a copy)")
      .def(
          "reset", [](PyEstimator& e) { e.estimator->reset(); }, "Back to x0, P0, step 0.")
      .def(
          "clone",
          [](const PyEstimator& e)
          {
            auto c = std::make_shared<PyEstimator>();
            c->model = e.model;
            c->settings = e.settings;
            c->estimator = e.estimator->clone();
            return c;
          },
          "An independent copy in the same state.")
      .def_property_readonly("algorithm", [](const PyEstimator& e) { return toString(e.settings.algorithm); })
      .def_property_readonly("implementation", [](const PyEstimator& e) { return e.estimator->implementation(); })
      .def_property_readonly("steps", [](const PyEstimator& e) { return e.estimator->steps(); })
      .def_property_readonly("last_updated", [](const PyEstimator& e) { return e.estimator->lastUpdated(); })
      .def_property_readonly("command_arrival_probability",
                             [](const PyEstimator& e) { return e.estimator->commandArrivalProbability(); })
      .def_property_readonly("components", [](const PyEstimator& e) { return e.estimator->components(); })
      .def_property_readonly(
          "model", [](const PyEstimator& e) { return std::make_shared<Model>(*e.model); },
          "a copy of the estimator's model")
      .def("__repr__",
           [](const PyEstimator& e)
           {
             return "<networked_estimation.Estimator " + toString(e.settings.algorithm) + " (" +
                    e.estimator->implementation() + ") of model '" + e.model->name + "', step " +
                    std::to_string(e.estimator->steps()) + ">";
           });

  m.def(
      "make_estimator",
      [](const std::shared_ptr<Model>& model, const std::string& algorithm, py::kwargs settings)
      { return makePyEstimator(model, algorithm, settings); },
      py::arg("model"), py::arg("algorithm") = "kfio",
      "The estimator `algorithm` (kf, kfio, rseio, aoe, oe, ack_kf, ekfio) for `model`, the other keys of "
      "an estimator settings file (mu, control_link, max_components) as keywords; or `algorithm` an "
      "estimator settings file (.yaml).");
}

void bindSimulation(py::module& m)
{
  m.def("simulate", &simulate, py::arg("model"), py::arg("links") = py::none(), py::arg("steps") = 1000,
        py::arg("seed") = 1, py::arg("control") = py::none(), py::arg("actuator_link") = py::none(),
        py::arg("loss_output") = "noise",
        "Simulates the plant of `model` for `steps` samples, each sensor behind its link (links: None, a "
        "Link or channel file for every sensor, or {sensor: Link or file, '*': every other}), exactly as the "
        "simulate tool with the same seed. Returns a dict of arrays: k, x (truth), nu, y (what arrived; NaN "
        "for a lost sensor), gamma, u, scheduled (or None), and links (each sensor's link).");
  m.def("score", &score, py::arg("truth"), py::arg("x"), py::arg("P"), py::arg("gamma") = py::none(),
        py::arg("from_") = 1, py::arg("model") = py::none(), py::arg("name") = "estimate",
        "The score tool's numbers of an estimate (x (N, n), P (N, n, n)) against the truth ((N, n), or "
        "simulate()'s dict) over the steps k >= from_ (1-based): steps, arrival_rate, mse, mean_trace, "
        "ratio. With a model, its angles' errors are wrapped.");
  m.def("load_replay_input", &loadReplayInput, py::arg("path"), py::arg("model"),
        "Reads a replay input CSV (docs/formats.md) for `model`: a dict of k, gamma, Y (NaN where a sensor "
        "was lost), U, nu and R (None when the file has none of them).");
}

}  // namespace python
}  // namespace networked_estimation
