// Estimator settings and channel settings (formats.md).
#pragma once

#include <cstdint>
#include <string>

namespace YAML
{
class Node;
}

namespace networked_estimation
{

enum class Algorithm
{
  KF,     ///< plain Kalman filter; treats every finite received sample as a measurement
  KFIO,   ///< Kalman filter with intermittent observations (Sinopoli)
  RSEIO,  ///< Zhou's robust estimator with intermittent observations
  AOE,    ///< approximate optimal estimator, NACK control link (Lin et al.)
  OE,     ///< exact optimal estimator (Gaussian mixture, capped)
  ACK_KF  ///< Kalman filter told whether each command arrived
};

/// "kf", "kfio", "rseio", "aoe", "oe", "ack_kf".
std::string toString(Algorithm a);
/// Inverse of toString; throws ConfigError for an unknown name (listing the known ones).
Algorithm algorithmFromString(const std::string& name, const std::string& source);

struct EstimatorSettings
{
  Algorithm algorithm = Algorithm::KFIO;
  double mu = 1.0;              ///< rseio: in (0, 1]
  bool has_control_link = false;
  double recovery = 0.5;        ///< q1 = P(delivered at k | lost at k-1)
  double failure = 0.5;         ///< q2 = P(lost at k | delivered at k-1)
  std::size_t max_components = 4096;  ///< oe only
};

/// Parses and validates estimator settings. Throws ConfigError naming the key.
EstimatorSettings parseEstimatorSettings(const YAML::Node& node, const std::string& source);
EstimatorSettings loadEstimatorSettings(const std::string& path);

enum class LossModelKind
{
  BERNOULLI,
  GILBERT_ELLIOTT
};

enum class DelayDistribution
{
  UNIFORM,
  NORMAL,
  PARETO
};

struct ChannelSettings
{
  LossModelKind model = LossModelKind::BERNOULLI;
  double loss = 0.0;       ///< bernoulli: P(lost)
  double p = 0.0;          ///< gilbert_elliott: P(good -> bad)
  double r = 1.0;          ///< gilbert_elliott: P(bad -> good)
  double loss_bad = 1.0;   ///< P(lost | bad)
  double loss_good = 0.0;  ///< P(lost | good)
  std::uint64_t seed = 0;
  // nodelet only
  double delay = 0.0;
  double jitter = 0.0;
  DelayDistribution distribution = DelayDistribution::UNIFORM;
  bool reorder = false;
  double duplicate = 0.0;
  std::size_t queue_limit = 1000;
};

/// Parses and validates channel settings. Throws ConfigError naming the key.
ChannelSettings parseChannelSettings(const YAML::Node& node, const std::string& source);
ChannelSettings loadChannelSettings(const std::string& path);

/// The settings as a YAML map that parseChannelSettings accepts (only the current model's keys).
YAML::Node toYaml(const ChannelSettings& settings);

/// `base` with the keys of the map `changes` replaced, validated as a whole (runtime changes).
/// When `changes` names another model, the old model's keys are dropped first. Throws ConfigError
/// naming the key; `base` is never modified.
ChannelSettings mergeChannelSettings(const ChannelSettings& base, const YAML::Node& changes,
                                     const std::string& source);

}  // namespace networked_estimation
