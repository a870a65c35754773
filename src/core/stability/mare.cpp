// The MARE upper bound, its certificate and the bisection on a common rate (bounds.hpp;
// docs/stability.md 3.2).
#include "networked_estimation/stability/bounds.hpp"
#include "networked_estimation/stability/eigen_structure.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "stability_internal.hpp"

namespace networked_estimation
{

using stability_internal::isPd;
using stability_internal::sym;

// ---------------------------------------------------------------------------------------------

Mare::Mare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::vector<Eigen::MatrixXd>& H,
           const std::vector<double>& rates)
  : A_(A), Q_(Q)
{
  const int n = static_cast<int>(A.rows());
  int m = 0;
  for (std::size_t i = 0; i < H.size(); ++i)
    if (rates[i] > 0.0)
      m += static_cast<int>(H[i].rows());
  H_.resize(m, n);
  W_ = Eigen::MatrixXd::Ones(m, m);
  lambda_rows_.resize(m);
  sigma_rows_.resize(m);
  int off = 0;
  for (std::size_t i = 0; i < H.size(); ++i)
  {
    if (rates[i] <= 0.0)
      continue;
    const int p = static_cast<int>(H[i].rows());
    const double l = std::min(1.0, rates[i]);
    H_.middleRows(off, p) = H[i];
    W_.block(off, off, p, p).array() += (1.0 - l) / l;  // 1 / q_i
    lambda_rows_.segment(off, p).setConstant(l);
    sigma_rows_.segment(off, p).setConstant(std::sqrt(l * (1.0 - l)));
    offset_.push_back(off);
    size_.push_back(p);
    off += p;
  }
}

Eigen::MatrixXd Mare::step(const Eigen::MatrixXd& X) const
{
  const int m = static_cast<int>(H_.rows());
  const Eigen::MatrixXd AX = A_ * X;
  Eigen::MatrixXd out = AX * A_.transpose() + Q_;
  if (m > 0)
  {
    const Eigen::MatrixXd HX = H_ * X;
    const Eigen::MatrixXd S = W_.cwiseProduct(HX * H_.transpose() + Eigen::MatrixXd::Identity(m, m));
    const Eigen::MatrixXd K = AX * H_.transpose();  // A X H'
    out -= K * S.llt().solve(K.transpose());
  }
  return sym(out);
}

Eigen::MatrixXd Mare::gain(const Eigen::MatrixXd& X) const
{
  const int m = static_cast<int>(H_.rows());
  if (m == 0)
    return Eigen::MatrixXd::Zero(A_.rows(), 0);
  const Eigen::MatrixXd S = W_.cwiseProduct(H_ * X * H_.transpose() + Eigen::MatrixXd::Identity(m, m));
  const Eigen::MatrixXd G = S.llt().solve(H_ * X * A_.transpose()).transpose();  // A X H' S^{-1}
  return G * lambda_rows_.cwiseInverse().asDiagonal();
}

double Mare::certificateRadius(const Eigen::MatrixXd& X) const
{
  const int n = static_cast<int>(A_.rows());
  const Eigen::MatrixXd L = gain(X);
  std::vector<Eigen::MatrixXd> Ms;
  Ms.push_back(A_ - L * lambda_rows_.asDiagonal() * H_);
  for (std::size_t i = 0; i < offset_.size(); ++i)
  {
    const double sigma = sigma_rows_[offset_[i]];
    if (sigma > 0.0)
      Ms.push_back(sigma * L.middleCols(offset_[i], size_[i]) * H_.middleRows(offset_[i], size_[i]));
  }
  if (n <= kKroneckerStates)
  {
    Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n * n, n * n);
    for (const auto& M : Ms)
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
          T.block(i * n, j * n, n, n) += M(i, j) * M;
    return spectralRadius(T);
  }
  return positiveMapRadiusBound(Ms);
}

double positiveMapRadiusBound(const std::vector<Eigen::MatrixXd>& Ms, int max_iterations, double rel_gap)
{
  // T(Y) = sum M Y M' maps the cone of positive semidefinite matrices into itself. For any Y > 0,
  // T(Y) <= c Y with c = lambda_max(Y^-1/2 T(Y) Y^-1/2) gives T^k(Y) <= c^k Y, hence rho(T) <= c; and
  // T(Y) >= c_min Y gives rho(T) >= c_min. Power iterates Y_{k+1} = T(Y_k) (normalised, kept
  // definite) tighten both towards rho(T).
  const Eigen::Index n = Ms.front().rows();
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd Y = I;
  double best = std::numeric_limits<double>::infinity();
  for (int k = 1; k <= max_iterations; ++k)
  {
    Eigen::MatrixXd Z = Eigen::MatrixXd::Zero(n, n);
    for (const auto& M : Ms)
      Z.noalias() += M * Y * M.transpose();
    Z = sym(Z);
    if (!Z.allFinite())
      return best;
    if (k % 5 == 0 || k == max_iterations)
    {
      const Eigen::LLT<Eigen::MatrixXd> llt(Y);
      const Eigen::MatrixXd W = llt.matrixL().solve(llt.matrixL().solve(Z).transpose());
      const Eigen::VectorXd ev = symmetricEigenvalues(sym(W));
      best = std::min(best, ev.maxCoeff());
      if (best - ev.minCoeff() <= rel_gap * best)
        return best;
    }
    const double scale = Z.trace();
    if (!(scale > 0.0))
      return 0.0;  // T(Y) = 0 for a definite Y: T is nilpotent on the cone's interior
    Y = Z / scale + 1e-12 * I;
  }
  return best;
}

