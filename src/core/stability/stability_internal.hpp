// Small helpers shared by the stability sources (private to the core).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "networked_estimation/common/eigenvalues.hpp"
#include "networked_estimation/stability/exact_test.hpp"

namespace networked_estimation
{
namespace stability_internal
{

inline Eigen::MatrixXd sym(const Eigen::MatrixXd& X)
{
  return 0.5 * (X + X.transpose());
}

/// Orthonormal real basis of the null space of M.
inline Eigen::MatrixXd nullSpaceReal(const Eigen::MatrixXd& M, double rel_tol)
{
  const int n = static_cast<int>(M.cols());
  if (M.rows() == 0)
    return Eigen::MatrixXd::Identity(n, n);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  const double thr = rel_tol * std::max(1.0, sv.size() ? sv[0] : 0.0);
  int r = 0;
  for (int i = 0; i < sv.size(); ++i)
    r += sv[i] > thr ? 1 : 0;
  return svd.matrixV().rightCols(n - r);
}

inline bool isPd(const Eigen::MatrixXd& S)
{
  Eigen::LLT<Eigen::MatrixXd> llt(sym(S));
  return llt.info() == Eigen::Success;
}

/// lambda_min / lambda_max of a symmetric PSD matrix (0 for the zero matrix).
inline double conditionRatio(const Eigen::MatrixXd& S)
{
  const Eigen::VectorXd ev = symmetricEigenDecomposition(sym(S)).values;
  const double mx = ev.maxCoeff();
  return mx > 0.0 ? ev.minCoeff() / mx : 0.0;
}

/// Spectral radius of a small matrix (the per-link operators of the exact test).
inline double spectralRadiusSmall(const Eigen::MatrixXd& M)
{
  if (M.rows() == 1)
    return std::abs(M(0, 0));
  return spectralRadius(M);
}

/// The growth of one link's operator over a window (product of D_s P), to the power `exponent`, and
/// whether its spectral radius is exactly 1 (exact_test.cpp).
BlockGrowth linkGrowth(const Eigen::MatrixXd& product, double exponent);

}  // namespace stability_internal
}  // namespace networked_estimation
