// Parsing and validation of a model's `schedule` (schedule.hpp). Private to the core.
#pragma once

#include <string>
#include <vector>

#include "config/field.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/schedule.hpp"

namespace networked_estimation
{
namespace detail
{

/// Parses the `schedule` map of a model file whose sensors are known. Throws ConfigError naming
/// the key (schedule.pattern[1][0], schedule.probabilities, ...) and the problem.
Schedule parseSchedule(const Field& f, const std::vector<Sensor>& sensors);

/// The first problem of an already built schedule for `sensors` sensors: "<key>: <problem>", or ""
/// when it is fine (used by validateModel).
std::string scheduleProblem(const Schedule& schedule, std::size_t sensors);

}  // namespace detail
}  // namespace networked_estimation
