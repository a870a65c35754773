// The one covariance check (common/covariance.hpp): its rules, its messages, and that the fast
// certificate never changes a verdict of the eigenvalue test.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "networked_estimation/common/covariance.hpp"

using Eigen::MatrixXd;
using networked_estimation::checkCovariance;
using networked_estimation::CovarianceCheck;
using networked_estimation::Definiteness;

namespace
{

/// The positive definite rule of covariance.hpp, by eigenvalues only (no certificate).
bool positiveDefiniteByEigenvalues(const MatrixXd& M)
{
  const MatrixXd S = 0.5 * (M + M.transpose());
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<MatrixXd>(S, Eigen::EigenvaluesOnly).eigenvalues();
  const Eigen::VectorXd d = S.diagonal();
  if ((d.array() > 0.0).all())
  {
    const Eigen::VectorXd s = d.cwiseSqrt().cwiseInverse();
    const MatrixXd C = s.asDiagonal() * S * s.asDiagonal();
    const Eigen::VectorXd cv = Eigen::SelfAdjointEigenSolver<MatrixXd>(C, Eigen::EigenvaluesOnly).eigenvalues();
    if (cv(0) > 1e-12 * cv.cwiseAbs().maxCoeff())
      return true;
  }
  return ev(0) > 1e-12 * ev.cwiseAbs().maxCoeff();
}

}  // namespace

TEST(Covariance, SymmetryIsRelativeToTheLargestEntry)
{
  MatrixXd M(2, 2);
  M << 2.0, 1.0, 1.0 + 1e-10, 2.0;  // 1e-10 apart: within 1e-9 * 2
  EXPECT_TRUE(checkCovariance(M, Definiteness::POSITIVE).ok());
  M(1, 0) = 1.0 + 1e-8;  // beyond
  const CovarianceCheck c = checkCovariance(M, Definiteness::POSITIVE);
  EXPECT_EQ(c.problem, CovarianceCheck::Problem::NOT_SYMMETRIC);
  EXPECT_EQ(c.describe("R"), "not symmetric (R(0,1) = 1 but R(1,0) = 1.00000001)");
  // The same verdicts in any units: scaled by 1e-20 (an absolute tolerance, or one of at least 1,
  // would let the asymmetry through).
  EXPECT_EQ(checkCovariance(1e-20 * M, Definiteness::POSITIVE).problem, CovarianceCheck::Problem::NOT_SYMMETRIC);
  EXPECT_EQ(checkCovariance(1e-20 * M, Definiteness::SEMIDEFINITE).problem, CovarianceCheck::Problem::NOT_SYMMETRIC);
  M(1, 0) = 1.0;
  EXPECT_TRUE(checkCovariance(1e-20 * M, Definiteness::POSITIVE).ok());
}

TEST(Covariance, FirstNonFiniteEntryRowByRow)
{
  MatrixXd M = MatrixXd::Identity(3, 3);
  M(2, 0) = std::numeric_limits<double>::quiet_NaN();
  M(1, 2) = std::numeric_limits<double>::infinity();
  const CovarianceCheck c = checkCovariance(M, Definiteness::SEMIDEFINITE);
  EXPECT_EQ(c.problem, CovarianceCheck::Problem::NOT_FINITE);
  EXPECT_EQ(c.describe("P0"), "not finite (P0(1,2) = inf)");
  EXPECT_EQ(checkCovariance(MatrixXd::Zero(2, 3), Definiteness::POSITIVE).problem,
            CovarianceCheck::Problem::NOT_SQUARE);
}

TEST(Covariance, Definiteness)
{
  MatrixXd singular(2, 2);
  singular << 1.0, 1.0, 1.0, 1.0;
  EXPECT_TRUE(checkCovariance(singular, Definiteness::SEMIDEFINITE).ok());
  const CovarianceCheck pd = checkCovariance(singular, Definiteness::POSITIVE);
  EXPECT_EQ(pd.problem, CovarianceCheck::Problem::NOT_DEFINITE);
  EXPECT_EQ(pd.describe("R").rfind("not positive definite (smallest eigenvalue ", 0), 0u) << pd.describe("R");
  MatrixXd indefinite(2, 2);
  indefinite << 1.0, 2.0, 2.0, 1.0;
  const CovarianceCheck semi = checkCovariance(indefinite, Definiteness::SEMIDEFINITE);
  EXPECT_EQ(semi.describe("P0"), "not positive semidefinite (smallest eigenvalue -1)");
  EXPECT_DOUBLE_EQ(semi.smallest, -1.0);
  EXPECT_TRUE(checkCovariance(MatrixXd(0, 0), Definiteness::POSITIVE).ok());
}

// The exact Q of a constant-acceleration axis at 1 kHz: entries from T^5 / 20 to T, eigenvalues
// spanning far more than 12 orders of magnitude, but well conditioned scaled to unit diagonal.
TEST(Covariance, ScaledToUnitDiagonal)
{
  const double T = 1e-3;
  MatrixXd Q(3, 3);
  Q << std::pow(T, 5) / 20, std::pow(T, 4) / 8, std::pow(T, 3) / 6,  //
      std::pow(T, 4) / 8, std::pow(T, 3) / 3, T * T / 2,             //
      std::pow(T, 3) / 6, T * T / 2, T;
  EXPECT_TRUE(checkCovariance(Q, Definiteness::POSITIVE).ok());
  EXPECT_TRUE(positiveDefiniteByEigenvalues(Q));
}

// The certificate that spares the eigenvalues gives the eigenvalue test's verdict on random
// matrices from well conditioned to singular and indefinite, at sizes with the certificate
// (<= 16) and without (20). Fixed seed.
TEST(Covariance, CertificateKeepsTheVerdict)
{
  std::mt19937 rng(38);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> exponent(-16.0, 1.0);
  int accepted = 0, refused = 0;
  for (int trial = 0; trial < 3000; ++trial)
  {
    const int n = trial % 3 == 0 ? 20 : 1 + trial % 16;
    MatrixXd V(n, n);
    for (int i = 0; i < V.size(); ++i)
      V(i) = normal(rng);
    const Eigen::HouseholderQR<MatrixXd> qr(V);
    const MatrixXd U = qr.householderQ();
    Eigen::VectorXd ev(n);
    for (int i = 0; i < n; ++i)
      ev(i) = std::pow(10.0, exponent(rng)) * (trial % 7 == 0 && i == 0 ? -1.0 : 1.0);
    if (trial % 11 == 0)
      ev(0) = 0.0;
    MatrixXd M = U * ev.asDiagonal() * U.transpose();
    M = 0.5 * (M + M.transpose()).eval();
    Eigen::VectorXd units(n);  // variables in very different units
    for (int i = 0; i < n; ++i)
      units(i) = std::pow(10.0, exponent(rng) * 3.0);
    M = units.asDiagonal() * M * units.asDiagonal();
    const bool expected = positiveDefiniteByEigenvalues(M);
    const CovarianceCheck c = checkCovariance(M, Definiteness::POSITIVE);
    EXPECT_EQ(c.ok(), expected) << "trial " << trial << " n " << n << ": " << c.describe("M");
    (expected ? accepted : refused)++;
  }
  // Both verdicts are exercised many times.
  EXPECT_GT(accepted, 500);
  EXPECT_GT(refused, 500);
}
