// Gan and Liu's excitation condition (excitation.hpp).
#include "networked_estimation/stability/excitation.hpp"
#include "networked_estimation/common/eigenvalues.hpp"

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
  return symmetricEigenvalues(0.5 * (S + S.transpose()))(0);
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
/// Fills the verdict and A3 of a report whose lambda, lambda_block, h are set; norm_A = ||A||.
void conclude(ExcitationReport& rep, const Eigen::MatrixXd& A, double R, int p_max, double norm_A)
{
  const int n = static_cast<int>(A.rows());
  rep.norm_A = norm_A;
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
    a.printed =
        std::pow(2.0, (p - 1.0) / (p * h)) * norm_A * norm_A * std::pow(lambda, 1.0 / (8.0 * n * p * p * (1.0 + R)));
    a.proof =
        std::pow(16.0, p - 1.0) * std::pow(norm_A, 8.0 * p * h) * std::pow(lambda, 1.0 / (2.0 * n * h * (1.0 + R)));
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
  conclude(rep, A, R, p_max, spectralNorm(A));
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
  rep.lambda = spectralRadius(M);
  conclude(rep, A, R, p_max, spectralNorm(A));
  return rep;
}

GanLiuBlocks::GanLiuBlocks(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, int h, int p_max)
  : A_(A), R_(R), h_(h), p_max_(p_max)
{
  checkInputs(A, c, R, h);
  terms_ = gramTerms(A, c, h);
  norm_A_ = spectralNorm(A);
}

double GanLiuBlocks::block(const std::vector<bool>& arrivals, std::size_t first) const
{
  if (first + static_cast<std::size_t>(h_) > arrivals.size())
    throw std::invalid_argument("Gan-Liu: a block of h = " + std::to_string(h_) + " from sample " +
                                std::to_string(first) + " of " + std::to_string(arrivals.size()));
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(A_.rows(), A_.cols());
  for (int j = 0; j < h_; ++j)
    if (arrivals[first + static_cast<std::size_t>(j)])
      G += terms_[static_cast<std::size_t>(j)];
  return std::max(0.0, minEigenvalue(G)) / (1.0 + h_);
}

ExcitationReport GanLiuBlocks::report(const std::vector<double>& lambdas) const
{
  if (lambdas.empty())
    throw std::invalid_argument("Gan-Liu: no block");
  double log_sum = 0.0, smallest = 1.0;
  for (double lm : lambdas)
  {
    smallest = std::min(smallest, lm);
    log_sum += std::log1p(-lm);  // 1 - lm >= 1 / (1 + h) > 0
  }
  ExcitationReport rep;
  rep.h = h_;
  rep.lambda_block = smallest;
  rep.lambda = std::exp(log_sum / static_cast<double>(lambdas.size()));
  rep.verdict.numbers["blocks"] = static_cast<double>(lambdas.size());
  conclude(rep, A_, R_, p_max_, norm_A_);
  return rep;
}

ExcitationReport ganLiuTrace(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R,
                             const std::vector<bool>& arrivals, int h, int p_max)
{
  const GanLiuBlocks blocks(A, c, R, h, p_max);
  const std::size_t count = arrivals.size() / static_cast<std::size_t>(h);
  if (count == 0)
    throw std::invalid_argument("Gan-Liu: the trace has " + std::to_string(arrivals.size()) +
                                " samples, fewer than one block of h = " + std::to_string(h));
  std::vector<double> lambdas;
  for (std::size_t m = 0; m < count; ++m)
    lambdas.push_back(blocks.block(arrivals, m * static_cast<std::size_t>(h)));
  return blocks.report(lambdas);
}

Theorem1Monitor::Theorem1Monitor(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& c, double R,
                                 int h)
  : A_(A), Q_(Q), c_(c), R_(R), h_(h)
{
  checkInputs(A, c, R, h);
  const Eigen::Index n = A.rows();
  if (Q.rows() != n || Q.cols() != n)
    throw std::invalid_argument("Gan-Liu Theorem 1: Q must be n x n");
  Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  if (!lu.isInvertible())
    throw std::invalid_argument("Gan-Liu Theorem 1: A must be invertible (A1)");
  const Eigen::MatrixXd Ainv = lu.inverse();
  Ai_.assign(h + 1, Eigen::MatrixXd::Identity(n, n));
  for (int j = 1; j <= h; ++j)
    Ai_[j] = Ainv * Ai_[j - 1];
  backQ_ = Eigen::MatrixXd::Zero(n, n);
  for (int j = 1; j <= h; ++j)
    backQ_ += Ai_[j] * Q * Ai_[j].transpose();
  double forward = 0.0;  // tr sum_{j=0}^h A^j Q A^j'
  Eigen::MatrixXd Aj = Eigen::MatrixXd::Identity(n, n);
  for (int j = 0; j <= h; ++j)
  {
    forward += (Aj * Q * Aj.transpose()).trace();
    Aj = A * Aj;
  }
  b_A_ = h * forward + 2.0 * h * backQ_.trace();
  growth_ = std::pow(spectralNorm(A), 2.0 * h);
  terms_ = gramTerms(A, c, h);
}

void Theorem1Monitor::start(const Eigen::MatrixXd& P0)
{
  started_ = true;
  block_ = 0;
  pos_ = 0;
  S_ = P0 + backQ_;
  G_ = Eigen::MatrixXd::Zero(A_.rows(), A_.cols());
  T_block_ = T_prev_ = 0.0;
}

void Theorem1Monitor::add(bool gamma, const Eigen::MatrixXd& P_next)
{
  if (!started_)
    throw std::logic_error("Theorem1Monitor: start() first");
  // Step i = m h + pos: its regressor enters block m's Gram matrix, P'_{i+1} its T.
  if (gamma)
    G_ += terms_[pos_];
  T_block_ += (Ai_[pos_ + 1] * P_next * Ai_[pos_ + 1].transpose()).trace();
  if (++pos_ < h_)
    return;
  // Block m complete: T_{m+1} = T_block_. The inequality holds for m >= 1.
  if (block_ >= 1)
  {
    const double top = symmetricEigenvalues(0.5 * (S_ + S_.transpose())).maxCoeff();
    const double a = (S_ * S_ * G_).trace() / (h_ * (1.0 + R_) * S_.trace() * (1.0 + top));
    const double gap = T_block_ - ((1.0 - a) * growth_ * T_prev_ + b_A_);
    ++check_.blocks;
    if (gap > check_.worst)
    {
      check_.worst = gap;
      check_.block = block_;
    }
    if (gap > 1e-9 * (1.0 + std::abs(T_block_)))
      ++violations_;
  }
  else
  {
    ++check_.blocks;
  }
  T_prev_ = T_block_;
  T_block_ = 0.0;
  S_ = P_next + backQ_;  // P'_{(m+1)h}
  G_.setZero();
  pos_ = 0;
  ++block_;
}

Theorem1Check ganLiuTheorem1(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& c, double R,
                             const std::vector<Eigen::MatrixXd>& predicted, const std::vector<bool>& arrivals, int h)
{
  Theorem1Monitor mon(A, Q, c, R, h);
  if (predicted.empty())
    return mon.check();
  mon.start(predicted[0]);
  const std::size_t steps = std::min(arrivals.size(), predicted.size() - 1);
  for (std::size_t i = 0; i < steps; ++i)
    mon.add(arrivals[i], predicted[i + 1]);
  return mon.check();
}

}  // namespace networked_estimation
