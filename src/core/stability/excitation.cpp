// Gan and Liu's excitation condition (excitation.hpp).
#include "networked_estimation/stability/excitation.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace networked_estimation
{
namespace
{

double minEigenvalue(const Eigen::MatrixXd& S)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (S + S.transpose()), Eigen::EigenvaluesOnly);
  return es.eigenvalues()(0);
}

double spectralNorm(const Eigen::MatrixXd& A)
{
  return Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues()(0);
}

/// Term j of the block Gram matrix: (A^j)' c' c A^j / (1 + ||c A^j||^2), for j = 0..h-1.
std::vector<Eigen::MatrixXd> gramTerms(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, int h)
{
  std::vector<Eigen::MatrixXd> terms;
  Eigen::MatrixXd Aj = Eigen::MatrixXd::Identity(A.rows(), A.cols());
  for (int j = 0; j < h; ++j)
  {
    const Eigen::RowVectorXd cA = c * Aj;
    terms.push_back(cA.transpose() * cA / (1.0 + cA.squaredNorm()));
    Aj = A * Aj;
  }
  return terms;
}

void checkInputs(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, int h)
{
  if (A.rows() != A.cols() || A.rows() == 0)
    throw std::invalid_argument("Gan-Liu: A must be square");
  if (c.rows() != 1 || c.cols() != A.rows())
    throw std::invalid_argument("Gan-Liu: c must be 1 x n (a scalar output)");
  if (!(R > 0.0) || !std::isfinite(R))
    throw std::invalid_argument("Gan-Liu: R must be a positive variance");
  if (h < 1)
    throw std::invalid_argument("Gan-Liu: the block length h must be >= 1");
}

/// Fills the verdict and A3 of a report whose lambda, lambda_block, h are set.
void conclude(ExcitationReport& rep, const Eigen::MatrixXd& A, double R, int p_max)
{
  const int n = static_cast<int>(A.rows());
  rep.norm_A = spectralNorm(A);
  rep.a3 = ganLiuA3(rep.norm_A, rep.lambda, n, rep.h, R, p_max);
  Verdict& v = rep.verdict;
  v.numbers["lambda"] = rep.lambda;
  v.numbers["lambda_block"] = rep.lambda_block;
  v.numbers["norm_A"] = rep.norm_A;
  v.numbers["h"] = rep.h;
  std::ostringstream os;
  os.precision(6);
  const double det = A.determinant();
  if (!(std::abs(det) > 1e-12 * std::pow(std::max(1.0, rep.norm_A), n)))
  {
    v.kind = Verdict::Kind::NOT_APPLICABLE;
    v.reason = "not applicable: A1 (A invertible) fails";
    return;
  }
  if (!(rep.lambda < 1.0))
  {
    v.kind = Verdict::Kind::UNDECIDED;
    os << "no excitation: lambda = " << rep.lambda << " >= 1 (A2 fails), the sufficient condition says nothing";
    v.reason = os.str();
    return;
  }
  int best = 0;
  for (const ExcitationA3& a : rep.a3)
    if (a.holds())
      best = a.p;
  if (best > 0)
  {
    v.kind = Verdict::Kind::STABLE;
    v.numbers["p"] = best;
    os << "A1-A3 hold (lambda = " << rep.lambda << ", A3 for p = " << best
       << "): sup_k E||P'_k||^p is bounded (Gan and Liu, Theorem 2)";
  }
  else
  {
    v.kind = Verdict::Kind::UNDECIDED;
    os << "excited (lambda = " << rep.lambda << " < 1) but A3 fails for p = 1.." << rep.a3.size()
       << " (||A|| = " << rep.norm_A << "): no conclusion, A3 is very conservative";
  }
  v.reason = os.str();
}

}  // namespace

const char* ExcitationReport::caveat()
{
  return "Gan and Liu's A3 is very conservative: with ||A|| > 1 it almost never holds, so a failed A3 is no "
         "evidence of instability; it covers any loss pattern (no i.i.d. or Markov assumption) for a scalar output";
}

