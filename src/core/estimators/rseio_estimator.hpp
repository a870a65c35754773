#pragma once

#include <memory>

#include "estimators/estimator_sizes.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/estimators/rseio.hpp"

namespace networked_estimation
{
namespace detail
{

/// RSEIO (docs/algorithms.md 4.4, 4.6), fixed-size for the sizes of RseioSizes, dynamic otherwise.
/// The estimator it returns is also an Rseio.
std::unique_ptr<Estimator> makeRseio(const Model& model, double mu, SizeChoice choice);

/// What RSEIO tells beyond the Estimator interface (any size; reached by dynamic_cast from the
/// Estimator that makeRseio returns).
class Rseio
{
public:
  virtual ~Rseio() = default;
  /// Which form the last arrival step used ("rank" or "gram"); for tests.
  virtual const char* lastForm() const = 0;
};

}  // namespace detail
}  // namespace networked_estimation
