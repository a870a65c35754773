// The plant, the data and the hand-written Kalman filters of bench_estimators (the baselines every
// ratio refers to). Included by bench_estimators.cpp only.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/estimators/estimator.hpp"

namespace networked_estimation
{
namespace bench
{

constexpr int kRingSize = 1024;  // pre-generated samples; a power of two
constexpr double kSpectralRadius = 0.95;

constexpr int measurementCount(int n)
{
  return n == 2 ? 1 : n / 2;
}

// ---------------------------------------------------------------------------------------------
// Model and data generation
// ---------------------------------------------------------------------------------------------

inline Eigen::MatrixXd randomMatrix(Rng& rng, int r, int c, double scale = 1.0)
{
  Eigen::MatrixXd M(r, c);
  for (int i = 0; i < r; ++i)
  {
    for (int j = 0; j < c; ++j)
    {
      M(i, j) = scale * rng.uniform(-1.0, 1.0);
    }
  }
  return M;
}

/// Symmetric positive definite with eigenvalues in [lo, hi].
inline Eigen::MatrixXd randomSpd(Rng& rng, int n, double lo, double hi)
{
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(randomMatrix(rng, n, n));
  const Eigen::MatrixXd U = qr.householderQ();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i)
  {
    d[i] = rng.uniform(lo, hi);
  }
  const Eigen::MatrixXd S = U * d.asDiagonal() * U.transpose();
  return 0.5 * (S + S.transpose());
}

/// The benchmark plant: stable A (spectral radius 0.95), m = n/2 rows in one sensor, nw = n,
/// one uncertain parameter with non-zero dA, dB, dC, and one control input. `angle`: state 0 is
/// an angle (docs/algorithms.md 2.7) measured by row 0: column 0 of A is e_0 (a random walk the
/// others do not feed on), row 0 of C is e_0' and no other row, dA or dC involves state 0.
inline Model benchModel(int n, bool angle = false)
{
  Rng rng(deriveSeed(20240601, static_cast<std::uint64_t>(n)));
  const int m = measurementCount(n);
  const int nw = n;
  Model model;
  model.name = "bench_n" + std::to_string(n);
  model.period = 0.01;
  model.A = randomMatrix(rng, n, n);
  const double rho = Eigen::EigenSolver<Eigen::MatrixXd>(model.A, false).eigenvalues().cwiseAbs().maxCoeff();
  model.A *= kSpectralRadius / rho;
  model.B = randomMatrix(rng, n, nw, 0.5);
  model.Q = randomSpd(rng, nw, 0.2, 1.0);
  model.C = randomMatrix(rng, m, n);
  model.R = randomSpd(rng, m, 0.2, 1.0);
  model.sensors.push_back({"y", 0, m});
  model.x0 = Eigen::VectorXd::Zero(n);
  model.P0 = Eigen::MatrixXd::Identity(n, n);
  Uncertainty u;
  u.dA = randomMatrix(rng, n, n, 0.1 / std::sqrt(static_cast<double>(n)));
  u.dB = randomMatrix(rng, n, nw, 0.05);
  u.dC = randomMatrix(rng, m, n, 0.1);
  u.range = 0.5;
  model.uncertainty.push_back(u);
  model.Bu = randomMatrix(rng, n, 1);
  if (angle)
  {
    model.name += "_angle";
    model.A.col(0) = Eigen::VectorXd::Unit(n, 0);
    model.C.col(0).setZero();
    model.C.row(0) = Eigen::RowVectorXd::Unit(n, 0);
    model.uncertainty[0].dA.col(0).setZero();
    model.uncertainty[0].dC.col(0).setZero();
    model.angles = {0};
  }
  validateModel(model, model.name);
  return model;
}

/// A ring of samples (y, u) simulated from the nominal plant, u ~ N(0, 1) (non-zero).
/// arrival: gamma = 1 with every y; otherwise gamma = 0 and y empty.
inline std::vector<Sample> sampleRing(const Model& model, bool arrival)
{
  Rng rng(deriveSeed(77, static_cast<std::uint64_t>(model.n())));
  const Eigen::LLT<Eigen::MatrixXd> lq(model.Q);
  const Eigen::LLT<Eigen::MatrixXd> lr(model.R);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.n());
  Eigen::VectorXd w(model.nw()), v(model.m());
  std::vector<Sample> ring(kRingSize);
  for (Sample& s : ring)
  {
    s.u.resize(1);
    s.u[0] = rng.normal();
    for (int i = 0; i < w.size(); ++i)
    {
      w[i] = rng.normal();
    }
    for (int i = 0; i < v.size(); ++i)
    {
      v[i] = rng.normal();
    }
    x = model.A * x + model.Bu * s.u + model.B * (lq.matrixL() * w);
    for (const int a : model.angles)
    {
      x[a] = wrapAngle(x[a]);
    }
    s.gamma = arrival;
    if (arrival)
    {
      s.y = model.C * x + lr.matrixL() * v;
      for (const int a : model.angles)
      {
        s.y[a] = wrapAngle(s.y[a]);  // row a measures state a (benchModel)
      }
    }
  }
  return ring;
}

