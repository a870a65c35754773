// ekfio's factory (ekfio.cpp).
#pragma once

#include <memory>

#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{
namespace detail
{

/// ekfio runs in its dynamic form only: the robot motions have n = 8 or 15 and sensors of any
/// size (a fixed form would fix m too), and on a linear model it is kfio's dynamic form.
using ExtendedSizes = SizeList<>;

/// ekfio for a built-in motion or a linear model (docs/algorithms.md 7.4).
std::unique_ptr<Estimator> makeExtendedFilter(const Model& model, SizeChoice choice);

}  // namespace detail
}  // namespace networked_estimation
