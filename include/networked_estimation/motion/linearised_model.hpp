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
/// A linear model is returned as it is. Throws ConfigError "linearisation of model '<name>': ..."
/// for a bad dt or a state `at` that linearisationStateProblem refuses.
Model linearisedModel(const Model& model, const Eigen::VectorXd& at, double dt);

/// Why `at` is not a state to linearise `model` (a built-in motion) at over `dt` seconds (> 0), or
/// "" when it is one: "expected a finite state of n values (<motion>: x, y, ...), found <size>
/// (<values>)", "entry i (<state>): expected a finite number, found nan", or "the Jacobian of
/// <motion> there over dt s is not finite (F(i,j) = inf): expected a state of smaller values, found
/// [...]". Callers put the key in front (analyze's "option '--at'", Python's "analyze(): at").
std::string linearisationStateProblem(const Model& model, const Eigen::VectorXd& at, double dt);

}  // namespace networked_estimation
