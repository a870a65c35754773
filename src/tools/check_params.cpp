// check_params: validates an Estimator parameter file offline (no ROS master), with the checks and
// the messages of the Estimator nodelet's load: the parameters parsed by the core's
// parseEstimatorNodeConfig, the filter built as the nodelet builds it (OnlineStream) and, with
// live_stability, its link verdicts' model. A refusal prints what the nodelet logs before it
// refuses its load ("Estimator not started: <file>: <key>: ...") and exits 2. Several files and
// single parameters make up a node's parameters as a launch file does (--params A --params B
// --set model=FILE). import_robot_localization --check FILE runs it.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include "cli.hpp"
#include "networked_estimation/config/rate_schedule.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/online/estimator_node_config.hpp"
#include "networked_estimation/online/online_stream.hpp"
#include "networked_estimation/online/sensor_lattice.hpp"
#include "networked_estimation/stability/live_stability.hpp"

using namespace networked_estimation;

namespace
{

YAML::Node loadMap(const std::string& path)
{
  YAML::Node params;
  try
  {
    params = YAML::LoadFile(path);
  }
  catch (const YAML::BadFile&)
  {
    throw ConfigError(path + ": cannot read the file");
  }
  catch (const YAML::Exception& e)
  {
    throw ConfigError(path + ": not YAML: " + e.what());
  }
  if (!params.IsMap())
    throw ConfigError(path + ": expected a map of the Estimator's parameters");
  return params;
}

/// `from` loaded over `into`, as rosparam loads a second file into the same namespace: maps are
/// merged key by key, anything else replaces.
void mergeInto(YAML::Node into, const YAML::Node& from)
{
  for (const auto& kv : from)
  {
    const std::string key = kv.first.as<std::string>();
    if (kv.second.IsMap() && into[key] && into[key].IsMap())
      mergeInto(into[key], kv.second);
    else
      into[key] = YAML::Clone(kv.second);
  }
}

/// The nodelet's configure(), without its ROS side, on the files loaded in order and then the
/// single parameters (KEY=VALUE, as <param>); throws ConfigError as it does.
std::string check(const std::vector<std::string>& files, const std::vector<std::string>& sets)
{
  const std::string path = files.front();
  YAML::Node params = loadMap(path);
  for (std::size_t i = 1; i < files.size(); ++i)
    mergeInto(params, loadMap(files[i]));
  for (const std::string& set : sets)
  {
    const std::string::size_type eq = set.find('=');
    if (eq == std::string::npos || eq == 0)
      throw cli::UsageError("option '--set': expected KEY=VALUE, found '" + set + "'");
    try
    {
      params[set.substr(0, eq)] = YAML::Load(set.substr(eq + 1));
    }
    catch (const YAML::Exception& e)
    {
      throw cli::UsageError("option '--set': " + set + ": the value is not YAML: " + e.what());
    }
  }
  // A rosparam file's keys become the private parameters; diagnostic_period belongs to
  // diagnostic_updater (the nodelet leaves it out too).
  params.remove("diagnostic_period");
  const EstimatorNodeConfig c = parseEstimatorNodeConfig(params, path);
  OnlineStream stream(c.model, c.settings, c.online, c.timeline, c.runtime);
  std::vector<double> ratios;
  for (double r : c.online.rate_ratio)
    ratios.push_back(SensorLattice::whole(r));
  std::string rates_note;
  const Model stability_model = withSensorRates(linearisedModel(c.model, c.model.x0, c.period), ratios, &rates_note);
  if (c.live_stability)
  {
    LiveStabilityOptions live;
    live.window = c.stability_window;
    live.markov = c.markov_link;
    live.min_samples = c.stability_min_samples;
    live.late_data_dropped = c.online.late_policy == LatePolicy::DROP;
    LiveStability verdicts(stability_model, c.settings, live);
  }
  std::string summary = path + ": the Estimator would start: algorithm " + toString(c.settings.algorithm) +
                        ", model '" + c.model.name + "' (" + std::to_string(c.model.n()) + " states, " +
                        std::to_string(c.model.sensors.size()) + " sensors), period " + std::to_string(c.period) + " s";
  // What each sensor's rows measure: the state of a unit row of C, else "a combination".
  for (std::size_t k = 0; k < c.model.sensors.size(); ++k)
  {
    const Sensor& s = c.model.sensors[k];
    const SensorInput& in = c.inputs[k];
    std::string rows;
    for (int i = 0; i < s.size; ++i)
    {
      const Eigen::RowVectorXd row = c.model.C.row(s.offset + i);
      Eigen::Index j = 0;
      const bool unit = row.cwiseAbs().maxCoeff(&j) == 1.0 && row(j) == 1.0 && row.cwiseAbs().sum() == 1.0;
      const std::string state = !unit                    ? std::string("a combination")
                                : c.model.states.empty() ? "x[" + std::to_string(j) + "]"
                                                         : c.model.states[static_cast<std::size_t>(j)];
      rows += (i ? ", " : "") + state;
    }
    const bool derived =
        std::find(c.derived_sensors.begin(), c.derived_sensors.end(), s.name) != c.derived_sensors.end();
    summary += "\n  sensor " + s.name + ": " + toString(in.type) + " on " + in.topic + ", measures " + rows +
               (derived ? " (C and R from its fields)" : "");
  }
  if (!rates_note.empty())
    summary += "\nwarning (as the nodelet logs it): Estimator: " + rates_note;
  return summary;
}

}  // namespace

int main(int argc, char** argv)
{
  cli::CommandLine cl(
      "check_params",
      "Checks an Estimator parameter file (a YAML of its private parameters, the model inline\n"
      "or named) as the Estimator nodelet checks its parameters at load, without ROS: exit 0\n"
      "when it would start, 2 with the nodelet's message when it would refuse to load.",
      {
          {"params", "FILE",
           "an Estimator parameter file; several are loaded in order, each over the ones before (as "
           "a launch file's <rosparam command=\"load\">s into one node), the messages naming the "
           "first",
           true, true},
          {"set", "KEY=VALUE", "one parameter after the files (as a <param>), VALUE in YAML", false, true},
      });
  return cli::runTool(cl, argc, argv,
                      [&]() -> int
                      {
                        try
                        {
                          std::cout << check(cl.getAll("params"), cl.getAll("set")) << "\n";
                        }
                        catch (const ConfigError& e)
                        {
                          throw ConfigError(std::string("Estimator not started: ") + e.what());
                        }
                        return 0;
                      });
}