namespace
{

/// Cheap sufficient test for rho(T_L) < 1 with L = L(X): T is a positive map, so T^k(I) < I for
/// some k implies rho(T) < 1.
bool quickCertificate(const Mare& mare, const Eigen::MatrixXd& A, const Eigen::MatrixXd& X,
                      const Eigen::VectorXd& lambda_rows, const Eigen::VectorXd& sigma_rows,
                      const std::vector<int>& offset, const std::vector<int>& size)
{
  const int n = static_cast<int>(A.rows());
  const Eigen::MatrixXd L = mare.gain(X);
  const Eigen::MatrixXd& H = mare.stackedH();
  const Eigen::MatrixXd M0 = A - L * lambda_rows.asDiagonal() * H;
  std::vector<Eigen::MatrixXd> Ms;
  for (std::size_t i = 0; i < offset.size(); ++i)
    Ms.push_back(sigma_rows[offset[i]] * L.middleCols(offset[i], size[i]) * H.middleRows(offset[i], size[i]));
  Eigen::MatrixXd Y = Eigen::MatrixXd::Identity(n, n);
  for (int k = 0; k < 400; ++k)
  {
    Eigen::MatrixXd Yn = M0 * Y * M0.transpose();
    for (const auto& M : Ms)
      Yn += M * Y * M.transpose();
    Y = sym(Yn);
    if (!Y.allFinite() || Y.trace() > 1e12)
      return false;
    if (isPd(Eigen::MatrixXd::Identity(n, n) - Y))
      return true;
  }
  return false;
}

}  // namespace

MareResult solveMare(const Mare& mare, const MareOptions& options, bool stop_at_certificate)
{
  MareResult res;
  const Eigen::MatrixXd& A = mare.A_;
  const int n = static_cast<int>(A.rows());
  Eigen::MatrixXd X = Eigen::MatrixXd::Zero(n, n);
  double prev_d = std::numeric_limits<double>::infinity();
  int decreasing = 0;
  for (int k = 1; k <= options.max_iterations; ++k)
  {
    const Eigen::MatrixXd Xn = mare.step(X);
    const double d = (Xn - X).norm();
    X = Xn;
    res.iterations = k;
    if (!X.allFinite() || X.trace() > options.divergence_trace)
    {
      res.status = MareResult::Status::DIVERGED;
      res.X = X;
      return res;
    }
    if (d < options.tolerance * std::max(1.0, X.norm()))
    {
      res.X = X;
      res.certificate = mare.certificateRadius(X);
      res.status = res.certificate < 1.0 ? MareResult::Status::CONVERGED : MareResult::Status::UNDECIDED;
      return res;
    }
    decreasing = d < prev_d ? decreasing + 1 : 0;
    prev_d = d;
    // The certificate costs up to 400 iterations of the (1 + N)-term Lyapunov-like map: tried at
    // k = 64, 128, 256, ... (and at the last iteration), not every 64 iterations.
    const bool try_now = (k >= 64 && (k & (k - 1)) == 0) || k == options.max_iterations;
    if (stop_at_certificate && decreasing >= 20 && try_now &&
        quickCertificate(mare, A, X, mare.lambda_rows_, mare.sigma_rows_, mare.offset_, mare.size_))
    {
      res.X = X;
      res.certificate = mare.certificateRadius(X);
      if (res.certificate < 1.0)
      {
        res.status = MareResult::Status::CONVERGED;
        return res;
      }
    }
  }
  res.X = X;
  res.status = MareResult::Status::UNDECIDED;
  return res;
}

CriticalBand mareCriticalRate(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::vector<Eigen::MatrixXd>& H,
                              double lo, double hi, double tolerance, const MareOptions& options)
{
  CriticalBand band;
  auto status = [&](double lambda)
  {
    ++band.evaluations;
    const Mare mare(A, Q, H, std::vector<double>(H.size(), lambda));
    return solveMare(mare, options, true).status;
  };
  using S = MareResult::Status;
  if (status(hi) != S::CONVERGED)
  {
    if (hi < 1.0 && status(1.0) == S::CONVERGED)
      hi = 1.0;
    else
    {
      band.diverges_at = lo;
      return band;  // converges_at stays NaN: no certified rate
    }
  }
  // lo is known to diverge (it is the necessary lower bound).
  double dlo = lo, chi = hi;
  while (chi - dlo > tolerance)
  {
    const double mid = 0.5 * (dlo + chi);
    const S s = status(mid);
    if (s == S::CONVERGED)
      chi = mid;
    else if (s == S::DIVERGED)
      dlo = mid;
    else
    {
      band.undecided_band = true;
      double a = mid, b = chi;  // smallest certified rate in (mid, chi]
      while (b - a > tolerance)
      {
        const double c = 0.5 * (a + b);
        (status(c) == S::CONVERGED ? b : a) = c;
      }
      chi = b;
      a = dlo;
      b = mid;  // largest diverging rate in [dlo, mid)
      while (b - a > tolerance)
      {
        const double c = 0.5 * (a + b);
        (status(c) == S::DIVERGED ? a : b) = c;
      }
      dlo = a;
      break;
    }
  }
  band.diverges_at = dlo;
  band.converges_at = chi;
  return band;
}

}  // namespace networked_estimation
