#include "estimators/estimator_factory.hpp"
#include "estimators/aoe_estimators.hpp"
#include "estimators/kalman_filter.hpp"
#include "estimators/rseio_estimator.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

std::unique_ptr<Estimator> makeEstimator(const Model& model, const EstimatorSettings& settings)
{
  return detail::makeEstimator(model, settings, detail::SizeChoice::AUTOMATIC);
}

namespace detail
{

// Each algorithm's factory picks its fixed-size form when the model's sizes are among the
// instantiated ones (estimator_sizes.hpp) and the dynamic form otherwise.
std::unique_ptr<Estimator> makeEstimator(const Model& model, const EstimatorSettings& settings, SizeChoice choice)
{
  const std::string name = toString(settings.algorithm);
  ControlLink link;
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
      return makeKalmanFilter(model, settings.algorithm, choice);
    case Algorithm::RSEIO:
      return makeRseio(model, settings.mu, choice);
    case Algorithm::AOE:
      return makeAoe(model, link, choice);
    case Algorithm::OE:
      return makeOptimalEstimator(model, link, settings.max_components, choice);
  }
  throw ConfigError("settings: algorithm: unsupported value");
}

}  // namespace detail
}  // namespace networked_estimation
