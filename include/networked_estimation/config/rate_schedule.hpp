// Sensors at their own rates as a sensor schedule, so that the stability analysis (which works on
// the model's steps) sees a 2 Hz GNSS in a 50 Hz model as a sensor that can only arrive at every
// 25th step. A sensor with rate ratio q (the model's rate over the sensor's, a whole number) is
// scheduled at the steps k with (k - 1) mod q = 0; the pattern's period is the least common
// multiple of the ratios (and of the model's own periodic schedule, which it refines).
#pragma once

#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// Largest period of the combined pattern (the analysis' cost grows with it).
constexpr int kMaxRateSchedulePeriod = 10000;

/// `model` with the sensors' rates in its schedule. Unchanged when every ratio is 1. When the rates
/// cannot be written as a periodic schedule (a ratio that is not a whole number, a random schedule
/// in the model, a period above kMaxRateSchedulePeriod) the model is returned unchanged and
/// `note` (if given) says why: its verdicts then assume every sensor can arrive at every step.
Model withSensorRates(const Model& model, const std::vector<double>& ratio, std::string* note = nullptr);

}  // namespace networked_estimation
