// The one validity check of a covariance matrix (covariance.hpp).
#include "networked_estimation/common/covariance.hpp"

#include <cmath>

#include "networked_estimation/common/eigenvalues.hpp"
#include "networked_estimation/common/number_format.hpp"

namespace networked_estimation
{
namespace
{

/// The largest matrix the certificate takes (on the stack).
constexpr Eigen::Index kCertificateMax = 16;

/// The certificate of covariance.hpp: true proves that M (finite, symmetric within the tolerance,
/// n <= kCertificateMax) passes the positive definite test; false proves nothing. Plain loops on
/// the stack: C = D^-1/2 S D^-1/2 (S = (M + M') / 2), its Cholesky factor L in place, then the
/// squared Frobenius norm of L^-1 column by column (forward substitution on the unit vectors).
bool certainlyPositiveDefinite(const Eigen::Ref<const Eigen::MatrixXd>& M)
{
  const Eigen::Index n = M.rows();
  double s[kCertificateMax];
  for (Eigen::Index i = 0; i < n; ++i)
  {
    if (!(M(i, i) > 0.0))
      return false;
    s[i] = 1.0 / std::sqrt(M(i, i));
  }
  double L[kCertificateMax * kCertificateMax];  // row-major, lower triangle
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j <= i; ++j)
    {
      double v = 0.5 * (M(i, j) + M(j, i)) * s[i] * s[j];
      for (Eigen::Index k = 0; k < j; ++k)
        v -= L[i * n + k] * L[j * n + k];
      if (i == j)
      {
        if (!(v > 0.0))
          return false;
        L[i * n + i] = std::sqrt(v);
      }
      else
        L[i * n + j] = v / L[j * n + j];
    }
  double frobenius2 = 0.0;
  double x[kCertificateMax];
  for (Eigen::Index c = 0; c < n; ++c)  // column c of L^-1: L x = e_c, zero above row c
  {
    for (Eigen::Index i = c; i < n; ++i)
    {
      double v = i == c ? 1.0 : 0.0;
      for (Eigen::Index k = c; k < i; ++k)
        v -= L[i * n + k] * x[k];
      x[i] = v / L[i * n + i];
      frobenius2 += x[i] * x[i];
    }
  }
  return std::isfinite(frobenius2) && 1.0 / frobenius2 > kDefinitenessTolerance * static_cast<double>(n);
}

/// Ascending eigenvalues of a symmetric S (common/eigenvalues.hpp); false when they could not be
/// computed.
bool eigenvalues(const Eigen::MatrixXd& S, Eigen::VectorXd& ev)
{
  bool converged = false;
  ev = symmetricEigenvalues(S, &converged);
  return converged;
}

void definiteness(const Eigen::Ref<const Eigen::MatrixXd>& M, CovarianceCheck& out)
{
  const Eigen::Index n = M.rows();
  if (n == 0)
    return;
  if (out.definiteness == Definiteness::POSITIVE && n <= kCertificateMax && certainlyPositiveDefinite(M))
    return;
  const Eigen::MatrixXd S = 0.5 * (M + M.transpose());
  Eigen::VectorXd ev;
  if (!eigenvalues(S, ev))
  {
    out.problem = CovarianceCheck::Problem::NOT_DEFINITE;
    return;
  }
  out.smallest = ev(0);
  out.largest = ev(n - 1);
  const double scale = ev.cwiseAbs().maxCoeff();
  if (out.definiteness == Definiteness::SEMIDEFINITE)
  {
    if (!(out.smallest >= -kDefinitenessTolerance * scale))
      out.problem = CovarianceCheck::Problem::NOT_DEFINITE;
    return;
  }
  const Eigen::VectorXd d = S.diagonal();
  if ((d.array() > 0.0).all() && d.allFinite())
  {
    const Eigen::VectorXd inv_sqrt = d.cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd C = inv_sqrt.asDiagonal() * S * inv_sqrt.asDiagonal();
    Eigen::VectorXd sv;
    if (eigenvalues(C, sv))
    {
      out.scaled = true;
      out.scaled_smallest = sv(0);
      out.scaled_largest = sv.cwiseAbs().maxCoeff();
      if (out.scaled_smallest > kDefinitenessTolerance * out.scaled_largest)
        return;
    }
  }
  if (!(out.smallest > kDefinitenessTolerance * scale))
    out.problem = CovarianceCheck::Problem::NOT_DEFINITE;
}

std::string entry(const std::string& label, Eigen::Index i, Eigen::Index j)
{
  return label + "(" + std::to_string(i) + "," + std::to_string(j) + ")";
}

}  // namespace

CovarianceCheck checkCovariance(const Eigen::Ref<const Eigen::MatrixXd>& M, Definiteness d)
{
  CovarianceCheck out;
  out.definiteness = d;
  const Eigen::Index n = M.rows();
  if (M.cols() != n)
  {
    out.problem = CovarianceCheck::Problem::NOT_SQUARE;
    return out;
  }
  double largest = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)  // row by row: the first entry as a reader sees the matrix
    for (Eigen::Index j = 0; j < n; ++j)
    {
      if (!std::isfinite(M(i, j)))
      {
        out.problem = CovarianceCheck::Problem::NOT_FINITE;
        out.row = i;
        out.col = j;
        out.value = M(i, j);
        return out;
      }
      largest = std::max(largest, std::abs(M(i, j)));
    }
  const double tol = kSymmetryTolerance * largest;
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = i + 1; j < n; ++j)
      if (std::abs(M(i, j) - M(j, i)) > tol)
      {
        out.problem = CovarianceCheck::Problem::NOT_SYMMETRIC;
        out.row = i;
        out.col = j;
        out.value = M(i, j);
        out.mirror = M(j, i);
        return out;
      }
  definiteness(M, out);
  return out;
}

std::string CovarianceCheck::describe(const std::string& label) const
{
  switch (problem)
  {
    case Problem::NONE:
      return "";
    case Problem::NOT_SQUARE:
      return "not square";
    case Problem::NOT_FINITE:
      return "not finite (" + entry(label, row, col) + " = " + formatNumber(value) + ")";
    case Problem::NOT_SYMMETRIC:
      return "not symmetric (" + entry(label, row, col) + " = " + formatNumber(value) + " but " +
             entry(label, col, row) + " = " + formatNumber(mirror) + ")";
    case Problem::NOT_DEFINITE:
      break;
  }
  if (std::isnan(smallest))
    return "eigenvalues could not be computed";
  if (definiteness == Definiteness::SEMIDEFINITE)
    return "not positive semidefinite (smallest eigenvalue " + formatNumber(smallest, 6) + ")";
  std::string out = "not positive definite (smallest eigenvalue " + formatNumber(smallest, 6);
  if (smallest >= 0.0)
    out += ", largest " + formatNumber(largest, 6);
  out += ")";
  if (scaled && smallest >= 0.0)
    out += "; scaled to unit diagonal it is near-singular too (smallest eigenvalue " +
           formatNumber(scaled_smallest, 6) + ", largest " + formatNumber(scaled_largest, 6) + ")";
  return out;
}

}  // namespace networked_estimation
