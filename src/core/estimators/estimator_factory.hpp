// makeEstimator with the choice of compiled form (estimator_sizes.hpp), for the tests and
// measurements that compare the fixed-size form with the dynamic one.
#pragma once

#include <memory>

#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{
namespace detail
{

/// makeEstimator(model, settings) is makeEstimator(model, settings, SizeChoice::AUTOMATIC).
std::unique_ptr<Estimator> makeEstimator(const Model& model, const EstimatorSettings& settings, SizeChoice choice);

}  // namespace detail
}  // namespace networked_estimation
