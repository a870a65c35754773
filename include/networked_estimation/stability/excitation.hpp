// Gan and Liu's excitation condition (On the stability of Kalman filter with random coefficients,
// IFAC-PapersOnLine 2020): L_p stability of the Kalman filter for a scalar output y_k = phi_k' x_k
// + v_k whose regressor phi_k is random with no stationarity or independence assumed. With packet
// loss, phi_k = gamma_k c: any arrival pattern, i.i.d., Markov, periodic or none of these.
//
// Per block m of h steps (docs/stability.md, "Gan and Liu"):
//   G_m = sum_{i=mh}^{(m+1)h-1} (A^j)' phi_i phi_i' A^j / (1 + ||phi_i' A^j||^2),  j = i - mh,
//   lambda_m = lambda_min(E[G_m | past]) / (1 + h)                       (excitation of block m),
//   A2: {1 - lambda_m} in S^0(lambda): E prod (1 - lambda_m) <= M lambda^(blocks), lambda < 1,
//   A3 (printed):  2^((p-1)/(p h)) ||A||^2 lambda^(1/(8 n p^2 (1+R))) < 1,
//   A3 (proof):    16^(p-1) ||A||^(8 p h) lambda^(1/(2 n h (1+R))) < 1,
// and when A1 (A invertible), A2 and both forms of A3 hold for p, sup_k E||P'_k||^p < infinity
// (P'_k the prediction covariance). A3 is very conservative: with ||A|| > 1 it almost never holds,
// so a failed A3 says nothing about instability. Theorem 1 holds pathwise for every arrival
// sequence and is checked here as a runtime invariant of the filter.
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <string>
#include <vector>

#include "networked_estimation/stability/stability.hpp"

