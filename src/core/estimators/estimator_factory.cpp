#include "estimators/aoe_estimators.hpp"
#include "estimators/kalman_filter.hpp"
#include "estimators/rseio_estimator.hpp"

namespace networked_estimation
{

std::unique_ptr<Estimator> makeEstimator(const Model& model, const EstimatorSettings& settings)
{
  const std::string name = toString(settings.algorithm);
  detail::ControlLink link;
  if (settings.algorithm == Algorithm::AOE || settings.algorithm == Algorithm::OE)
  {
    if (model.hasControl() && !settings.has_control_link)
      throw ConfigError("settings: control_link: required for algorithm " + name + " because model '" + model.name +
                        "' has control (the estimator weighs both outcomes of every command with this chain)");
    if (settings.has_control_link)
    {
      link.q1 = settings.recovery;
      link.q2 = settings.failure;
    }
  }
  switch (settings.algorithm)
  {
    case Algorithm::KF:
    case Algorithm::KFIO:
    case Algorithm::ACK_KF:
      return std::make_unique<detail::KalmanFilter>(model, settings.algorithm);
    case Algorithm::RSEIO:
      return std::make_unique<detail::Rseio>(model, settings.mu);
    case Algorithm::AOE:
      return std::make_unique<detail::Aoe>(model, link);
    case Algorithm::OE:
      return std::make_unique<detail::OptimalEstimator>(model, link, settings.max_components);
  }
  throw ConfigError("settings: algorithm: unsupported value");
}

}  // namespace networked_estimation