// ---------------------------------------------------------------------------------------------
// Baselines
// ---------------------------------------------------------------------------------------------

/// The textbook Kalman filter, dynamic-size, preallocated workspace (no allocation per step).
class DynamicKalman
{
public:
  explicit DynamicKalman(const Model& model)
    : A_(model.A), C_(model.C), R_(model.R), Bu_(model.Bu), x_(model.x0), P_(model.P0)
  {
    const Eigen::MatrixXd bqb = model.B * model.Q * model.B.transpose();
    Q_ = 0.5 * (bqb + bqb.transpose());
    const int n = model.n();
    const int m = model.m();
    xp_.resize(n);
    e_.resize(m);
    Pp_.resize(n, n);
    AP_.resize(n, n);
    IKC_.resize(n, n);
    Pn_.resize(n, n);
    CP_.resize(m, n);
    Kt_.resize(m, n);
    S_.resize(m, m);
  }

  void step(const Sample& s)
  {
    // xp = A x + Bu u
    xp_.noalias() = A_ * x_;
    xp_.noalias() += Bu_ * s.u;
    // Pp = A P A' + Q
    AP_.noalias() = A_ * P_;
    Pp_ = Q_;
    Pp_.noalias() += AP_ * A_.transpose();
    // S = C Pp C' + R
    CP_.noalias() = C_ * Pp_;
    S_ = R_;
    S_.noalias() += CP_ * C_.transpose();
    // K = Pp C' S^{-1}, held as K' = S^{-1} C Pp
    llt_.compute(S_);
    Kt_ = llt_.solve(CP_);
    // x = xp + K (y - C xp)
    e_ = s.y;
    e_.noalias() -= C_ * xp_;
    x_ = xp_;
    x_.noalias() += Kt_.transpose() * e_;
    // P = (I - K C) Pp, symmetrised
    IKC_.setIdentity();
    IKC_.noalias() -= Kt_.transpose() * C_;
    Pn_.noalias() = IKC_ * Pp_;
    P_ = 0.5 * (Pn_ + Pn_.transpose());
  }

  const Eigen::VectorXd& state() const { return x_; }
  const Eigen::MatrixXd& covariance() const { return P_; }

private:
  Eigen::MatrixXd A_, C_, R_, Bu_, Q_;
  Eigen::VectorXd x_, xp_, e_;
  Eigen::MatrixXd P_, Pp_, AP_, IKC_, Pn_, CP_, Kt_, S_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

/// The same filter with fixed-size Eigen types.
template <int N>
class FixedKalman
{
public:
  static constexpr int M = measurementCount(N);
  using MatN = Eigen::Matrix<double, N, N>;
  using MatMN = Eigen::Matrix<double, M, N>;
  using MatM = Eigen::Matrix<double, M, M>;
  using VecN = Eigen::Matrix<double, N, 1>;
  using VecM = Eigen::Matrix<double, M, 1>;

  explicit FixedKalman(const Model& model)
    : A_(model.A), C_(model.C), R_(model.R), bu_(model.Bu.col(0)), x_(model.x0), P_(model.P0)
  {
    const Eigen::MatrixXd bqb = model.B * model.Q * model.B.transpose();
    Q_ = 0.5 * (bqb + bqb.transpose());
  }

  void step(const VecM& y, double u)
  {
    const VecN xp = A_ * x_ + bu_ * u;
    const MatN Pp = A_ * P_ * A_.transpose() + Q_;
    const MatMN CP = C_ * Pp;
    const MatM S = CP * C_.transpose() + R_;
    const Eigen::LLT<MatM> llt(S);
    const MatMN Kt = llt.solve(CP);
    x_ = xp + Kt.transpose() * (y - C_ * xp);
    const MatN Pn = (MatN::Identity() - Kt.transpose() * C_) * Pp;
    P_ = 0.5 * (Pn + Pn.transpose());
  }

  /// The covariance recursion alone (the random Riccati recursion of a covariance-only Monte Carlo run):
  /// the prediction, then the update when the measurement arrived, in the same form as the
  /// estimators' (Cholesky of S, P - W'W, mirrored), without the mean.
  void covarianceStep(bool arrived)
  {
    Pp_.noalias() = A_ * P_;
    P_ = Q_;
    P_.noalias() += Pp_ * A_.transpose();
    if (arrived)
    {
      MatMN W = C_ * P_;
      MatM S = R_;
      S.noalias() += W * C_.transpose();
      const Eigen::LLT<MatM> llt(S);
      llt.matrixL().solveInPlace(W);
      P_.noalias() -= W.transpose() * W;
      P_.template triangularView<Eigen::StrictlyUpper>() = P_.transpose();
    }
  }

  const VecN& state() const { return x_; }
  const MatN& covariance() const { return P_; }

private:
  MatN A_;
  MatMN C_;
  MatM R_;
  VecN bu_;
  MatN Q_;
  VecN x_;
  MatN P_;
  MatN Pp_;  ///< covarianceStep's workspace
};

}  // namespace bench
}  // namespace networked_estimation
