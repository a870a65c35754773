// The fixed-size forms for n = 1 (estimator_sizes.hpp).
// One translation unit per state dimension n: the algorithms of one n share most of their compiled
// code (the base class, the update and Eigen's kernels for n x n), so compiling them together costs
// about half as much as one unit per algorithm, and the units of different n compile in parallel.
// Add a size here and to its list in estimator_sizes.hpp; a new algorithm adds a line per size.
#include "estimators/aoe_impl.hpp"
#include "estimators/kalman_impl.hpp"
#include "estimators/rseio_impl.hpp"

namespace networked_estimation
{
namespace detail
{

template std::unique_ptr<Estimator> newKalmanFilter<Sizes<1, 1>>(const Model&, Algorithm);
template std::unique_ptr<Estimator> newAoe<Sizes<1, 1>>(const Model&, ControlLink);
template std::unique_ptr<Estimator> newOptimalEstimator<Sizes<1, 1>>(const Model&, ControlLink, std::size_t);
template std::unique_ptr<Estimator> newKalmanFilter<Sizes<1, 2>>(const Model&, Algorithm);
template std::unique_ptr<Estimator> newAoe<Sizes<1, 2>>(const Model&, ControlLink);
template std::unique_ptr<Estimator> newOptimalEstimator<Sizes<1, 2>>(const Model&, ControlLink, std::size_t);
template std::unique_ptr<Estimator> newRseio<Sizes<1, 1, 1>>(const Model&, double);

}  // namespace detail
}  // namespace networked_estimation
