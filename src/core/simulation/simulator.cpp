#include "networked_estimation/simulation/simulator.hpp"
#include "networked_estimation/common/eigenvalues.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"
#include "io/tokens.hpp"

namespace networked_estimation
{

namespace
{

/// Square root S (S S' = P) of a symmetric positive semidefinite matrix, from the pivoted LDLT
/// factorisation P = T' L D L' T; negative pivots (round-off) are clamped to zero.
Eigen::MatrixXd psdSqrt(const Eigen::MatrixXd& P)
{
  if (P.size() == 0)
    return P;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(P);
  const Eigen::VectorXd d = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
  Eigen::MatrixXd LD = ldlt.matrixL();
  LD = LD * d.asDiagonal();
  return ldlt.transpositionsP().transpose() * LD;
}

Eigen::MatrixXd lowerCholesky(const Eigen::MatrixXd& M, const std::string& name, const std::string& model_name)
{
  Eigen::LLT<Eigen::MatrixXd> llt(M);
  if (llt.info() != Eigen::Success)
    throw ConfigError("PlantSimulator: model '" + model_name + "': " + name + " is not positive definite");
  return llt.matrixL();
}

/// The rounding floor's fraction of the noise (simulator.hpp: limit = kFloorFraction sigma / eps).
constexpr double kFloorFraction = 1e-3;

/// The smallest eigenvalue of the symmetric positive semidefinite M above n eps lambda_max (the
/// numerically non-zero ones); 0 when there is none.
double smallestNonZeroEigenvalue(const Eigen::MatrixXd& M)
{
  if (M.size() == 0)
    return 0.0;
  const Eigen::VectorXd ev = symmetricEigenvalues(M);  // ascending
  const double tol = static_cast<double>(M.rows()) * std::numeric_limits<double>::epsilon() * ev(ev.size() - 1);
  for (Eigen::Index i = 0; i < ev.size(); ++i)
    if (ev(i) > tol)
      return ev(i);
  return 0.0;
}

/// ||M||_inf (largest absolute row sum); 0 for an empty matrix.
double infNorm(const Eigen::MatrixXd& M)
{
  return M.size() == 0 ? 0.0 : M.cwiseAbs().rowwise().sum().maxCoeff();
}

std::string shortNumber(double v)
{
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

template <typename Derived>
void requireSize(const Eigen::EigenBase<Derived>& M, Eigen::Index rows, Eigen::Index cols, const std::string& name,
                 const std::string& model_name)
{
  if (M.rows() != rows || M.cols() != cols)
    throw ConfigError("PlantSimulator: model '" + model_name + "': " + name + " is " + std::to_string(M.rows()) + "x" +
                      std::to_string(M.cols()) + ", expected " + std::to_string(rows) + "x" + std::to_string(cols));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// ControlSequence

Eigen::VectorXd ControlSequence::at(long k, int p) const
{
  double u = 0.0;
  switch (kind)
  {
    case Kind::CONSTANT:
      u = value;
      break;
    case Kind::STEP:
      u = k >= step_at ? value : 0.0;
      break;
    case Kind::PAPER:
      u = value * (1.0 + std::exp(-static_cast<double>(k) / 10.0));
      break;
  }
  return Eigen::VectorXd::Constant(p, u);
}

ControlSequence ControlSequence::parse(const std::string& text, const std::string& what)
{
  const std::vector<std::string> parts = tokens::split(text, ':');
  ControlSequence c;
  bool ok = false;
  if (parts[0] == "constant" && parts.size() == 2)
  {
    c.kind = Kind::CONSTANT;
    ok = tokens::parseFinite(parts[1], c.value);
  }
  else if (parts[0] == "step" && parts.size() == 3)
  {
    c.kind = Kind::STEP;
    ok = tokens::parseLong(parts[1], c.step_at) && tokens::parseFinite(parts[2], c.value);
  }
  else if (parts[0] == "paper" && parts.size() == 1)
  {
    c.kind = Kind::PAPER;
    c.value = 1.0;
    ok = true;
  }
  else if (parts[0] == "paper" && parts.size() == 2)
  {
    c.kind = Kind::PAPER;
    ok = tokens::parseFinite(parts[1], c.value);
  }
  if (!ok)
    throw ConfigError(what + ": cannot parse control sequence '" + text +
                      "' (expected constant:V, step:K:V, paper or paper:V)");
  return c;
}

// ---------------------------------------------------------------------------------------------
// PlantSimulator

PlantSimulator::PlantSimulator(const Model& model, std::uint64_t seed, ControlSequence control,
                               std::unique_ptr<LossModel> actuator)
  : model_(model),
    control_(control),
    actuator_(std::move(actuator)),
    rng_x0_(deriveSeed(seed, 0)),
    rng_w_(deriveSeed(seed, 1)),
    rng_v_(deriveSeed(seed, 2)),
    rng_eps_(deriveSeed(seed, 3))
{
  const int n = model.n(), nw = model.nw(), m = model.m(), p = model.p(), ne = model.ne();
  const std::string& name = model.name;
  if (!model.nonlinear())
    requireSize(model.A, n, n, "A", name);
  requireSize(model.B, n, nw, "B", name);
  requireSize(model.Q, nw, nw, "Q", name);
  requireSize(model.C, m, n, "C", name);
  requireSize(model.R, m, m, "R", name);
  requireSize(model.x0, n, 1, "x0", name);
  requireSize(model.P0, n, n, "P0", name);
  if (p > 0)
    requireSize(model.Bu, n, p, "Bu", name);
  for (int j = 0; j < ne; ++j)
  {
    const Uncertainty& unc = model.uncertainty[j];
    const std::string idx = "uncertainty[" + std::to_string(j) + "].";
    // Absent derivatives may be left empty (treated as zero).
    if (unc.dA.size() > 0)
      requireSize(unc.dA, n, n, idx + "dA", name);
    if (unc.dB.size() > 0)
      requireSize(unc.dB, n, nw, idx + "dB", name);
    if (unc.dC.size() > 0)
      requireSize(unc.dC, m, n, idx + "dC", name);
  }

  // a built-in motion's Q is per second: the noise of one step of the period is N(0, Q T)
  const Eigen::MatrixXd q_step = model.nonlinear() ? Eigen::MatrixXd(model.Q * model.period) : model.Q;
  sqrtQ_ = lowerCholesky(q_step, "Q", name);
  sqrtR_ = lowerCholesky(model.R, "R", name);

  // The rounding floor (simulator.hpp): the smallest noise standard deviation in state units.
  // R is positive definite here (lowerCholesky refused it otherwise).
  double c = infNorm(model.C);
  for (int j = 0; j < ne; ++j)
    if (model.uncertainty[j].dC.size() > 0)
      c += std::abs(model.uncertainty[j].range) * infNorm(model.uncertainty[j].dC);
  const double sd_v = c > 0.0 && m > 0 ? std::sqrt(std::max(0.0, symmetricEigenvalues(model.R)(0))) / c
                                       : std::numeric_limits<double>::infinity();
  const double lw = nw > 0 ? smallestNonZeroEigenvalue(model.B * q_step * model.B.transpose()) : 0.0;
  const double sd_w = lw > 0.0 ? std::sqrt(lw) : std::numeric_limits<double>::infinity();
  noise_sd_ = std::min(sd_v, sd_w);
  noise_kind_ =
      sd_v <= sd_w ? "measurement noise sqrt(lambda_min(R)) / ||C||_inf" : "process noise sqrt(lambda_min+(B Q B'))";
  state_limit_ = kFloorFraction * noise_sd_ / std::numeric_limits<double>::epsilon();

  angle_rows_ = angularRows(model);
  sqrtP0_ = psdSqrt(model.P0);
  z0_.resize(n);
  eps_.resize(ne);
  start();

  if (ne > 0)
  {
    Ae_.resize(n, n);
    Be_.resize(n, nw);
    Ce_.resize(m, n);
  }
  zw_.resize(nw);
  zv_.resize(m);
  w_.resize(nw);
  xn_.resize(n);
  sample_.x.resize(n);
  sample_.y.resize(m);
  sample_.v.resize(m);
}

void PlantSimulator::start()
{
  // x_0 ~ N(x0, P0), P0 possibly singular.
  for (Eigen::Index i = 0; i < z0_.size(); ++i)
    z0_(i) = rng_x0_.normal();
  x_ = model_.x0 + sqrtP0_ * z0_;
  if (model_.two_d_mode)
    for (const int held : planarConstrained())
      x_[held] = 0.0;

  // eps_0: used in A and B of the first transition.
  for (int j = 0; j < model_.ne(); ++j)
  {
    const double range = model_.uncertainty[j].range;
    eps_(j) = rng_eps_.uniform(-range, range);
  }
}

void PlantSimulator::restart(std::uint64_t seed, std::uint64_t actuator_seed)
{
  rng_x0_.reseed(deriveSeed(seed, 0));
  rng_w_.reseed(deriveSeed(seed, 1));
  rng_v_.reseed(deriveSeed(seed, 2));
  rng_eps_.reseed(deriveSeed(seed, 3));
  if (actuator_)
    actuator_->reseed(actuator_seed);
  k_ = 0;
  start();
}

const SimulatedSample& PlantSimulator::step()
{
  const Model& M = model_;
  ++k_;

  // Command and actuator link.
  if (M.hasControl())
    sample_.u = control_.at(k_, M.p());
  else
    sample_.u.resize(0);
  const bool nu = actuator_ ? !actuator_->nextLost() : true;
  return advance(nu);
}

const SimulatedSample& PlantSimulator::stepApplied(const Eigen::VectorXd* applied)
{
  const Model& M = model_;
  if (applied && (applied->size() != M.p() || !applied->allFinite()))
    throw InputError("applied command: expected " + std::to_string(M.p()) + " finite values, found " +
                     std::to_string(applied->size()) + (applied->allFinite() ? "" : " (not finite)"));
  ++k_;
  if (!M.hasControl())
    sample_.u.resize(0);
  else if (applied)
    sample_.u = *applied;
  else
    sample_.u.setZero(M.p());
  return advance(applied != nullptr && M.hasControl());
}

const SimulatedSample& PlantSimulator::advance(bool nu)
{
  const Model& M = model_;
  const int ne = M.ne();

  // Transition with eps_{k-1}.
  if (ne > 0)
  {
    Ae_ = M.A;
    Be_ = M.B;
    for (int j = 0; j < ne; ++j)
    {
      const Uncertainty& unc = M.uncertainty[j];
      if (unc.dA.size() > 0)
        Ae_ += eps_(j) * unc.dA;
      if (unc.dB.size() > 0)
        Be_ += eps_(j) * unc.dB;
    }
  }
  const Eigen::MatrixXd& A = ne > 0 ? Ae_ : M.A;
  const Eigen::MatrixXd& B = ne > 0 ? Be_ : M.B;

  for (Eigen::Index i = 0; i < zw_.size(); ++i)
    zw_(i) = rng_w_.normal();
  w_.noalias() = sqrtQ_.triangularView<Eigen::Lower>() * zw_;

  if (M.nonlinear())
  {
    // the same motion ekfio predicts with, over the period, plus N(0, Q T) (B = I)
    propagate(M.motion, x_, M.period, xn_, nullptr);
    xn_ += w_;
    if (M.two_d_mode)
      for (const int held : planarConstrained())
        xn_[held] = 0.0;
  }
  else
  {
    xn_.noalias() = A * x_;
    xn_.noalias() += B * w_;
    if (nu && M.hasControl())
      xn_.noalias() += M.Bu * sample_.u;
  }
  x_.swap(xn_);
  wrapEntries(x_, M.angles);  // an angle of the plant lives in (-pi, pi] (docs/formats.md 1.2b)

  // The rounding floor (one pass over x_k; a NaN fails the comparison).
  for (Eigen::Index i = 0; i < x_.size(); ++i)
  {
    const double a = std::abs(x_(i));
    if (!(a <= state_limit_) || a == std::numeric_limits<double>::infinity())
      throwBeyondFloor();
  }

  // Fresh eps_k for the output (and the next transition).
  for (int j = 0; j < ne; ++j)
  {
    const double range = M.uncertainty[j].range;
    eps_(j) = rng_eps_.uniform(-range, range);
  }
  if (ne > 0)
  {
    Ce_ = M.C;
    for (int j = 0; j < ne; ++j)
    {
      const Uncertainty& unc = M.uncertainty[j];
      if (unc.dC.size() > 0)
        Ce_ += eps_(j) * unc.dC;
    }
  }
  const Eigen::MatrixXd& C = ne > 0 ? Ce_ : M.C;

  for (Eigen::Index i = 0; i < zv_.size(); ++i)
    zv_(i) = rng_v_.normal();
  sample_.v.noalias() = sqrtR_.triangularView<Eigen::Lower>() * zv_;
  sample_.y.noalias() = C * x_;
  sample_.y += sample_.v;
  wrapEntries(sample_.y, angle_rows_);  // a sensor of an angle reports it in (-pi, pi]

  sample_.k = k_;
  sample_.x = x_;
  sample_.nu = nu;
  return sample_;
}

void PlantSimulator::throwBeyondFloor() const
{
  const std::string what = "PlantSimulator: the plant state of model '" + model_.name + "'";
  const std::string k = std::to_string(k_);
  if (!x_.allFinite())
    throw DivergenceError(what + " is no longer finite at step k = " + k +
                          " (an unstable plant overflows): simulate fewer steps");
  const double norm = x_.lpNorm<Eigen::Infinity>();
  throw DivergenceError(what + " reached ||x_k||_inf = " + shortNumber(norm) + " at step k = " + k +
                        ", beyond the limit " + shortNumber(state_limit_) + " where rounding (||x_k||_inf * eps = " +
                        shortNumber(norm * std::numeric_limits<double>::epsilon()) + ") exceeds " +
                        shortNumber(kFloorFraction) + " of the smallest noise standard deviation in state units (" +
                        noise_kind_ + " = " + shortNumber(noise_sd_) +
                        "): results from this step on would be below the rounding floor; simulate fewer steps");
}

}  // namespace networked_estimation