namespace networked_estimation
{

/// Both forms of A3 for one p.
struct ExcitationA3
{
  int p = 1;
  double printed = 0.0;  ///< 2^((p-1)/(ph)) ||A||^2 lambda^(1/(8 n p^2 (1+R)))
  double proof = 0.0;    ///< 16^(p-1) ||A||^(8ph) lambda^(1/(2nh(1+R)))
  bool holds() const { return printed < 1.0 && proof < 1.0; }
};

struct ExcitationReport
{
  int h = 1;
  double lambda_block = 0.0;     ///< smallest block excitation lambda_m (conditional or realised)
  double lambda = 1.0;           ///< S^0 rate of {1 - lambda_m}: lambda < 1 means excited
  double norm_A = 0.0;           ///< spectral norm ||A||
  std::vector<ExcitationA3> a3;  ///< p = 1, 2, ..., p_max
  /// STABLE: A1, A2 and A3 hold for some p (the largest such p is in numbers["p"]);
  /// UNDECIDED: excited but A3 fails for every p tried (A3 is very conservative: no conclusion),
  /// or not excited (lambda >= 1: the sufficient condition fails);
  /// NOT_APPLICABLE: A singular (A1), or the output is not scalar.
  Verdict verdict;
  static const char* caveat();  ///< the conservativeness note printed with every report
};

/// lambda_min(sum_{j<h} pi_j (A^j)' c c' A^j / (1 + ||c' A^j||^2)) / (1 + h), where pi_j is the
/// probability (given the past) that the sample j steps into the block arrives. c is 1 x n.
double blockExcitation(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, const std::vector<double>& pi);

/// A3 in both forms for p = 1..p_max.
std::vector<ExcitationA3> ganLiuA3(double norm_A, double lambda, int n, int h, double R, int p_max);

/// I.i.d. arrivals with probability `arrival` on the scalar sensor c (1 x n), noise variance R:
/// pi_j = arrival for every j, so lambda_m is a constant l and lambda = 1 - l.
ExcitationReport ganLiuIid(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, double arrival, int h,
                           int p_max = 4);

/// An on/off Markov chain of arrivals (failure p = P(lost | arrived before), recovery r): pi_j
/// depends on the last arrival before the block; lambda = rho(diag(1 - f) Pi^h), f(s) the block
/// excitation after state s.
ExcitationReport ganLiuMarkov(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, double failure,
                              double recovery, int h, int p_max = 4);

/// A recorded arrival sequence (gamma_1, gamma_2, ..., any pattern): the model-free proxy of the
/// excitation, lambda_m = lambda_min(G_m) / (1 + h) from the realised regressors, and
/// lambda = (prod over the blocks of (1 - lambda_m))^(1 / blocks). Throws std::invalid_argument when
/// the trace is shorter than one block.
ExcitationReport ganLiuTrace(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R,
                             const std::vector<bool>& arrivals, int h, int p_max = 4);

/// ganLiuTrace block by block, for a caller that keeps the blocks it has done (the live diagnostic
/// computes each block of its sliding window once): the Gram terms and ||A|| are computed once.
class GanLiuBlocks
{
public:
  /// Throws std::invalid_argument on inputs ganLiuTrace refuses.
  GanLiuBlocks(const Eigen::MatrixXd& A, const Eigen::MatrixXd& c, double R, int h, int p_max = 4);
  int h() const { return h_; }
  /// lambda_m of the block of h samples arrivals[first], ..., arrivals[first + h - 1].
  double block(const std::vector<bool>& arrivals, std::size_t first) const;
  /// The report for the blocks' lambda_m (at least one): ganLiuTrace's for the same blocks.
  ExcitationReport report(const std::vector<double>& lambdas) const;

private:
  Eigen::MatrixXd A_;
  double R_ = 1.0;
  int h_ = 1, p_max_ = 4;
  std::vector<Eigen::MatrixXd> terms_;
  double norm_A_ = 0.0;
};

/// Theorem 1, checked along one run: with P'_k the filter's prediction covariances (P'_0 first,
/// k = 0..K) and the arrivals gamma_1..gamma_K, every block m >= 1 must satisfy
///   T_{m+1} <= (1 - a_{m+1}) ||A||^(2h) T_m + b_A.
/// Returns the largest lhs - rhs over the blocks (<= 0 when the inequality holds everywhere) and
/// the block where it is reached. Q is the process noise covariance of the state (B Q B').
struct Theorem1Check
{
  double worst = -std::numeric_limits<double>::infinity();  ///< max over blocks of lhs - rhs
  long block = -1;
  long blocks = 0;
  bool holds() const { return worst <= 1e-9 * (1.0 + std::abs(worst)); }
};
Theorem1Check ganLiuTheorem1(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& c, double R,
                             const std::vector<Eigen::MatrixXd>& predicted, const std::vector<bool>& arrivals, int h);

/// Theorem 1 checked as a filter runs (the live form of ganLiuTheorem1): feed P'_0 with start(),
/// then after every step k the arrival gamma_{k-1}... in P3's indexing: add(gamma_i, P'_{i+1}).
/// O(h n^3) per completed block; the constants are computed once.
class Theorem1Monitor
{
public:
  /// Throws std::invalid_argument when A is singular (A1) or the inputs do not fit.
  Theorem1Monitor(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& c, double R, int h);
  /// The prediction covariance P'_0 the run starts from (also a restart).
  void start(const Eigen::MatrixXd& P0);
  /// The arrival gamma_i used to go from P'_i to P'_{i+1}, and P'_{i+1}.
  void add(bool gamma, const Eigen::MatrixXd& P_next);
  const Theorem1Check& check() const { return check_; }
  long violations() const { return violations_; }

private:
  Eigen::MatrixXd A_, Q_, c_;
  double R_;
  int h_;
  std::vector<Eigen::MatrixXd> Ai_;     ///< A^-j, j = 0..h
  std::vector<Eigen::MatrixXd> terms_;  ///< Gram terms, j = 0..h-1
  Eigen::MatrixXd backQ_;               ///< sum_{j=1}^h A^-j Q A^-j'
  double b_A_ = 0.0, growth_ = 0.0;
  bool started_ = false;
  long block_ = 0;        ///< index m of the block being filled
  int pos_ = 0;           ///< steps of it seen
  Eigen::MatrixXd S_;     ///< P'_{mh} + backQ
  Eigen::MatrixXd G_;     ///< realised Gram matrix of block m
  double T_block_ = 0.0;  ///< T_{m+1} so far
  double T_prev_ = 0.0;   ///< T_m
  Theorem1Check check_;
  long violations_ = 0;
};

}  // namespace networked_estimation
