// Reading and validating the estimator settings (docs/formats.md, "Estimator settings").
#include "networked_estimation/config/estimator_settings.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
using namespace detail;

namespace
{

const std::vector<std::string>& algorithmNames()
{
  static const std::vector<std::string> names = {"kf", "kfio", "rseio", "aoe", "oe", "ack_kf", "ekfio"};
  return names;
}

const std::vector<Algorithm>& algorithmValues()
{
  static const std::vector<Algorithm> values = {Algorithm::KF, Algorithm::KFIO,   Algorithm::RSEIO, Algorithm::AOE,
                                                Algorithm::OE, Algorithm::ACK_KF, Algorithm::EKFIO};
  return values;
}

EstimatorSettings parseEstimatorSettingsImpl(const YAML::Node& node, const std::string& source)
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(node, "", {"algorithm", "mu", "control_link", "max_components"});

  EstimatorSettings settings;
  const YAML::Node algorithm = in.require(node, "", "algorithm");
  settings.algorithm = algorithmValues()[in.choice(algorithm, "algorithm", "algorithm", algorithmNames())];

  if (const YAML::Node mu = node["mu"])
  {
    settings.mu = in.number(mu, "mu");
    if (!(settings.mu > 0.0 && settings.mu <= 1.0))
    {
      in.fail(mu, "mu", "expected a number in (0, 1], found " + mu.Scalar());
    }
  }
  else if (settings.algorithm == Algorithm::RSEIO)
  {
    in.fail(node, "mu", "missing required key (algorithm rseio needs mu in (0, 1])");
  }

  if (const YAML::Node link = node["control_link"])
  {
    in.requireMap(link, "control_link");
    in.checkKeys(link, "control_link", {"recovery", "failure"});
    settings.recovery = in.probability(in.require(link, "control_link", "recovery"), "control_link.recovery");
    settings.failure = in.probability(in.require(link, "control_link", "failure"), "control_link.failure");
    settings.has_control_link = true;
  }

  if (const YAML::Node max = node["max_components"])
  {
    const std::uint64_t value = in.integer(max, "max_components", 1);
    if (value > std::numeric_limits<std::size_t>::max())
    {
      in.fail(max, "max_components", "integer out of range, found " + max.Scalar());
    }
    settings.max_components = static_cast<std::size_t>(value);
  }
  return settings;
}

}  // namespace

std::string toString(Algorithm a)
{
  const auto& values = algorithmValues();
  for (std::size_t i = 0; i < values.size(); ++i)
  {
    if (values[i] == a)
    {
      return algorithmNames()[i];
    }
  }
  return "unknown";
}

Algorithm algorithmFromString(const std::string& name, const std::string& source)
{
  const auto& names = algorithmNames();
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end())
  {
    throw ConfigError(
        message(source, 0, "algorithm", "unknown algorithm '" + name + "' (expected one of: " + joinList(names) + ")"));
  }
  return algorithmValues()[static_cast<std::size_t>(it - names.begin())];
}

EstimatorSettings parseEstimatorSettings(const YAML::Node& node, const std::string& source)
{
  return guarded(source, [&] { return parseEstimatorSettingsImpl(node, source); });
}

EstimatorSettings loadEstimatorSettings(const std::string& path)
{
  return parseEstimatorSettings(loadYamlFile(path), path);
}

bool isAlgorithmName(const std::string& text)
{
  const auto& names = algorithmNames();
  return std::find(names.begin(), names.end(), text) != names.end();
}

EstimatorSettings estimatorSettingsArgument(const std::string& arg)
{
  if (isAlgorithmName(arg))
  {
    EstimatorSettings s;
    s.algorithm = algorithmFromString(arg, arg);
    return s;
  }
  try
  {
    return loadEstimatorSettings(arg);
  }
  catch (const ConfigError& e)
  {
    std::ifstream probe(arg);
    if (probe)
      throw;
    throw ConfigError(std::string(e.what()) + " (nor is '" + arg + "' an algorithm: " + joinList(algorithmNames()) +
                      ")");
  }
}

}  // namespace networked_estimation
