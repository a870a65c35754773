// Estimator settings: which algorithm and its parameters (docs/formats.md, "Estimator settings").
#pragma once

#include <cstddef>
#include <string>

namespace YAML
{
class Node;
}

namespace networked_estimation
{

enum class Algorithm
{
  KF,      ///< plain Kalman filter; treats every finite received sample as a measurement
  KFIO,    ///< Kalman filter with intermittent observations (Sinopoli)
  RSEIO,   ///< Zhou's robust estimator with intermittent observations
  AOE,     ///< approximate optimal estimator, NACK control link (Lin et al.)
  OE,      ///< exact optimal estimator (Gaussian mixture, capped)
  ACK_KF,  ///< Kalman filter told whether each command arrived
  EKFIO    ///< extended kfio: a built-in nonlinear motion (or kfio's prediction on a linear model)
};

/// "kf", "kfio", "rseio", "aoe", "oe", "ack_kf", "ekfio".
std::string toString(Algorithm a);
/// Inverse of toString; throws ConfigError for an unknown name (listing the known ones).
Algorithm algorithmFromString(const std::string& name, const std::string& source);

struct EstimatorSettings
{
  Algorithm algorithm = Algorithm::KFIO;
  double mu = 1.0;  ///< rseio: in (0, 1]
  bool has_control_link = false;
  double recovery = 0.5;              ///< q1 = P(delivered at k | lost at k-1)
  double failure = 0.5;               ///< q2 = P(lost at k | delivered at k-1)
  std::size_t max_components = 4096;  ///< oe only
};

/// Parses and validates estimator settings. Throws ConfigError naming the key.
EstimatorSettings parseEstimatorSettings(const YAML::Node& node, const std::string& source);
EstimatorSettings loadEstimatorSettings(const std::string& path);
/// Whether `text` is the name of an algorithm ("kf", "kfio", ...).
bool isAlgorithmName(const std::string& text);
/// A tool's settings argument: an algorithm name (its default settings; the name wins over a file
/// of that name) or an estimator settings file. Throws ConfigError naming the file, and for a file
/// that cannot be opened saying it is not an algorithm name either (listing them).
EstimatorSettings estimatorSettingsArgument(const std::string& arg);

}  // namespace networked_estimation
