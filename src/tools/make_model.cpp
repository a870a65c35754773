// make_model: writes the model file of a constant-velocity or constant-acceleration robot
// (kinematic_model.hpp, docs/formats.md "Kinematic models for robots (make_model)"), or of a robot
// with a built-in motion omni_2d / omni_3d (omni_model.hpp, docs/formats.md 1.7b).
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "cli.hpp"
#include "networked_estimation/config/kinematic_model.hpp"
#include "networked_estimation/config/model_writer.hpp"
#include "networked_estimation/config/omni_model.hpp"
#include "networked_estimation/io/atomic_file.hpp"

using namespace networked_estimation;

namespace
{

/// A number (inf and nan are passed on, for the model's own checks to name).
double parseNumber(const std::string& text, const std::string& what)
{
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    throw cli::UsageError(what + ": expected a number, found '" + text + "'");
  return v;
}

std::vector<std::string> split(const std::string& text, char sep)
{
  std::vector<std::string> parts(1);
  for (const char c : text)
  {
    if (c == sep)
      parts.emplace_back();
    else
      parts.back() += c;
  }
  return parts;
}

KinematicSensor parseSensor(const std::string& text)
{
  const std::vector<std::string> parts = split(text, ':');
  if (parts.size() != 3)
    throw cli::UsageError("option '--sensor': expected NAME:QUANTITY:SIGMA, found '" + text + "'");
  return KinematicSensor{parts[0], parts[1], parseNumber(parts[2], "option '--sensor' '" + text + "': SIGMA")};
}

/// Comma-separated numbers ("0.1" or "0.1,0.2"), for the option `what`.
std::vector<double> parseNumbers(const std::string& text, const std::string& what)
{
  std::vector<double> out;
  const std::vector<std::string> parts = split(text, ',');
  for (std::size_t i = 0; i < parts.size(); ++i)
    out.push_back(parseNumber(parts[i], what + (parts.size() > 1 ? ": entry " + std::to_string(i) : "")));
  return out;
}

/// --sensor NAME:STATE,STATE,...:SIGMA[,SIGMA...] of an omni model.
OmniSensor parseOmniSensor(const std::string& text)
{
  const std::vector<std::string> parts = split(text, ':');
  if (parts.size() != 3)
    throw cli::UsageError(
        "option '--sensor': expected NAME:STATE,STATE,...:SIGMA[,SIGMA,...] for an omni model, "
        "found '" +
        text + "'");
  return OmniSensor{parts[0], split(parts[1], ','), parseNumbers(parts[2], "option '--sensor' '" + text + "': SIGMA")};
}

/// The options of a kinematic model that an omni model does not take, and the other way round.
const std::vector<std::string>& kinematicOnly()
{
  static const std::vector<std::string> keys = {"dims",        "accel-density",      "jerk-density", "p0-position",
                                                "p0-velocity", "p0-acceleration",    "heading",      "p0-yaw",
                                                "p0-yaw-rate", "p0-yaw-acceleration"};
  return keys;
}
const std::vector<std::string>& omniOnly()
{
  static const std::vector<std::string> keys = {"process-noise", "p0", "two-d-mode"};
  return keys;
}

/// The option a key of makeKinematicModel's and makeOmniModel's messages comes from, as the user
/// typed it: "sensors[1].sigma" -> "--sensor 'imu:acceleration:0' sigma", "dims" -> "--dims".
std::string optionOf(const std::string& key, const std::vector<std::string>& sensor_args)
{
  const std::string prefix = "sensors[";
  if (key.compare(0, prefix.size(), prefix) == 0)
  {
    const std::string::size_type close = key.find(']');
    const std::size_t i = static_cast<std::size_t>(std::strtoul(key.c_str() + prefix.size(), nullptr, 10));
    const std::string field = close == std::string::npos || close + 2 > key.size() ? "" : key.substr(close + 2);
    return "--sensor '" + (i < sensor_args.size() ? sensor_args[i] : std::string()) + "'" +
           (field.empty() ? "" : " " + field);
  }
  return "--" + std::string(key == "sensors" ? "sensor" : key);
}

/// make_model --motion omni_2d | omni_3d.
Model omniModel(const cli::CommandLine& cl, std::string& comment)
{
  for (const std::string& key : kinematicOnly())
    if (cl.has(key))
      throw cli::UsageError("option '--" + key + "' is not for a " + cl.get("motion") + " model");
  if (!cl.has("process-noise"))
    throw cli::UsageError("missing required option '--process-noise' (for a " + cl.get("motion") + " model)");
  OmniSpec spec;
  spec.motion = cl.get("motion");
  spec.name = cl.get("name", "robot");
  spec.rate = parseNumber(cl.get("rate"), "option '--rate'");
  spec.process_noise = parseNumbers(cl.get("process-noise"), "option '--process-noise'");
  const std::vector<std::string> sensor_args = cl.getAll("sensor");
  for (const std::string& s : sensor_args)
    spec.sensors.push_back(parseOmniSensor(s));
  spec.key_name = [&sensor_args](const std::string& key) { return optionOf(key, sensor_args); };
  if (cl.has("x0"))
    spec.x0 = parseNumbers(cl.get("x0"), "option '--x0'");
  if (cl.has("p0"))
    spec.p0 = parseNumbers(cl.get("p0"), "option '--p0'");
  spec.two_d_mode = cl.has("two-d-mode");
  const Model model = makeOmniModel(spec);
  comment += omniModelComment(spec);
  return model;
}

/// The command line as one shell line (arguments with special characters single-quoted).
std::string commandLine(int argc, char** argv)
{
  std::string out = "make_model";
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    bool plain = !arg.empty();
    for (const char c : arg)
      plain = plain &&
              (std::isalnum(static_cast<unsigned char>(c)) || std::string("_-./:=,+@%").find(c) != std::string::npos);
    std::string quoted;
    for (const char c : arg)
      quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
    out += " " + (plain ? arg : "'" + quoted + "'");
  }
  return out;
}

