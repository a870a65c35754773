#pragma once

#include <memory>

#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{
namespace detail
{

/// kf, kfio or ack_kf (algorithm), fixed-size for the sizes of KalmanSizes, dynamic otherwise.
std::unique_ptr<Estimator> makeKalmanFilter(const Model& model, Algorithm algorithm, SizeChoice choice);

}  // namespace detail
}  // namespace networked_estimation
