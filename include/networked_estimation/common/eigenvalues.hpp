// Eigenvalue decompositions of dynamic-size matrices, compiled once (src/core/common/eigenvalues.cpp).
//
// Why functions and not Eigen's solvers at each use: each solver is a large template
// (EigenSolver brings the real Schur form and the Hessenberg reduction), and every translation unit
// that names one compiles and optimises it again: 4 to 11 CPU-seconds per unit and solver. The
// stability and simulation sources call these. The units that hold the estimators' steps or the
// per-message code (estimators/, and the unity batches with config/ and online/) keep their own
// solver calls: GCC's inlining budget grows with a unit's size, so removing code from them would
// change how their hot code is compiled. Results are Eigen's own, unchanged.
#pragma once

#include <Eigen/Core>

namespace networked_estimation
{

/// Eigenvalues of a real square A (complex, in the order of Eigen::EigenSolver; empty for an empty A).
Eigen::VectorXcd eigenvalues(const Eigen::MatrixXd& A);

/// Eigenvalues and eigenvectors of a real square A (Eigen::EigenSolver): column i of `vectors`
/// belongs to values(i).
struct EigenDecomposition
{
  Eigen::VectorXcd values;
  Eigen::MatrixXcd vectors;
};
EigenDecomposition eigenDecomposition(const Eigen::MatrixXd& A);

/// rho(A) = max |lambda_i| (0 for an empty A).
double spectralRadius(const Eigen::MatrixXd& A);

/// Eigenvalues of a symmetric S (its lower triangle is read), ascending
/// (Eigen::SelfAdjointEigenSolver without eigenvectors). `converged`, when given, says whether the
/// iteration converged (the values are unspecified otherwise).
Eigen::VectorXd symmetricEigenvalues(const Eigen::MatrixXd& S, bool* converged = nullptr);

/// Eigenvalues (ascending) and orthonormal eigenvectors (columns, in the same order) of a
/// symmetric S (Eigen::SelfAdjointEigenSolver).
struct SymmetricEigenDecomposition
{
  Eigen::VectorXd values;
  Eigen::MatrixXd vectors;
};
SymmetricEigenDecomposition symmetricEigenDecomposition(const Eigen::MatrixXd& S);

}  // namespace networked_estimation