/// The model to --output (atomically, then a one-line summary: `what`, n, m) or to stdout.
void writeModel(const cli::CommandLine& cl, const Model& model, const std::string& comment, const std::string& what)
{
  if (!cl.has("output"))
  {
    std::ostringstream text;
    writeModelYaml(text, model, comment);
    std::cout << text.str();
    return;
  }
  AtomicFile file(cl.get("output"));
  writeModelYaml(file.stream(), model, comment);
  file.commit();
  std::cout << "wrote " << file.path() << ": " << what << ", n = " << model.n() << ", m = " << model.m() << "\n";
}

}  // namespace

int main(int argc, char** argv)
{
  cli::CommandLine cl(
      "make_model",
      "Writes the model file (YAML) of a constant_velocity or constant_acceleration robot in 1-D, 2-D or\n"
      "3-D sampled at RATE Hz: A and Q are the exact discretisation of white acceleration (constant_velocity,\n"
      "--accel-density in m^2/s^3) or white jerk (constant_acceleration, --jerk-density in m^2/s^5). The state\n"
      "is all positions, then all velocities (then accelerations): 2-D constant_velocity is [x, y, vx, vy].\n"
      "Each --sensor NAME:QUANTITY:SIGMA measures QUANTITY (position, velocity or acceleration) on every\n"
      "axis with standard deviation SIGMA (m, m/s, m/s^2). --heading Q adds a heading: the yaw (an angle, written\n"
      "in the file's angles) moves like one more axis, driven by white angular acceleration (rad^2/s^3) or jerk\n"
      "(rad^2/s^5) of density Q, last in each group ([x, y, yaw, vx, vy, vyaw]); QUANTITY yaw, yaw_rate or\n"
      "yaw_acceleration is a one-row sensor of it.\n"
      "--motion omni_2d or omni_3d writes a robot with a built-in nonlinear motion (for ekfio; docs/algorithms.md\n"
      "7): the state of robot_localization, omni_2d [x, y, yaw, vx, vy, vyaw, ax, ay], omni_3d [x, y, z, roll,\n"
      "pitch, yaw, vx, vy, vz, vroll, vpitch, vyaw, ax, ay, az], velocities and accelerations in the robot's\n"
      "frame; --process-noise gives Q per second (one value, or one per state), each --sensor\n"
      "NAME:STATE,STATE,...:SIGMA[,SIGMA,...] measures the named states. Writes to stdout unless --output is given.",
      {
          {"motion", "MOTION", "constant_velocity, constant_acceleration, omni_2d or omni_3d", true, false},
          {"dims", "D", "constant_velocity / constant_acceleration: number of axes, 1, 2 or 3", false, false},
          {"rate", "HZ", "sampling rate (the model's period is 1 / HZ)", true, false},
          {"accel-density", "Q", "constant_velocity: spectral density of the acceleration (m^2/s^3)", false, false},
          {"jerk-density", "Q", "constant_acceleration: spectral density of the jerk (m^2/s^5)", false, false},
          {"sensor", "NAME:QUANTITY:SIGMA", "a sensor (at least one)", true, true},
          {"name", "NAME", "model name (default kinematic)", false, false},
          {"x0", "V1,V2,...", "initial estimate, n values in the state order (default zeros)", false, false},
          {"p0-position", "VAR", "initial variance of each position, m^2 (default 1)", false, false},
          {"p0-velocity", "VAR", "initial variance of each velocity, (m/s)^2 (default 1)", false, false},
          {"p0-acceleration", "VAR", "constant_acceleration: initial variance of each acceleration (default 1)", false,
           false},
          {"heading", "Q",
           "a heading (yaw) with white angular acceleration / jerk of density Q (rad^2/s^3 / rad^2/s^5)", false, false},
          {"p0-yaw", "VAR", "with --heading: initial variance of the yaw, rad^2 (default 1)", false, false},
          {"p0-yaw-rate", "VAR", "with --heading: initial variance of the yaw rate, (rad/s)^2 (default 1)", false,
           false},
          {"p0-yaw-acceleration", "VAR", "with --heading, constant_acceleration: of the yaw acceleration (default 1)",
           false, false},
          {"process-noise", "V|V1,...,Vn",
           "omni: Q's diagonal per second (robot_localization's "
           "process_noise_covariance), one value or n",
           false, false},
          {"p0", "V|V1,...,Vn", "omni: P0's diagonal, one value or n (default 1)", false, false},
          {"two-d-mode", "", "omni_3d: hold z, roll, pitch, their rates and az at 0", false, false},
          {"output", "FILE", "write the model here (atomically) instead of to stdout", false, false},
      });
  return cli::runTool(
      cl, argc, argv,
      [&]() -> int
      {
        const std::string motion = cl.get("motion");
        if (motion == "omni_2d" || motion == "omni_3d")
        {
          std::string comment = "Generated by make_model (docs/formats.md 1.7b):\n  " + commandLine(argc, argv) + "\n";
          const Model model = omniModel(cl, comment);
          writeModel(cl, model, comment, motion + " at " + cl.get("rate") + " Hz");
          return 0;
        }
        for (const std::string& key : omniOnly())
          if (cl.has(key))
            throw cli::UsageError("option '--" + key + "' is only for an omni_2d or omni_3d model");
        if (!cl.has("dims"))
          throw cli::UsageError("missing required option '--dims' (for a " + motion + " model)");
        KinematicSpec spec;
        spec.motion = cl.get("motion");
        spec.name = cl.get("name", spec.name);
        spec.dims = static_cast<int>(cl.getLong("dims", 0, -1000, 1000));
        spec.rate = parseNumber(cl.get("rate"), "option '--rate'");

        const int order = kinematicOrder(spec.motion);  // ConfigError for an unknown motion
        const std::string density = densityKey(spec.motion);
        const std::string other = order == 2 ? "jerk-density" : "accel-density";
        if (cl.has(other))
          throw cli::UsageError("option '--" + other + "' is not for a " + spec.motion + " model (it takes --" +
                                density + ")");
        if (!cl.has(density))
          throw cli::UsageError("missing required option '--" + density + "' (for a " + spec.motion + " model)");
        spec.density = parseNumber(cl.get(density), "option '--" + density + "'");
        if (order == 2 && cl.has("p0-acceleration"))
          throw cli::UsageError("option '--p0-acceleration' is only for a constant_acceleration model");

        const std::vector<std::string> sensor_args = cl.getAll("sensor");
        for (const std::string& s : sensor_args)
          spec.sensors.push_back(parseSensor(s));
        spec.key_name = [&sensor_args](const std::string& key) { return optionOf(key, sensor_args); };
        if (cl.has("x0"))
        {
          const std::vector<std::string> values = split(cl.get("x0"), ',');
          spec.x0.resize(static_cast<Eigen::Index>(values.size()));
          for (std::size_t i = 0; i < values.size(); ++i)
            spec.x0[static_cast<Eigen::Index>(i)] = parseNumber(values[i], "option '--x0': entry " + std::to_string(i));
        }
        spec.p0_position = parseNumber(cl.get("p0-position", "1"), "option '--p0-position'");
        spec.p0_velocity = parseNumber(cl.get("p0-velocity", "1"), "option '--p0-velocity'");
        spec.p0_acceleration = parseNumber(cl.get("p0-acceleration", "1"), "option '--p0-acceleration'");
        if (cl.has("heading"))
        {
          spec.heading_density = parseNumber(cl.get("heading"), "option '--heading'");
          if (!(spec.heading_density > 0.0))  // 0 would mean "no heading"
            throw cli::UsageError("option '--heading': expected a spectral density > 0, found '" + cl.get("heading") +
                                  "'");
        }
        for (const char* key : {"p0-yaw", "p0-yaw-rate", "p0-yaw-acceleration"})
          if (cl.has(key) && !cl.has("heading"))
            throw cli::UsageError(std::string("option '--") + key + "' is only for a model with --heading");
        if (order == 2 && cl.has("p0-yaw-acceleration"))
          throw cli::UsageError("option '--p0-yaw-acceleration' is only for a constant_acceleration model");
        spec.p0_yaw = parseNumber(cl.get("p0-yaw", "1"), "option '--p0-yaw'");
        spec.p0_yaw_rate = parseNumber(cl.get("p0-yaw-rate", "1"), "option '--p0-yaw-rate'");
        spec.p0_yaw_acceleration = parseNumber(cl.get("p0-yaw-acceleration", "1"), "option '--p0-yaw-acceleration'");

        const Model model = makeKinematicModel(spec);
        const std::string comment = "Generated by make_model (docs/formats.md, \"Kinematic models for robots\"):\n  " +
                                    commandLine(argc, argv) + "\n" + kinematicModelComment(spec);
        writeModel(cl, model, comment,
                   spec.motion + " in " + std::to_string(spec.dims) + "-D at " + cl.get("rate") + " Hz");
        return 0;
      });
}