double blockExcitation(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, const std::vector<double>& pi)
{
  const int h = static_cast<int>(pi.size());
  const std::vector<Eigen::MatrixXd> terms = gramTerms(A, c, h);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(A.rows(), A.cols());
  for (int j = 0; j < h; ++j)
    G += pi[j] * terms[j];
  return std::max(0.0, minEigenvalue(G)) / (1.0 + h);
}

std::vector<ExcitationA3> ganLiuA3(double norm_A, double lambda, int n, int h, double R, int p_max)
{
  std::vector<ExcitationA3> out;
  for (int p = 1; p <= p_max; ++p)
  {
    ExcitationA3 a;
    a.p = p;
    a.printed = std::pow(2.0, (p - 1.0) / (p * h)) * norm_A * norm_A *
                std::pow(lambda, 1.0 / (8.0 * n * p * p * (1.0 + R)));
    a.proof = std::pow(16.0, p - 1.0) * std::pow(norm_A, 8.0 * p * h) * std::pow(lambda, 1.0 / (2.0 * n * h * (1.0 + R)));
    out.push_back(a);
  }
  return out;
}

ExcitationReport ganLiuIid(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, double arrival, int h,
                           int p_max)
{
  checkInputs(A, c, R, h);
  if (!(arrival >= 0.0 && arrival <= 1.0))
    throw std::invalid_argument("Gan-Liu: the arrival probability must be in [0, 1]");
  ExcitationReport rep;
  rep.h = h;
  rep.lambda_block = blockExcitation(A, c, std::vector<double>(h, arrival));
  rep.lambda = 1.0 - rep.lambda_block;  // a constant lambda_m: S^0 rate 1 - lambda_m (Remark 1)
  conclude(rep, A, R, p_max);
  return rep;
}

ExcitationReport ganLiuMarkov(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, double failure,
                              double recovery, int h, int p_max)
{
  checkInputs(A, c, R, h);
  if (!(failure >= 0.0 && failure <= 1.0 && recovery >= 0.0 && recovery <= 1.0))
    throw std::invalid_argument("Gan-Liu: failure and recovery rates must be in [0, 1]");
  // States: 0 = the last sample arrived, 1 = it was lost. Pi is row-stochastic.
  Eigen::Matrix2d Pi;
  Pi << 1.0 - failure, failure, recovery, 1.0 - recovery;
  Eigen::Vector2d f;
  for (int s = 0; s < 2; ++s)
  {
    std::vector<double> pi(h);
    Eigen::RowVector2d row = Eigen::RowVector2d::Zero();
    row(s) = 1.0;
    for (int j = 0; j < h; ++j)
    {
      row = row * Pi;  // the distribution j + 1 steps after the state s
      pi[j] = row(0);
    }
    f(s) = blockExcitation(A, c, pi);
  }
  Eigen::Matrix2d Ph = Eigen::Matrix2d::Identity();
  for (int j = 0; j < h; ++j)
    Ph = Ph * Pi;
  const Eigen::Matrix2d M = (Eigen::Vector2d::Ones() - f).asDiagonal() * Ph;
  ExcitationReport rep;
  rep.h = h;
  rep.lambda_block = f.minCoeff();
  rep.lambda = M.eigenvalues().cwiseAbs().maxCoeff();
  conclude(rep, A, R, p_max);
  return rep;
}

