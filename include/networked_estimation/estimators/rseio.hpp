// Pieces of Zhou's robust estimator (docs/algorithms.md section 4) that are useful outside the
// estimator itself: the sensitivity matrices S, T (4.3) and the Theorem 2 "analysis form" (4.9)
// used by tests and by the convergence analysis.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "networked_estimation/config/model.hpp"

namespace networked_estimation
{

/// S (r x n), T (r x nw) and Sc (r x n), r = 2 n_e m_a, for the measurement rows `rows` of the
/// stacked y (empty = all rows). Row blocks per parameter k: [C dA_k ; dC_k A], [C dB_k ; dC_k B],
/// [0 ; dC_k] (the control-input sensitivity of docs/algorithms.md 4.6).
struct RseioSensitivity
{
  Eigen::MatrixXd S, T, Sc;
};
RseioSensitivity rseioSensitivity(const Model& model, const std::vector<int>& rows = {});

/// lambda = (1 - mu) / mu for mu in (0, 1]; throws ConfigError otherwise.
double rseioLambda(double mu);

/// Theorem 2 data (docs/algorithms.md 4.9) for all sensors:
///   P+^{-1} = [Atil P Atil' + B Qtil B']^{-1} + Ctil' Rtil^{-1} Ctil.
struct RseioAnalysisForm
{
  Eigen::MatrixXd Qcheck, Acheck, Stil, Atil, Qtil, Ctil, Rtil;
  /// Applies (9) to P (requires the bracket to be invertible). Returns P+.
  Eigen::MatrixXd arrivalCovariance(const Eigen::MatrixXd& P, const Eigen::MatrixXd& B) const;
};
/// Throws ConfigError naming the problem when Acheck is singular (Theorem 2 does not apply).
RseioAnalysisForm rseioAnalysisForm(const Model& model, double mu);

}  // namespace networked_estimation
