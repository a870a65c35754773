// Stability results about particular estimators: Lin et al.'s Theorem 5 for AOE / OE / the ACK
// Kalman filter over an on/off Markov link (docs/stability.md 3.7) and Zhou's Theorem 5 checklist for
// RSEIO (3.9). ROS-free.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/stability/link_model.hpp"
#include "networked_estimation/stability/verdict.hpp"

namespace networked_estimation
{

// Markov arrivals, Lin et al.'s Theorem 5

/// Lin et al.'s Theorem 5 (docs/stability.md 3.7): Assumption 1 (Q, R > 0; (A, C) observable;
/// (A, Q^1/2) controllable; recovery, failure in (0, 1]), Assumption 2 (diagonalizable, strongly
/// observable), then stable iff recovery > 1 - rho^{-2}. Q is the n x n process noise covariance.
Verdict aoeTheorem5(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q,
                    const Eigen::MatrixXd& R, double recovery, double failure, const StabilityTolerances& tol = {});

// ---------------------------------------------------------------------------------------------
// RSEIO, Zhou's Theorem 5 (docs/stability.md 3.9)

/// Gramians of a word r (time order, letters 0 = drop, 1 = arrival) for Phi factors
/// (A_i, G_i, W_i): O(r) = sum (A_i...A_1)' W_i (A_i...A_1) and
/// Cg(r) = sum (A_N...A_{i+1}) G_i G_i' (A_N...A_{i+1})'.
Eigen::MatrixXd wordObservabilityGramian(const std::vector<int>& word, const Eigen::MatrixXd& A1,
                                         const Eigen::MatrixXd& W1, const Eigen::MatrixXd& A2);
Eigen::MatrixXd wordControllabilityGramian(const std::vector<int>& word, const Eigen::MatrixXd& A1,
                                           const Eigen::MatrixXd& G1, const Eigen::MatrixXd& A2,
                                           const Eigen::MatrixXd& G2);
/// Zhou's Theorem 5 checklist (docs/stability.md 3.9) for the model, mu and the arrival link of the whole
/// measurement. STABLE means "P_{t|t} converges to a unique stationary distribution" (sufficient
/// conditions hold); UNDECIDED when a sufficient condition fails; NOT_APPLICABLE when A, Acheck or
/// Atil is singular or the link is outside the theorem (e.g. a hidden GE chain).
Verdict rseioTheorem5(const Model& model, double mu, const LinkModel& link, const StabilityTolerances& tol = {});

}  // namespace networked_estimation
