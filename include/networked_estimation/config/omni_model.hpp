// The model file of a robot with a built-in nonlinear motion, omni_2d or omni_3d (docs/formats.md
// 1.7b, docs/algorithms.md 7): what make_model writes for `--motion omni_2d | omni_3d`.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// One sensor: it measures the named states (one row each, C their unit rows), R = diag(sigma^2).
struct OmniSensor
{
  std::string name;
  std::vector<std::string> states;  ///< state names of the motion, at least one, each once
  std::vector<double> sigmas;       ///< one per state, or one for all
};

struct OmniSpec
{
  std::string name = "robot";
  std::string motion;                 ///< "omni_2d" or "omni_3d"
  double rate = 0.0;                  ///< Hz; the period is 1 / rate
  std::vector<double> process_noise;  ///< Q's diagonal per second: n values, or one for all
  std::vector<OmniSensor> sensors;    ///< at least one
  std::vector<double> x0;             ///< empty: zeros; else n values
  std::vector<double> p0;             ///< P0's diagonal: empty (1 each), one value, or n values
  bool two_d_mode = false;            ///< omni_3d only
  /// How a message names a key ("rate", "sensors[1].states", ...): make_model names the option the
  /// user typed, as for a kinematic model. Empty: the key itself.
  std::function<std::string(const std::string& key)> key_name;
};

/// Builds and validates (validateModel) the model. Throws ConfigError naming the option (motion,
/// rate, process-noise, sensors[i].states / .sigma / .name, x0, p0, two-d-mode, each through
/// spec.key_name when given) and what was found.
Model makeOmniModel(const OmniSpec& spec);

/// The comment describing the model: the motion, the state, the process noise, the sensors.
std::string omniModelComment(const OmniSpec& spec);

}  // namespace networked_estimation
