#include "estimators/estimator_factory.hpp"
#include "estimators/aoe_estimators.hpp"
#include "estimators/ekfio_estimator.hpp"
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

namespace
{

/// Why an algorithm other than ekfio cannot run a built-in motion.
std::string linearOnlyReason(Algorithm algorithm)
{
  switch (algorithm)
  {
    case Algorithm::RSEIO:
      return "its robust gain is built on the sensitivity of A, B and C to uncertain parameters (dA, dB, dC), "
             "which a built-in motion does not have";
    case Algorithm::AOE:
    case Algorithm::OE:
      return "it weighs both outcomes of every command through A and Bu (a mixture of linear Gaussian "
             "predictions), and a built-in motion has neither";
    default:
      return "it predicts with A, which a built-in motion does not have; use ekfio, which predicts through the "
             "motion and its Jacobian and updates as kfio does";
  }
}

}  // namespace

// Each algorithm's factory picks its fixed-size form when the model's sizes are among the
// instantiated ones (estimator_sizes.hpp) and the dynamic form otherwise.
std::unique_ptr<Estimator> makeEstimator(const Model& model, const EstimatorSettings& settings, SizeChoice choice)
{
  const std::string name = toString(settings.algorithm);
  if (model.nonlinear() && settings.algorithm != Algorithm::EKFIO)
    throw ConfigError("settings: algorithm: " + name + " needs a linear model (x_k = A x_{k-1} + ...), but model '" +
                      model.name + "' has motion " + toString(model.motion) + ": " +
                      linearOnlyReason(settings.algorithm));
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
    case Algorithm::EKFIO:
      return makeExtendedFilter(model, choice);
  }
  throw ConfigError("settings: algorithm: unsupported value");
}

}  // namespace detail
}  // namespace networked_estimation
