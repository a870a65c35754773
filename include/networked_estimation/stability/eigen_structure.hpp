// Eigen-structure helpers of the stability analysis (docs/stability.md 1.3): spectral radius,
// Mahler measure, ranks and null spaces, diagonalizability, PBH observability and controllability of
// the modes, strong observability, and the FMO blocks of Marelli et al. ROS-free.
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <vector>

#include "networked_estimation/common/eigenvalues.hpp"
#include "networked_estimation/stability/verdict.hpp"

namespace networked_estimation
{

// Eigen-structure helpers

// eigenvalues(A) and spectralRadius(A): networked_estimation/common/eigenvalues.hpp
/// M(A) = prod_i max(1, |lambda_i|) (docs/stability.md 1.3).
double mahlerMeasure(const Eigen::MatrixXd& A);
/// h(A) = ln M(A).
double topologicalEntropy(const Eigen::MatrixXd& A);
/// Numerical rank: singular values above rel_tol * max(scale, largest singular value).
int numericalRank(const Eigen::MatrixXcd& M, double rel_tol = 1e-9, double scale = 0.0);
/// Orthonormal basis of the null space of M (columns), with the same rank rule.
Eigen::MatrixXcd nullSpace(const Eigen::MatrixXcd& M, double rel_tol = 1e-9, double scale = 0.0);
/// Geometric = algebraic multiplicity for every eigenvalue cluster.
bool isDiagonalizable(const Eigen::MatrixXd& A, const StabilityTolerances& tol = {});
/// rank [C; CA; ...; CA^{n-1}] = n.
bool isObservable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, double rel_tol = 1e-9);
/// PBH: rank [A - lambda I, G] = n for every eigenvalue with |lambda| >= min_modulus
/// (min_modulus = 0: full controllability).
bool modesControllable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& G, double min_modulus = 0.0,
                       double rel_tol = 1e-9);
/// PBH: rank [A - lambda I; C] = n for every eigenvalue with |lambda| >= min_modulus (min_modulus = 1:
/// detectability).
bool modesObservable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, double min_modulus = 0.0,
                     double rel_tol = 1e-9);
/// Lin et al.'s Definition 5 (docs/stability.md 1.3): A diagonalizable and, for every group of eigenvalues of equal
/// modulus, C V restricted to the group has full column rank. NOT_APPLICABLE when A is not
/// diagonalizable; STABLE stands for "strongly observable", UNSTABLE for "not strongly observable".
Verdict strongObservability(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const StabilityTolerances& tol = {});

/// One FMO block (docs/stability.md 1.3, 3.5) of the eigenvalues with modulus >= min_modulus.
struct FmoBlock
{
  std::complex<double> alpha;                     ///< a representative eigenvalue
  double modulus = 0.0;                           ///< |alpha|
  int order = 1;                                  ///< common multiplicative order N_k
  std::vector<std::complex<double>> eigenvalues;  ///< members, with algebraic multiplicity
  bool diagonalizable = true;                     ///< geometric = algebraic multiplicity for every member
  bool single_eigenvalue = true;                  ///< all members are the same eigenvalue
  Eigen::MatrixXcd basis;       ///< n x n_k: eigenvectors (diagonalizable) or generalised eigenspace basis
  Eigen::VectorXcd diagonal;    ///< diagonalizable: eigenvalue of each basis column
  Eigen::MatrixXcd eigenspace;  ///< single eigenvalue: basis of ker(A - alpha I)
};
/// Groups the eigenvalues with |lambda| >= min_modulus (relative tolerance) into FMO blocks: equal
/// modulus and argument differences / 2 pi rational with denominator <= tol.max_denominator.
/// Ordered by decreasing modulus.
std::vector<FmoBlock> fmoBlocks(const Eigen::MatrixXd& A, double min_modulus = 1.0,
                                const StabilityTolerances& tol = {});

}  // namespace networked_estimation
