// Error types of the ROS-free core. Every message names the source (file or topic), the key or
// field, and what was expected versus what was found.
#pragma once

#include <stdexcept>
#include <string>

namespace networked_estimation
{

/// A model, estimator-settings or channel-settings file (or parameter set) is invalid.
class ConfigError : public std::runtime_error
{
public:
  explicit ConfigError(const std::string& what) : std::runtime_error(what) {}
};

/// A data input (CSV row, measurement) is invalid.
class InputError : public std::runtime_error
{
public:
  explicit InputError(const std::string& what) : std::runtime_error(what) {}
};

/// The estimator's covariance stopped being finite (the expected error is unbounded).
/// The estimator must be reset() before it is stepped again.
class DivergenceError : public std::runtime_error
{
public:
  explicit DivergenceError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace networked_estimation
