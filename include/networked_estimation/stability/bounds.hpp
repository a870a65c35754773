// Yang et al.'s bounds for multi-sensor Kalman filtering with intermittent measurements
// (docs/stability.md 3.1-3.3, 3.8): the necessary lower bound, capacities, the closed-form bound,
// the lower-bound recursions, and the MARE upper bound with its certificate and bisection. ROS-free.
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <vector>

namespace networked_estimation
{

// Yang et al.: bounds and capacities (docs/stability.md 3.1-3.3, 3.8)

/// Sinopoli / Yang Theorem 1 with a common rate for N sensors: 1 - rho^{-2/N} (0 when rho <= 1).
double sinopoliLowerBound(double rho, int sensors = 1);
/// N = 1 closed-form MARE upper bound 1 - 1/M(A)^2 (0 when M = 1).
double mahlerUpperBound(double mahler);
/// Lin et al.'s Theorem 5 threshold on the recovery rate: p_t = 1 - rho^{-2} (may be <= 0).
double aoeRecoveryThreshold(double rho);

/// Capacity quantities of docs/stability.md 3.8 for per-sensor rates (rates in [0, 1)).
struct Capacity
{
  std::vector<double> individual;  ///< c_i = -1/2 ln(1 - lambda_i)
  double total = 0.0;              ///< c
  double lower = 0.0;              ///< c_lower = ln rho(A)
  double upper = 0.0;              ///< c_upper = h(A)
  double loss_product = 1.0;       ///< prod (1 - lambda_i)
  double weighted = 0.0;           ///< sum p_i c_i (Theorem 7)
  double log_abs_det = 0.0;        ///< ln |det A| (-inf when singular)
};
Capacity transmissionCapacity(const Eigen::MatrixXd& A, const std::vector<double>& rates,
                              const std::vector<int>& sensor_rows);

/// Theorem 5 of Yang et al. via the kernel chain of docs/stability.md 3.3 (rows of each sensor in order,
/// a row is chosen when it shrinks the unobservable subspace).
struct EntropySplit
{
  bool observable = false;                ///< (H, A) observable (the theorem's assumption)
  std::vector<double> max_block_entropy;  ///< per sensor: max_j h(A_ij) (0 when no row chosen)
  double sum = 0.0;                       ///< sum_i max_j h(A_ij): c above it suffices for some allocation
  std::vector<double> sufficient_rate;    ///< per sensor: 1 - exp(-2 max_j h(A_ij))
  double common_rate = std::numeric_limits<double>::quiet_NaN();  ///< max_i sufficient_rate (common-rate form)
};
EntropySplit entropySplit(const Eigen::MatrixXd& A, const std::vector<Eigen::MatrixXd>& H, double rel_tol = 1e-9);

/// One step of the lower bound recursion (Prop. 1): m(G) = loss_product A G A' + Q with
/// loss_product = prod(1 - lambda_i); G_1 = 0, G_{k+1} = m(G_k) satisfies G_k <= E[P-_k].
Eigen::MatrixXd lowerBoundStep(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, double loss_product,
                               const Eigen::MatrixXd& G);
/// Ḡ = sum_k Atil^k Q Atil'^k with Atil = sqrt(prod(1 - lambda_i)) A (Theorem 2); throws
/// std::domain_error when prod(1 - lambda_i) rho(A)^2 >= 1.
Eigen::MatrixXd lowerBoundLimit(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, double loss_product);
/// F̄ (Remark 3): fixed point of X = A (X^{-1} + S)^{-1} A' + Q with S = sum lambda_i H_i' H_i.
Eigen::MatrixXd informationLowerBoundLimit(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& S,
                                           int max_iterations = 100000);

struct MareOptions
{
  int max_iterations = 1500;
  double tolerance = 1e-11;        ///< relative: ||X_{k+1} - X_k|| < tolerance * max(1, ||X_k||)
  double divergence_trace = 1e10;  ///< tr X above it: diverged
};

struct MareResult
{
  enum class Status
  {
    CONVERGED,  ///< fixed point reached and certificate rho(T) < 1
    DIVERGED,   ///< tr X exceeded the divergence level
    UNDECIDED   ///< iteration cap reached, or converged without certificate
  };
  Status status = Status::UNDECIDED;
  Eigen::MatrixXd X;  ///< last iterate
  int iterations = 0;
  double certificate = std::numeric_limits<double>::quiet_NaN();  ///< rho(T) at the fixed point
};
/// MARE (18): g(X) = A X A' + Q - A X H'(W ⊙ (H X H' + I))^{-1} H X A' for whitened sensors H_i
/// with i.i.d. arrival rates lambda_i (sensors with lambda_i = 0 contribute nothing).
/// An upper bound on the spectral radius of the positive map T(Y) = sum_i M_i Y M_i' (docs/stability.md
/// 3.2): lambda_max(Y^-1/2 T(Y) Y^-1/2) at power iterates Y of T, the least found; stops when the
/// lower bound lambda_min is within rel_gap of it (relative) or after max_iterations.
double positiveMapRadiusBound(const std::vector<Eigen::MatrixXd>& Ms, int max_iterations = 400, double rel_gap = 1e-6);

class Mare
{
public:
  Mare(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::vector<Eigen::MatrixXd>& H,
       const std::vector<double>& rates);
  /// One step g(X) (symmetrised).
  Eigen::MatrixXd step(const Eigen::MatrixXd& X) const;
  /// Gain L(X) = A X H'(W ⊙ (H X H' + I))^{-1} Lambda^{-1} (n x m of the used sensors).
  Eigen::MatrixXd gain(const Eigen::MatrixXd& X) const;
  /// rho(T) with T = M0 ⊗ M0 + sum_i Mi ⊗ Mi at L = L(X) (docs/stability.md 3.2); < 1 certifies
  /// condition (1) of Theorem 4. Exact (the n^2 x n^2 matrix) up to kKroneckerStates states; above,
  /// the upper bound positiveMapRadiusBound (O(n^3) per iteration instead of O(n^6)).
  double certificateRadius(const Eigen::MatrixXd& X) const;
  static constexpr int kKroneckerStates = 8;
  /// Stacked whitened H of the sensors with a positive rate.
  const Eigen::MatrixXd& stackedH() const { return H_; }

private:
  friend MareResult solveMare(const Mare&, const MareOptions&, bool);
  Eigen::MatrixXd A_, Q_, H_, W_;
  Eigen::VectorXd lambda_rows_, sigma_rows_;
  std::vector<int> offset_, size_;
};

/// Iterates the MARE from X_0 = 0 and certifies the fixed point (docs/stability.md 3.2).
/// With stop_at_certificate, the iteration also stops as soon as the gain of the current iterate
/// certifies condition (1) (any L with rho(T_L) < 1 does), without reaching the fixed point.
MareResult solveMare(const Mare& mare, const MareOptions& options = {}, bool stop_at_certificate = false);

/// A critical rate found by bisection, with an explicit undecided band: the MARE diverges at
/// `diverges_at` (or it is the lower end of the search), converges (certified) at `converges_at`,
/// and iterations between them hit the cap. Without an undecided band the two differ by the
/// bisection tolerance.
struct CriticalBand
{
  double diverges_at = std::numeric_limits<double>::quiet_NaN();
  double converges_at = std::numeric_limits<double>::quiet_NaN();
  bool undecided_band = false;  ///< some rate inside was neither certified nor diverged
  int evaluations = 0;
};
/// Bisection on a common arrival rate lambda in [lo, hi] for the MARE of all sensors.
CriticalBand mareCriticalRate(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::vector<Eigen::MatrixXd>& H,
                              double lo, double hi, double tolerance = 1e-4, const MareOptions& options = {});

}  // namespace networked_estimation
