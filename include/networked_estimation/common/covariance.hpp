// The one validity check of a covariance matrix. Every covariance the package takes is checked by
// it: the configuration's Q, R, P0 (model files, kinematic models), each message's covariance of
// its fields, a step's own R (Sample::R), set_pose and OnlineEstimator::setEstimate.
//
//   finite                 every entry;
//   symmetric              |M(i,j) - M(j,i)| <= kSymmetryTolerance * max |M| (relative: the same
//                          verdict in any units);
//   positive definite      smallest eigenvalue > kDefinitenessTolerance * largest, of M scaled to
//                          unit diagonal (D^-1/2 M D^-1/2, D = diag M > 0) or else of M itself. The
//                          scaling is what decides whether Cholesky, which the filters use, works on
//                          M: a covariance whose variables have very different units (an exact Q at
//                          1 kHz spans T^5 to T) is well conditioned in it;
//   positive semidefinite  smallest eigenvalue >= -kDefinitenessTolerance * largest |eigenvalue|.
// The eigenvalues are of the symmetric part (M + M') / 2.
//
// Cost: a positive definite matrix is usually accepted without eigenvalues, by a certificate that
// gives the same verdict: with C = L L' (Cholesky of the scaled matrix), lambda_min(C) >=
// 1 / ||L^-1||_F^2 and lambda_max(C) <= trace C = n, so 1 / ||L^-1||_F^2 > tol * n proves the
// test passes. Only when it does not prove it (or for a refusal's message) are the eigenvalues
// computed. Up to 16 x 16 nothing is allocated on that path (a message's covariance per message).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>

namespace networked_estimation
{

/// Relative tolerance of the symmetry test.
constexpr double kSymmetryTolerance = 1e-9;
/// Relative tolerance of the definiteness tests.
constexpr double kDefinitenessTolerance = 1e-12;

enum class Definiteness
{
  POSITIVE,      ///< positive definite (R, Q of a model, a message's covariance)
  SEMIDEFINITE,  ///< positive semidefinite (P0, a pose set by set_pose: exact entries may be 0)
};

/// The outcome of checkCovariance: what is wrong (the first problem in the order finite,
/// symmetric, definite) and the numbers that show it.
struct CovarianceCheck
{
  enum class Problem
  {
    NONE,
    NOT_SQUARE,
    NOT_FINITE,     ///< entry (row, col) is not finite
    NOT_SYMMETRIC,  ///< entries (row, col) and (col, row) differ beyond the tolerance
    NOT_DEFINITE,   ///< the definiteness test failed (smallest / largest eigenvalues below)
  };
  Problem problem = Problem::NONE;
  Definiteness definiteness = Definiteness::POSITIVE;
  Eigen::Index row = -1, col = -1;
  double value = 0.0, mirror = 0.0;                            ///< M(row, col) and M(col, row)
  double smallest = std::numeric_limits<double>::quiet_NaN();  ///< eigenvalues of M
  double largest = std::numeric_limits<double>::quiet_NaN();
  bool scaled = false;  ///< the scaled matrix's eigenvalues were computed too
  double scaled_smallest = std::numeric_limits<double>::quiet_NaN();
  double scaled_largest = std::numeric_limits<double>::quiet_NaN();

  bool ok() const { return problem == Problem::NONE; }
  /// The problem in words, entries named label(i,j), e.g. "not symmetric (R(0,1) = 1 but R(1,0) =
  /// 2)", "not positive definite (smallest eigenvalue -1, largest 3)"; "" when ok.
  std::string describe(const std::string& label) const;
};

/// Checks M (any size; a non-square M is NOT_SQUARE).
CovarianceCheck checkCovariance(const Eigen::Ref<const Eigen::MatrixXd>& M, Definiteness definiteness);

}  // namespace networked_estimation
