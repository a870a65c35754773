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

#include "config/field.hpp"
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

/// The control link's two probabilities.
void readControlLink(const Field& link, EstimatorSettings& settings)
{
  static const std::vector<KeyRule<EstimatorSettings>> table = {
      requiredKey<EstimatorSettings>("recovery",
                                     [](const Field& f, EstimatorSettings& s) { s.recovery = f.probability(); }),
      requiredKey<EstimatorSettings>("failure",
                                     [](const Field& f, EstimatorSettings& s) { s.failure = f.probability(); }),
  };
  readKeys(link, table, settings);
  settings.has_control_link = true;
}

EstimatorSettings parseEstimatorSettingsImpl(const YAML::Node& node, const std::string& source)
{
  using S = EstimatorSettings;
  static const std::vector<KeyRule<S>> table = {
      requiredKey<S>("algorithm", [](const Field& f, S& s)
                     { s.algorithm = algorithmValues()[f.oneOf("algorithm", algorithmNames())]; }),
      optionalKey<S>(
          "mu",
          [](const Field& f, S& s)
          {
            s.mu = f.number();
            if (!(s.mu > 0.0 && s.mu <= 1.0))
            {
              f.fail("expected a number in (0, 1], found " + f.text());
            }
          },
          [](const Field& map, S& s)
          {
            if (s.algorithm == Algorithm::RSEIO)
            {
              map.required("mu", "algorithm rseio needs mu in (0, 1]");
            }
          }),
      optionalKey<S>("control_link", readControlLink),
      optionalKey<S>("max_components",
                     [](const Field& f, S& s)
                     {
                       const std::uint64_t value = f.integer(1);
                       if (value > std::numeric_limits<std::size_t>::max())
                       {
                         f.fail("integer out of range, found " + f.text());
                       }
                       s.max_components = static_cast<std::size_t>(value);
                     }),
  };
  const Field root(node, source);
  root.requireTopMap();
  S settings;
  readKeys(root, table, settings);
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
