// Writing a model file (docs/formats.md, "Model file") that loadModel reads back to the same
// matrices, bit for bit: every number is written with the fewest digits that round-trip exactly.
#pragma once

#include <ostream>
#include <string>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// Writes `comment` (each line prefixed with "# ") and the keys name, period (when set), states and
/// angles (when given; angles by name when the states are named), motion (or A), B (when not the
/// identity), Q, sensors, x0, P0, and control, uncertainty and schedule when the model has them.
/// Throws ConfigError for a model that fails validateModel.
void writeModelYaml(std::ostream& out, const Model& model, const std::string& comment);

}  // namespace networked_estimation
