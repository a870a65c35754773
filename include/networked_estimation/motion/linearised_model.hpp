// The linear model of a built-in motion around one state (docs/stability.md 5): what the link
// verdicts of `analyze` and the Estimator's live diagnostic examine for an omni model. A local
// verdict: it holds near that state, for the modes the linearisation has there.
#pragma once

#include <Eigen/Core>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// For a model with a built-in motion: the linear model x_k = F x_{k-1} + w, F = df/dx at `at`
/// over `dt` seconds (> 0), w ~ N(0, Q dt), the same sensors, x0 = at, P0, state names; no angles
/// (F's columns of the angles are not unit vectors: the linearisation is not periodic in them).
/// A linear model is returned as it is. Throws ConfigError for a wrong size of `at` or a bad dt.
Model linearisedModel(const Model& model, const Eigen::VectorXd& at, double dt);

}  // namespace networked_estimation
