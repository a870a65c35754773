// Yang et al.'s bounds and capacities (bounds.hpp; docs/stability.md 3.1, 3.3, 3.8).
#include "networked_estimation/stability/bounds.hpp"
#include "networked_estimation/stability/eigen_structure.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stability_internal.hpp"

namespace networked_estimation
{

using stability_internal::nullSpaceReal;
using stability_internal::sym;

double sinopoliLowerBound(double rho, int sensors)
{
  if (rho <= 1.0 || sensors <= 0)
    return 0.0;
  return 1.0 - std::pow(rho, -2.0 / sensors);
}

double mahlerUpperBound(double mahler)
{
  return mahler <= 1.0 ? 0.0 : 1.0 - 1.0 / (mahler * mahler);
}

double aoeRecoveryThreshold(double rho)
{
  return 1.0 - 1.0 / (rho * rho);
}

Capacity transmissionCapacity(const Eigen::MatrixXd& A, const std::vector<double>& rates,
                              const std::vector<int>& sensor_rows)
{
  Capacity c;
  for (std::size_t i = 0; i < rates.size(); ++i)
  {
    const double ci = -0.5 * std::log1p(-rates[i]);
    c.individual.push_back(ci);
    c.total += ci;
    c.loss_product *= 1.0 - rates[i];
    c.weighted += (i < sensor_rows.size() ? sensor_rows[i] : 1) * ci;
  }
  c.lower = std::log(spectralRadius(A));
  c.upper = topologicalEntropy(A);
  c.log_abs_det = std::log(std::abs(A.determinant()));
  return c;
}

EntropySplit entropySplit(const Eigen::MatrixXd& A, const std::vector<Eigen::MatrixXd>& H, double rel_tol)
{
  const int n = static_cast<int>(A.rows());
  EntropySplit out;
  int rows = 0;
  for (const auto& h : H)
    rows += static_cast<int>(h.rows());
  Eigen::MatrixXd stacked(rows, n);
  int r0 = 0;
  for (const auto& h : H)
  {
    stacked.middleRows(r0, h.rows()) = h;
    r0 += static_cast<int>(h.rows());
  }
  out.observable = rows > 0 && isObservable(A, stacked, rel_tol);
  Eigen::MatrixXd U = Eigen::MatrixXd::Identity(n, n);
  double h_prev = topologicalEntropy(A);
  Eigen::MatrixXd obs(0, n);
  for (const auto& h : H)
  {
    double best = 0.0;
    for (int i = 0; i < h.rows(); ++i)
    {
      Eigen::MatrixXd cand(obs.rows() + n, n);
      cand.topRows(obs.rows()) = obs;
      Eigen::RowVectorXd row = h.row(i);
      for (int k = 0; k < n; ++k)
      {
        cand.row(obs.rows() + k) = row / std::max(1e-300, row.norm());
        row = row * A;
      }
      const Eigen::MatrixXd Un = nullSpaceReal(cand, rel_tol);
      if (Un.cols() < U.cols())
      {
        const double h_new = Un.cols() ? topologicalEntropy(Un.transpose() * A * Un) : 0.0;
        best = std::max(best, h_prev - h_new);
        h_prev = h_new;
        U = Un;
        obs = cand;
      }
    }
    out.max_block_entropy.push_back(best);
    out.sum += best;
    out.sufficient_rate.push_back(1.0 - std::exp(-2.0 * best));
  }
  if (out.observable)
  {
    out.common_rate = 0.0;
    for (double r : out.sufficient_rate)
      out.common_rate = std::max(out.common_rate, r);
  }
  return out;
}

Eigen::MatrixXd lowerBoundStep(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, double loss_product,
                               const Eigen::MatrixXd& G)
{
  return loss_product * A * G * A.transpose() + Q;
}

Eigen::MatrixXd lowerBoundLimit(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, double loss_product)
{
  const double rho = spectralRadius(A);
  if (loss_product * rho * rho >= 1.0)
    throw std::domain_error("lower bound G_k diverges: prod(1 - lambda_i) rho(A)^2 >= 1");
  const int n = static_cast<int>(A.rows());
  // (I - c A (x) A) vec(G) = vec(Q), column-major vec.
  Eigen::MatrixXd K(n * n, n * n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      K.block(i * n, j * n, n, n) = A(i, j) * A;
  const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(n * n, n * n) - loss_product * K;
  const Eigen::VectorXd q = Eigen::Map<const Eigen::VectorXd>(Q.data(), n * n);
  const Eigen::VectorXd g = M.partialPivLu().solve(q);
  return sym(Eigen::Map<const Eigen::MatrixXd>(g.data(), n, n));
}

Eigen::MatrixXd informationLowerBoundLimit(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& S,
                                           int max_iterations)
{
  const int n = static_cast<int>(A.rows());
  Eigen::MatrixXd X = Q;
  for (int k = 0; k < max_iterations; ++k)
  {
    const Eigen::MatrixXd post = (Eigen::MatrixXd::Identity(n, n) + X * S).partialPivLu().solve(X);
    const Eigen::MatrixXd Xn = sym(A * post * A.transpose() + Q);
    const double d = (Xn - X).norm();
    X = Xn;
    if (!X.allFinite())
      break;
    if (d < 1e-14 * std::max(1.0, X.norm()))
      return X;
  }
  throw std::domain_error("information lower bound F_k did not converge");
}

}  // namespace networked_estimation