ExcitationReport ganLiuTrace(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R,
                             const std::vector<bool>& arrivals, int h, int p_max)
{
  checkInputs(A, c, R, h);
  const std::size_t blocks = arrivals.size() / static_cast<std::size_t>(h);
  if (blocks == 0)
    throw std::invalid_argument("Gan-Liu: the trace has " + std::to_string(arrivals.size()) +
                                " samples, fewer than one block of h = " + std::to_string(h));
  const std::vector<Eigen::MatrixXd> terms = gramTerms(A, c, h);
  double log_sum = 0.0, smallest = 1.0;
  for (std::size_t m = 0; m < blocks; ++m)
  {
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(A.rows(), A.cols());
    for (int j = 0; j < h; ++j)
      if (arrivals[m * h + j])
        G += terms[j];
    const double lm = std::max(0.0, minEigenvalue(G)) / (1.0 + h);
    smallest = std::min(smallest, lm);
    log_sum += std::log1p(-lm);  // 1 - lm >= 1 / (1 + h) > 0
  }
  ExcitationReport rep;
  rep.h = h;
  rep.lambda_block = smallest;
  rep.lambda = std::exp(log_sum / static_cast<double>(blocks));
  rep.verdict.numbers["blocks"] = static_cast<double>(blocks);
  conclude(rep, A, R, p_max);
  return rep;
}

Theorem1Check ganLiuTheorem1(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& c, double R,
                             const std::vector<Eigen::MatrixXd>& predicted, const std::vector<bool>& arrivals, int h)
{
  checkInputs(A, c, R, h);
  const Eigen::Index n = A.rows();
  Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  if (!lu.isInvertible())
    throw std::invalid_argument("Gan-Liu Theorem 1: A must be invertible (A1)");
  const Eigen::MatrixXd Ainv = lu.inverse();
  // A^{-j} for j = 0..h and the constants of the inequality.
  std::vector<Eigen::MatrixXd> Ai(h + 1, Eigen::MatrixXd::Identity(n, n));
  for (int j = 1; j <= h; ++j)
    Ai[j] = Ainv * Ai[j - 1];
  Eigen::MatrixXd backQ = Eigen::MatrixXd::Zero(n, n);  // sum_{j=1}^h A^-j Q A^-j'
  for (int j = 1; j <= h; ++j)
    backQ += Ai[j] * Q * Ai[j].transpose();
  double forward = 0.0;  // tr sum_{j=0}^h A^j Q A^j'
  Eigen::MatrixXd Aj = Eigen::MatrixXd::Identity(n, n);
  for (int j = 0; j <= h; ++j)
  {
    forward += (Aj * Q * Aj.transpose()).trace();
    Aj = A * Aj;
  }
  const double b_A = h * forward + 2.0 * h * backQ.trace();
  const double growth = std::pow(spectralNorm(A), 2.0 * h);
  const std::vector<Eigen::MatrixXd> terms = gramTerms(A, c, h);

  const long blocks = static_cast<long>(std::min(arrivals.size(), predicted.size() - 1) / static_cast<std::size_t>(h));
  auto T = [&](long m) {  // T_{m+1}: block m's predictions P'_{mh+1} .. P'_{(m+1)h}
    double t = 0.0;
    for (int j = 0; j < h; ++j)
    {
      const Eigen::MatrixXd& P = predicted[static_cast<std::size_t>(m * h + j + 1)];
      t += (Ai[j + 1] * P * Ai[j + 1].transpose()).trace();
    }
    return t;
  };
  Theorem1Check out;
  out.blocks = blocks;
  double T_prev = blocks > 0 ? T(0) : 0.0;  // T_1
  for (long m = 1; m < blocks; ++m)
  {
    const Eigen::MatrixXd S = predicted[static_cast<std::size_t>(m * h)] + backQ;
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n);
    for (int j = 0; j < h; ++j)
      if (arrivals[static_cast<std::size_t>(m * h + j)])
        G += terms[j];
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (S + S.transpose()), Eigen::EigenvaluesOnly);
    const double a = (S * S * G).trace() / (h * (1.0 + R) * S.trace() * (1.0 + es.eigenvalues().maxCoeff()));
    const double T_next = T(m);
    const double gap = T_next - ((1.0 - a) * growth * T_prev + b_A);
    if (gap > out.worst)
    {
      out.worst = gap;
      out.block = m;
    }
    T_prev = T_next;
  }
  return out;
}

}  // namespace networked_estimation
