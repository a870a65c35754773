// Lin et al.'s Theorem 5 and Zhou's RSEIO checklist (estimator_theorems.hpp; docs/stability.md 3.7,
// 3.9).
#include "networked_estimation/stability/estimator_theorems.hpp"
#include "networked_estimation/stability/bounds.hpp"
#include "networked_estimation/stability/eigen_structure.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/estimators/rseio.hpp"
#include "stability_internal.hpp"

namespace networked_estimation
{

using stability_internal::conditionRatio;
using stability_internal::isPd;
using stability_internal::sym;

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
  // (A, Q^1/2) is controllable: Q is positive definite (checked above), so Q^1/2 has full rank.
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
      v.reason =
          "Zhou's Theorem 5: the arrivals of a Gilbert-Elliott chain with loss_good > 0 or loss_bad < 1 "
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
  auto repeat = [](std::vector<int> head, const std::vector<int>& unit, int times)
  {
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
