// Stability analysis, part 2: the bounds and capacities of Yang et al. (docs/stability.md 3.1-3.3,
// 3.8), the MARE with its certificate and bisection (3.2), Lin et al.'s Theorem 5 (3.7) and Zhou's
// RSEIO checklist (3.9).
#include "networked_estimation/stability/stability.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/rseio.hpp"

namespace networked_estimation
{

namespace
{

Eigen::MatrixXd sym(const Eigen::MatrixXd& X)
{
  return 0.5 * (X + X.transpose());
}

/// Orthonormal real basis of the null space of M.
Eigen::MatrixXd nullSpaceReal(const Eigen::MatrixXd& M, double rel_tol)
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

bool isPd(const Eigen::MatrixXd& S)
{
  Eigen::LLT<Eigen::MatrixXd> llt(sym(S));
  return llt.info() == Eigen::Success;
}

/// lambda_min / lambda_max of a symmetric PSD matrix (0 for the zero matrix).
double conditionRatio(const Eigen::MatrixXd& S)
{
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(sym(S)).eigenvalues();
  const double mx = ev.maxCoeff();
  return mx > 0.0 ? ev.minCoeff() / mx : 0.0;
}

}  // namespace

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

Eigen::MatrixXd informationLowerBoundLimit(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q,
                                           const Eigen::MatrixXd& S, int max_iterations)
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
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(n * n, n * n);
  for (const auto& M : Ms)
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        T.block(i * n, j * n, n, n) += M(i, j) * M;
  return Eigen::EigenSolver<Eigen::MatrixXd>(T, false).eigenvalues().cwiseAbs().maxCoeff();
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
  auto status = [&](double lambda) {
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

// ---------------------------------------------------------------------------------------------

Verdict aoeTheorem5(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q,
                    const Eigen::MatrixXd& R, double recovery, double failure, const StabilityTolerances& tol)
{
  Verdict v;
  v.kind = Verdict::Kind::NOT_APPLICABLE;
  const double rho = spectralRadius(A);
  const double pt = aoeRecoveryThreshold(rho);
  v.numbers["rho(A)"] = rho;
  v.numbers["p_t"] = pt;
  v.numbers["recovery"] = recovery;
  if (!isPd(Q) || !isPd(R))
  {
    v.reason = "Assumption 1: Q and R must be positive definite";
    return v;
  }
  if (!isObservable(A, C, 1e-9))
  {
    v.reason = "Assumption 1: (A, C) is not observable";
    return v;
  }
  const Eigen::MatrixXd G = Eigen::LLT<Eigen::MatrixXd>(sym(Q)).matrixL();
  if (!modesControllable(A, G, 0.0))
  {
    v.reason = "Assumption 1: (A, Q^1/2) is not controllable";
    return v;
  }
  if (!(recovery > 0.0 && recovery <= 1.0 && failure > 0.0 && failure <= 1.0))
  {
    v.reason = "Assumption 1: the recovery and failure rates must be in (0, 1]";
    return v;
  }
  const Verdict so = strongObservability(A, C, tol);
  if (so.kind == Verdict::Kind::NOT_APPLICABLE)
  {
    v.reason = "Assumption 2: A is not diagonalizable";
    return v;
  }
  if (so.kind != Verdict::Kind::STABLE)
  {
    v.reason = "Assumption 2: " + so.reason;
    return v;
  }
  std::ostringstream os;
  v.numbers["margin"] = recovery - pt;
  if (rho <= 1.0)
  {
    v.kind = Verdict::Kind::STABLE;
    os << "Lin et al.'s Theorem 5: rho(A) = " << rho << " <= 1, stable for every recovery rate > 0";
  }
  else if (recovery > pt + tol.decision)
  {
    v.kind = Verdict::Kind::STABLE;
    os << "Lin et al.'s Theorem 5: recovery rate " << recovery << " > p_t = 1 - rho(A)^-2 = " << pt;
  }
  else if (recovery < pt - tol.decision)
  {
    v.kind = Verdict::Kind::UNSTABLE;
    os << "Lin et al.'s Theorem 5: recovery rate " << recovery << " < p_t = 1 - rho(A)^-2 = " << pt;
  }
  else
  {
    v.kind = Verdict::Kind::UNDECIDED;
    os << "Lin et al.'s Theorem 5: recovery rate " << recovery << " = p_t = " << pt << " (not covered)";
  }
  v.reason = os.str();
  return v;
}

// ---------------------------------------------------------------------------------------------

Eigen::MatrixXd wordObservabilityGramian(const std::vector<int>& word, const Eigen::MatrixXd& A1,
                                         const Eigen::MatrixXd& W1, const Eigen::MatrixXd& A2)
{
  const int n = static_cast<int>(A1.rows());
  Eigen::MatrixXd O = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n);  // A_i ... A_1
  for (int letter : word)
  {
    P = (letter ? A1 : A2) * P;
    if (letter)
      O += P.transpose() * W1 * P;
  }
  return sym(O);
}

Eigen::MatrixXd wordControllabilityGramian(const std::vector<int>& word, const Eigen::MatrixXd& A1,
                                           const Eigen::MatrixXd& G1, const Eigen::MatrixXd& A2,
                                           const Eigen::MatrixXd& G2)
{
  const int n = static_cast<int>(A1.rows());
  Eigen::MatrixXd Cg = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(n, n);  // A_N ... A_{i+1}
  for (auto it = word.rbegin(); it != word.rend(); ++it)
  {
    const Eigen::MatrixXd& G = *it ? G1 : G2;
    Cg += P * G * G.transpose() * P.transpose();
    P = P * (*it ? A1 : A2);
  }
  return sym(Cg);
}

Verdict rseioTheorem5(const Model& model, double mu, const LinkModel& link, const StabilityTolerances& tol)
{
  (void)tol;
  Verdict v;
  v.kind = Verdict::Kind::NOT_APPLICABLE;
  const int n = model.n();
  const double rank_tol = 1e-10;
  if (link.kind == LinkModel::Kind::IID)
  {
    v.numbers["gbar"] = link.arrival;
    if (!(link.arrival > 0.0))
    {
      v.reason = "Zhou's Theorem 5 needs gbar > 0";
      return v;
    }
  }
  else
  {
    if (!link.onOff())
    {
      v.reason = "Zhou's Theorem 5: the arrivals of a Gilbert-Elliott chain with loss_good > 0 or loss_bad < 1 "
                 "are not a Markov chain";
      return v;
    }
    v.numbers["alpha"] = 1.0 - link.p;
    v.numbers["beta"] = 1.0 - link.r;
    if (!(link.p > 0.0 && link.p < 1.0 && link.r > 0.0 && link.r < 1.0))
    {
      v.reason = "Zhou's Theorem 5 needs 0 < alpha, beta < 1 (0 < p, r < 1)";
      return v;
    }
  }
  if (std::abs(Eigen::FullPivLU<Eigen::MatrixXd>(model.A).determinant()) == 0.0 ||
      !Eigen::FullPivLU<Eigen::MatrixXd>(model.A).isInvertible())
  {
    v.reason = "Zhou's Theorem 5: A must be invertible";
    return v;
  }
  RseioAnalysisForm f;
  try
  {
    f = rseioAnalysisForm(model, mu);
  }
  catch (const ConfigError& e)
  {
    v.reason = std::string("Zhou's Theorem 5: ") + e.what();
    return v;
  }
  if (!Eigen::FullPivLU<Eigen::MatrixXd>(f.Atil).isInvertible())
  {
    v.reason = "Zhou's Theorem 5: Atil must be invertible";
    return v;
  }
  const Eigen::MatrixXd& A1 = f.Atil;
  const Eigen::MatrixXd& A2 = model.A;
  const Eigen::MatrixXd W1 = sym(f.Ctil.transpose() * f.Rtil.llt().solve(f.Ctil));
  const Eigen::MatrixXd G1 = model.B * Eigen::LLT<Eigen::MatrixXd>(sym(f.Qtil)).matrixL().toDenseMatrix();
  const Eigen::MatrixXd G2 = model.B * Eigen::LLT<Eigen::MatrixXd>(sym(model.Q)).matrixL().toDenseMatrix();
  auto pd = [&](const Eigen::MatrixXd& S) { return conditionRatio(S) > rank_tol; };
  auto repeat = [](std::vector<int> head, const std::vector<int>& unit, int times) {
    for (int t = 0; t < times; ++t)
      head.insert(head.end(), unit.begin(), unit.end());
    return head;
  };
  // Observability: word 1 (0^m 1)^{n-1}.
  int m_obs = -1;
  for (int m = 0; m < n && m_obs < 0; ++m)
  {
    std::vector<int> unit(m, 0);
    unit.push_back(1);
    if (pd(wordObservabilityGramian(repeat({1}, unit, n - 1), A1, W1, A2)))
      m_obs = m;
  }
  // Controllability (a), (b), (c).
  std::string ctrl;
  for (int m = 0; m < n && ctrl.empty(); ++m)
  {
    std::vector<int> unit(m, 0);
    unit.push_back(1);
    if (pd(wordControllabilityGramian(repeat({1}, unit, n - 1), A1, G1, A2, G2)))
      ctrl = "(a) with m = " + std::to_string(m);
  }
  if (ctrl.empty() && pd(wordControllabilityGramian(std::vector<int>(n, 0), A1, G1, A2, G2)))
    ctrl = "(b) (A, B Q^1/2) controllable";
  for (int m = 1; m <= n && ctrl.empty(); ++m)
  {
    std::vector<int> unit(1, 1);
    unit.insert(unit.end(), m, 0);
    if (pd(wordControllabilityGramian(repeat({0}, unit, n - 1), A1, G1, A2, G2)))
      ctrl = "(c) with m = " + std::to_string(m);
  }
  v.numbers["observability m"] = m_obs;
  const bool all_ones = link.kind == LinkModel::Kind::IID && link.arrival >= 1.0;
  std::string multi = model.sensors.size() > 1 ? " (arrival = all sensors arrive)" : "";
  if (all_ones)
  {
    // Only the all-ones word occurs: (A1, H1) observable and (A1, G1) controllable.
    const bool obs = pd(wordObservabilityGramian(std::vector<int>(n, 1), A1, W1, A2));
    const bool con = pd(wordControllabilityGramian(std::vector<int>(n, 1), A1, G1, A2, G2));
    v.kind = obs && con ? Verdict::Kind::STABLE : Verdict::Kind::UNDECIDED;
    v.reason = obs && con ? "Zhou's Theorem 5 (gbar = 1): (Atil, H1) observable and (Atil, G1) controllable; "
                            "P converges"
                          : "Zhou's Theorem 5 (gbar = 1): (Atil, H1) not observable or (Atil, G1) not controllable";
    return v;
  }
  if (m_obs >= 0 && !ctrl.empty())
  {
    v.kind = Verdict::Kind::STABLE;
    v.reason = "Zhou's Theorem 5: observability word with m = " + std::to_string(m_obs) + " and controllability " +
               ctrl + multi + "; P_{t|t} converges to a unique stationary distribution";
    return v;
  }
  v.kind = Verdict::Kind::UNDECIDED;
  v.reason = std::string("Zhou's Theorem 5: the sufficient conditions do not hold (") +
             (m_obs < 0 ? "no observability word" : "no controllability word") + ")" + multi;
  return v;
}

}  // namespace networked_estimation
