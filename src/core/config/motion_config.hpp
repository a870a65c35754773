// The model file's keys of a built-in motion (docs/formats.md 1.7b): `motion`, `two_d_mode`, and
// what they exclude (A, B, control, uncertainty) or fix (states, angles).
#pragma once

#include <string>
#include <utility>

#include "config/field.hpp"
#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{
namespace detail
{

/// `motion` (f) of a model file (map): reads it, refuses A, B, control and uncertainty (they belong
/// to linear models) and a missing period; sets the model's motion, A empty, B = I, and the
/// motion's state names and angles. Fails naming the key.
void readMotion(const Field& f, const Field& map, Model& model);
/// `two_d_mode`: only with motion omni_3d.
void readTwoDMode(const Field& f, Model& model);
/// For a motion model, `states` and `angles` when given must be the motion's.
void checkMotionStates(const Field& f, const Model& model);
void checkMotionAngles(const Field& f, const Model& model);
/// validateModel's checks of a built-in motion (A empty, B = I, no control, no uncertainty, the
/// motion's states and angles, two_d_mode only for omni_3d, a period): {key, problem}, or empty.
std::pair<std::string, std::string> motionModelProblem(const Model& model);

/// For a motion model with its Q (n x n) and a period > 0: why one step of the period is not a
/// finite step ("expected a number of seconds over which ..., found <period> (...)"), or "". The
/// motion's Jacobian has period and period^2 / 2 terms (at the zero state, to blame the period and
/// not x0), and the process noise of a step is Q period: each must stay finite.
std::string motionPeriodProblem(const Model& model);

}  // namespace detail
}  // namespace networked_estimation
