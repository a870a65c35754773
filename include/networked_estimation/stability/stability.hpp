// Stability analysis of Kalman filtering over lossy links (docs/stability.md; Lin et al., Theorem 5;
// Zhou, Theorem 5): critical arrival rates, the MARE upper bound with its certificate, the
// exact test of Marelli et al. (Theorem 14 with Proposition 24 / Corollary 26) where it is
// computable, the Markov (Gilbert-Elliott) threshold on the recovery rate, and the RSEIO
// convergence checklist. ROS-free.
//
// Every test returns a Verdict (stable / unstable / undecided / not applicable) with the reason and
// the numbers behind it; an input that violates an assumption of a test gives "not applicable".
//
// Conventions: the process noise covariance is B Q B' (n x n); a sensor i is whitened as
// H_i = L_i^{-1} C_i with R_i = L_i L_i' (so H_i' H_i = C_i' R_i^{-1} C_i). Each sensor has its own
// link: analyzeStability takes one (optional) channel per sensor, a sensor without one being
// lossless; the single-channel form gives every sensor an independent copy of the one channel (as
// the simulate tool and the nodelets do).
#pragma once

#include <Eigen/Dense>
#include <complex>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/schedule.hpp"
#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/estimator_settings.hpp"

namespace networked_estimation
{

/// The outcome of one test.
struct Verdict
{
  enum class Kind
  {
    STABLE,         ///< the expected error covariance stays bounded (or the test's notion of convergence holds)
    UNSTABLE,       ///< it is unbounded
    UNDECIDED,      ///< the available conditions do not decide (e.g. between a necessary and a sufficient threshold)
    NOT_APPLICABLE  ///< an assumption of the test fails; `reason` names it
  };
  Kind kind = Kind::NOT_APPLICABLE;
  std::string reason;
  std::map<std::string, double> numbers;  ///< the quantities the verdict was decided on
};

/// "stable", "unstable", "undecided", "not applicable".
std::string toString(Verdict::Kind kind);
/// "<kind>: <reason>".
std::string describe(const Verdict& verdict);

/// Numerical tolerances (all relative unless stated).
struct StabilityTolerances
{
  double rank = 1e-9;         ///< singular values below rank * largest (or * scale) count as zero
  double eigen_cluster = 1e-5; ///< eigenvalues closer than this (relative) are one repeated eigenvalue
  double modulus = 1e-6;      ///< equal moduli (FMO grouping, strong observability)
  int max_denominator = 24;    ///< FMO grouping: argument differences / 2 pi = p / q with q <= this
  double decision = 1e-9;     ///< |alpha|^2 Phi within this of 1 is undecided (Theorem 14 equality)
};

// ---------------------------------------------------------------------------------------------
// Eigen-structure helpers

/// Eigenvalues of A (complex, in the order of Eigen::EigenSolver).
Eigen::VectorXcd eigenvalues(const Eigen::MatrixXd& A);
/// rho(A) = max |lambda_i|.
double spectralRadius(const Eigen::MatrixXd& A);
/// M(A) = prod_i max(1, |lambda_i|) (docs/stability.md 1.3).
double mahlerMeasure(const Eigen::MatrixXd& A);
/// h(A) = ln M(A).
double topologicalEntropy(const Eigen::MatrixXd& A);
/// Numerical rank: singular values above rel_tol * max(scale, largest singular value).
int numericalRank(const Eigen::MatrixXcd& M, double rel_tol = 1e-9, double scale = 0.0);
/// Orthonormal basis of the null space of M (columns), with the same rank rule.
Eigen::MatrixXcd nullSpace(const Eigen::MatrixXcd& M, double rel_tol = 1e-9, double scale = 0.0);
/// Geometric = algebraic multiplicity for every eigenvalue cluster.
bool isDiagonalizable(const Eigen::MatrixXd& A, const StabilityTolerances& tol = {});
/// rank [C; CA; ...; CA^{n-1}] = n.
bool isObservable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, double rel_tol = 1e-9);
/// PBH: rank [A - lambda I, G] = n for every eigenvalue with |lambda| >= min_modulus
/// (min_modulus = 0: full controllability).
bool modesControllable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& G, double min_modulus = 0.0,
                       double rel_tol = 1e-9);
/// PBH: rank [A - lambda I; C] = n for every eigenvalue with |lambda| >= min_modulus (min_modulus = 1:
/// detectability).
bool modesObservable(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, double min_modulus = 0.0,
                     double rel_tol = 1e-9);
/// Lin et al.'s Definition 5 (docs/stability.md 1.3): A diagonalizable and, for every group of eigenvalues of equal
/// modulus, C V restricted to the group has full column rank. NOT_APPLICABLE when A is not
/// diagonalizable; STABLE stands for "strongly observable", UNSTABLE for "not strongly observable".
Verdict strongObservability(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const StabilityTolerances& tol = {});

/// One FMO block (docs/stability.md 1.3, 3.5) of the eigenvalues with modulus >= min_modulus.
struct FmoBlock
{
  std::complex<double> alpha;                    ///< a representative eigenvalue
  double modulus = 0.0;                          ///< |alpha|
  int order = 1;                                 ///< common multiplicative order N_k
  std::vector<std::complex<double>> eigenvalues; ///< members, with algebraic multiplicity
  bool diagonalizable = true;                    ///< geometric = algebraic multiplicity for every member
  bool single_eigenvalue = true;                 ///< all members are the same eigenvalue
  Eigen::MatrixXcd basis;       ///< n x n_k: eigenvectors (diagonalizable) or generalised eigenspace basis
  Eigen::VectorXcd diagonal;    ///< diagonalizable: eigenvalue of each basis column
  Eigen::MatrixXcd eigenspace;  ///< single eigenvalue: basis of ker(A - alpha I)
};
/// Groups the eigenvalues with |lambda| >= min_modulus (relative tolerance) into FMO blocks: equal
/// modulus and argument differences / 2 pi rational with denominator <= tol.max_denominator.
/// Ordered by decreasing modulus.
std::vector<FmoBlock> fmoBlocks(const Eigen::MatrixXd& A, double min_modulus = 1.0, const StabilityTolerances& tol = {});

// ---------------------------------------------------------------------------------------------
// Links

/// The arrival process of one sensor's link: i.i.d. (Bernoulli) or a Gilbert-Elliott chain
/// (two hidden states, P(lost | state) = loss_good / loss_bad).
struct LinkModel
{
  enum class Kind
  {
    IID,
    GILBERT_ELLIOTT
  };
  Kind kind = Kind::IID;
  double arrival = 1.0;  ///< IID: P(arrived)
  double p = 0.0;        ///< GE: P(good -> bad)
  double r = 1.0;        ///< GE: P(bad -> good)
  double loss_good = 0.0, loss_bad = 1.0;

  static LinkModel iid(double arrival_rate);
  static LinkModel gilbertElliott(double p, double r, double loss_bad = 1.0, double loss_good = 0.0);
  /// bernoulli: arrival = 1 - loss; gilbert_elliott: the chain.
  static LinkModel fromSettings(const ChannelSettings& settings);

  /// GE with loss_bad = 1 and loss_good = 0: the arrival indicator itself is a two-state Markov chain.
  bool onOff() const { return kind == Kind::GILBERT_ELLIOTT && loss_bad == 1.0 && loss_good == 0.0; }
  /// Stationary arrival rate (GE on/off: r / (p + r)).
  double arrivalRate() const;
  /// Stationary P(arrived at k | lost at k-1) (IID: the arrival rate; GE on/off: r). NaN when a
  /// loss never happens.
  double recoveryRate() const;
  /// lim_T P(T consecutive losses)^{1/T}: 1 - arrival (IID), 1 - r (GE on/off), in general the
  /// spectral radius of P diag(loss_state).
  double lossPersistence() const;
  /// Transition matrix (row-stochastic, rows = current state) and per-state loss probability of
  /// the hidden chain; one state for IID.
  Eigen::MatrixXd transition() const;
  Eigen::VectorXd stateLoss() const;
};

// ---------------------------------------------------------------------------------------------
// Marelli et al.: exact test (Theorem 14) via Proposition 24 / Corollary 26

/// How the growth rate Phi_k of one unstable FMO block is computed.
struct BlockStructure
{
  FmoBlock block;
  enum class Method
  {
    LATTICE,            ///< Proposition 24: diagonalizable block, kernel lattice (finite-state channels)
    SINGLE_EIGENVALUE,  ///< every sensor that sees the block observes it alone (Corollary 26 generalised):
                        ///< Phi = prod over those sensors of the loss persistence
    UNAVAILABLE         ///< neither applies; `reason` says why
  };
  Method method = Method::UNAVAILABLE;
  std::string reason;
  std::vector<bool> relevant;  ///< sensor j sees the block (H_j V_k != 0)
  /// LATTICE: for every non-trivial lattice element K, seen[K][j][s] = (H_j V_k A_k^s B_K != 0).
  std::vector<std::vector<std::vector<bool>>> seen;
};

/// Analyses the blocks of eigenvalues with modulus >= 1 for the (whitened) sensor matrices H.
/// lattice_cap bounds the number of lattice elements (beyond it the block is UNAVAILABLE).
std::vector<BlockStructure> analyseBlocks(const Eigen::MatrixXd& A, const std::vector<Eigen::MatrixXd>& H,
                                          const StabilityTolerances& tol = {}, std::size_t lattice_cap = 512);

/// Phi_k (docs/stability.md 3.5) of one block for the sensors' links (links.size() = H.size()).
/// NaN for an UNAVAILABLE block.
double blockPhi(const BlockStructure& block, const std::vector<LinkModel>& links);

/// Phi_k under a sensor schedule (schedule.hpp; Marelli et al. section 7 and Proposition 24 with
/// period tau): the links are time-driven (each link's chain advances every step) and a sensor
/// gives information on a lattice element at shift s only when it is scheduled and arrives.
///   periodic: Phi = max over phases t < tau and lattice elements K of
///             prod_j rho(prod_{s < M} D_{j,s} P_j)^{1/M}, M = lcm(N_k, tau);
///   random:   the hidden chain is (schedule state, every link's state); Phi = max over K of
///             rho(prod_{s < N_k} D_s T)^{1/N_k} with T the joint transition matrix (at most
///             `max_states` joint states: NaN beyond, with `why` set).
/// A single-eigenvalue block is treated as one element seen by its relevant sensors at every
/// shift. NaN for an UNAVAILABLE block. Without a schedule this is blockPhi.
double blockPhiScheduled(const BlockStructure& block, const std::vector<LinkModel>& links, const Schedule& schedule,
                         std::string* why = nullptr, std::size_t max_states = 512);

/// The schedule of a subset of the sensors (masks restricted to `set`, in its order).
Schedule restrictSchedule(const Schedule& schedule, const std::vector<int>& set);

/// Theorem 14: STABLE when |alpha_k|^2 Phi_k < 1 for every block, UNSTABLE when > 1 for some,
/// UNDECIDED at equality, NOT_APPLICABLE when a block with |alpha| >= 1 is UNAVAILABLE. With an
/// active `schedule` (over the same sensors as `links`), Phi_k is blockPhiScheduled's.
Verdict marelliTest(const std::vector<BlockStructure>& blocks, const std::vector<LinkModel>& links,
                    const StabilityTolerances& tol = {}, const Schedule* schedule = nullptr);

/// Critical common i.i.d. arrival rate (every sensor at rate lambda): inf{lambda : Theorem 14 stable}.
/// Closed form 1 - |alpha|^{-2/e} per block with e = min over lattice elements of (sensor, shift)
/// pairs that see it / N_k. Returns 1 + 0 * inf semantics: +inf when some block is unobservable
/// (never stable), NaN when some block is UNAVAILABLE, 0 without unstable blocks.
double exactCriticalArrivalRate(const std::vector<BlockStructure>& blocks);

/// Critical common recovery rate r of on/off Gilbert-Elliott links with failure rate p (every
/// sensor): inf{r : Theorem 14 stable}, by bisection on the exact Phi (to 1e-12). Same special
/// values as exactCriticalArrivalRate.
double exactCriticalRecoveryRate(const std::vector<BlockStructure>& blocks, double p);

/// Corollary 26 (22): Phi = (prod_t P(C_t = C^(a) | C_s = C^(a), s < t))^{1/tau}.
double corollary26Phi(const std::vector<double>& conditional_bad_probabilities);

// ---------------------------------------------------------------------------------------------
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
  std::vector<double> individual;   ///< c_i = -1/2 ln(1 - lambda_i)
  double total = 0.0;               ///< c
  double lower = 0.0;               ///< c_lower = ln rho(A)
  double upper = 0.0;               ///< c_upper = h(A)
  double loss_product = 1.0;        ///< prod (1 - lambda_i)
  double weighted = 0.0;            ///< sum p_i c_i (Theorem 7)
  double log_abs_det = 0.0;         ///< ln |det A| (-inf when singular)
};
Capacity transmissionCapacity(const Eigen::MatrixXd& A, const std::vector<double>& rates,
                              const std::vector<int>& sensor_rows);

/// Theorem 5 of Yang et al. via the kernel chain of docs/stability.md 3.3 (rows of each sensor in order,
/// a row is chosen when it shrinks the unobservable subspace).
struct EntropySplit
{
  bool observable = false;               ///< (H, A) observable (the theorem's assumption)
  std::vector<double> max_block_entropy; ///< per sensor: max_j h(A_ij) (0 when no row chosen)
  double sum = 0.0;                      ///< sum_i max_j h(A_ij): c above it suffices for some allocation
  std::vector<double> sufficient_rate;   ///< per sensor: 1 - exp(-2 max_j h(A_ij))
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
Eigen::MatrixXd informationLowerBoundLimit(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q,
                                           const Eigen::MatrixXd& S, int max_iterations = 100000);

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
  /// condition (1) of Theorem 4.
  double certificateRadius(const Eigen::MatrixXd& X) const;
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

// ---------------------------------------------------------------------------------------------
// Markov arrivals, Lin et al.'s Theorem 5

/// Lin et al.'s Theorem 5 (docs/stability.md 3.7): Assumption 1 (Q, R > 0; (A, C) observable;
/// (A, Q^1/2) controllable; recovery, failure in (0, 1]), Assumption 2 (diagonalizable, strongly
/// observable), then stable iff recovery > 1 - rho^{-2}. Q is the n x n process noise covariance.
Verdict aoeTheorem5(const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q,
                    const Eigen::MatrixXd& R, double recovery, double failure, const StabilityTolerances& tol = {});

// ---------------------------------------------------------------------------------------------
// RSEIO, Zhou's Theorem 5 (docs/stability.md 3.9)

/// Gramians of a word r (time order, letters 0 = drop, 1 = arrival) for Phi factors
/// (A_i, G_i, W_i): O(r) = sum (A_i...A_1)' W_i (A_i...A_1) and
/// Cg(r) = sum (A_N...A_{i+1}) G_i G_i' (A_N...A_{i+1})'.
Eigen::MatrixXd wordObservabilityGramian(const std::vector<int>& word, const Eigen::MatrixXd& A1,
                                         const Eigen::MatrixXd& W1, const Eigen::MatrixXd& A2);
Eigen::MatrixXd wordControllabilityGramian(const std::vector<int>& word, const Eigen::MatrixXd& A1,
                                           const Eigen::MatrixXd& G1, const Eigen::MatrixXd& A2,
                                           const Eigen::MatrixXd& G2);
/// Zhou's Theorem 5 checklist (docs/stability.md 3.9) for the model, mu and the arrival link of the whole
/// measurement. STABLE means "P_{t|t} converges to a unique stationary distribution" (sufficient
/// conditions hold); UNDECIDED when a sufficient condition fails; NOT_APPLICABLE when A, Acheck or
/// Atil is singular or the link is outside the theorem (e.g. a hidden GE chain).
Verdict rseioTheorem5(const Model& model, double mu, const LinkModel& link, const StabilityTolerances& tol = {});

// ---------------------------------------------------------------------------------------------
// Top level

/// An interval of a rate on which the verdict is stable (docs/stability.md 4.3). An edge inside
/// (0, 1) was located by bisection to the tolerance and lies on the stable side of the change; an
/// edge at 0 or 1 is the end of the range.
struct RateInterval
{
  double lower = std::numeric_limits<double>::quiet_NaN();
  double upper = std::numeric_limits<double>::quiet_NaN();
};

/// Results for a set of sensors, each with its own link of the given kind: the whole model, or
/// one sensor alone.
struct RateAnalysis
{
  std::string name;
  std::vector<int> sensors;  ///< indices into Model::sensors
  // i.i.d. arrivals at a common rate lambda on every sensor of the set
  double lower_bound = 0.0;  ///< necessary: 1 - rho^{-2/N} (Yang Theorem 1 / Sinopoli)
  double closed_form_upper = std::numeric_limits<double>::quiet_NaN();  ///< N = 1: 1 - 1/M^2; N > 1: Yang Thm 5 common rate
  CriticalBand mare;          ///< MARE threshold by bisection (NaN fields when A is stable)
  double exact_rate = std::numeric_limits<double>::quiet_NaN();  ///< Theorem 14, NaN when unavailable
  std::string exact_method;   ///< how exact_rate was obtained, or why it is unavailable
  // on/off Gilbert-Elliott links at a common recovery rate r with the links' failure rate p. When
  // the threshold depends on p and the set has no common Gilbert-Elliott p, none is assumed:
  // recovery_exact is NaN and recovery_note says why.
  double recovery_lower_bound = 0.0;  ///< necessary: rho^2 (1 - r)^N < 1
  double recovery_exact = std::numeric_limits<double>::quiet_NaN();  ///< NaN when not a half-line
  std::string recovery_note;          ///< the p used, "independent of p", or why not applicable
  /// The stable set of the common r when it is not a half-line (lattice blocks of order > 1):
  /// intervals found by a scan with bisection at each change (recovery_exact is then NaN).
  std::vector<RateInterval> recovery_stable;
  Verdict aoe_theorem5;       ///< Lin et al.'s Theorem 5 test (one packet = this set of sensors)
  std::vector<BlockStructure> blocks;
  // the given channel
  Verdict verdict;
  std::string margin_quantity;  ///< "arrival rate" or "recovery rate"
  double channel_value = std::numeric_limits<double>::quiet_NaN();  ///< the link's arrival or recovery rate
  double necessary_threshold = std::numeric_limits<double>::quiet_NaN();  ///< below: unbounded
  double sufficient_threshold = std::numeric_limits<double>::quiet_NaN(); ///< above: bounded
  double margin = std::numeric_limits<double>::quiet_NaN();  ///< channel_value - critical (exact, else sufficient)
  /// The stable set of channel_value when it is not a half-line (then the thresholds are NaN and
  /// the margin is the distance to the nearest edge, positive inside).
  std::vector<RateInterval> stable_intervals;
};

/// The rate one sensor needs, the other sensors' links fixed (docs/stability.md 4.3): the verdict
/// of the whole set (the same function as the report's verdict) along this sensor's arrival rate
/// (i.i.d. or lossless link) or recovery rate (on/off Gilbert-Elliott link with its own p).
struct SensorMargin
{
  std::string quantity;   ///< "arrival rate" or "recovery rate"; empty when not applicable
  std::string note;       ///< how the rate was found, or why there is none ("not applicable: ...")
  double value = std::numeric_limits<double>::quiet_NaN();  ///< this sensor's rate now
  /// The stable set along the rate is an upper half-line [converges_at, 1] (i.i.d. links; on/off
  /// links unless a lattice block of order > 1 is seen by this sensor). Otherwise it was found by a
  /// scan and is given as `stable` intervals, never as one threshold.
  bool half_line = true;
  /// half_line: unstable at and below diverges_at (NaN: no rate found unstable), stable at and above
  /// converges_at (NaN: not stable even at rate 1); undecided_band when undecided rates lie between.
  CriticalBand band;
  std::vector<RateInterval> stable;  ///< the stable set found (half_line: [converges_at, 1] or empty)
  int scan_points = 0;               ///< not half_line: grid points of the scan on [0, 1]
  /// half_line: value - converges_at. Otherwise the distance from value to the nearest edge of the
  /// stable set: positive inside a stable interval, negative outside.
  double margin = std::numeric_limits<double>::quiet_NaN();
};

/// One sensor's link and what it needs.
struct SensorLinkReport
{
  std::string sensor;
  bool lossless = false;    ///< no channel: an i.i.d. link with arrival 1
  LinkModel link;
  double arrival_rate = 1.0;
  double recovery_rate = std::numeric_limits<double>::quiet_NaN();
  double capacity = std::numeric_limits<double>::infinity();  ///< c_i = -1/2 ln(1 - arrival rate)
  SensorMargin margin;      ///< in the set of all sensors, the others' links fixed (only with per_sensor)
  /// The Markov (recovery-rate) threshold for this sensor: its margin when it has an on/off
  /// Gilbert-Elliott link; "not applicable: ..." otherwise (no failure rate p is assumed).
  std::string markov_note;
};

struct StabilityReport
{
  std::string model_name;
  Eigen::VectorXcd eigenvalues;
  double spectral_radius = 0.0, mahler_measure = 1.0, entropy = 0.0, log_abs_det = 0.0;
  bool diagonalizable = true;
  Verdict strong_observability;   ///< of (A, C) (all sensors stacked)
  bool noise_excites_unstable_modes = true;  ///< PBH: (A, B Q^1/2) controllable on every |lambda| >= 1
  bool detectable = true;                    ///< PBH: (C, A) observable on every |lambda| >= 1
  bool has_channel = false;       ///< some sensor has a channel
  bool uniform_links = true;      ///< every sensor has the same link (then `link` is that link)
  LinkModel link;                 ///< the channel of every sensor (uniform_links), else of sensor 0
  double arrival_rate = std::numeric_limits<double>::quiet_NaN();
  double recovery_rate = std::numeric_limits<double>::quiet_NaN();
  Capacity capacity;              ///< for each sensor's stationary arrival rate (lossless: 1, c_i = inf)
  /// What the capacity implies for this rate vector (Yang et al., Theorems 2 and 6).
  std::string capacity_note;
  /// Yang et al.'s MARE upper bound at this rate vector (every sensor at its own i.i.d. rate):
  /// "converges" (E[P] bounded, Theorem 4, with the fixed point's trace as a bound on the limit of
  /// E[P_k|k-1]), "diverges" or "undecided" (which prove nothing), or "not applicable: ...".
  std::string mare_at_rates = "not applicable: no channel given";
  double mare_at_rates_trace = std::numeric_limits<double>::quiet_NaN();
  double mare_at_rates_certificate = std::numeric_limits<double>::quiet_NaN();
  std::vector<SensorLinkReport> links;  ///< per sensor (empty without any channel)
  EntropySplit entropy_split;
  RateAnalysis model;             ///< all sensors
  std::vector<RateAnalysis> sensors;  ///< each sensor alone (empty when options.per_sensor is false)
  Verdict rseio;                  ///< Zhou's Theorem 5 (NOT_APPLICABLE unless the estimator is rseio)
  std::string estimator;          ///< the estimator analysed (kfio without settings)
  std::string estimator_note;     ///< how the verdicts relate to that estimator
};

struct AnalysisOptions
{
  bool per_sensor = true;  ///< each sensor alone (StabilityReport::sensors) and each sensor's margin
  double bisection_tolerance = 1e-4;  ///< MARE bisections (and margins decided by the MARE)
  double exact_tolerance = 1e-7;      ///< margins and intervals decided by Theorem 14
  int scan_points = 200;              ///< scan of a rate whose stable set is not a half-line
  MareOptions mare;
  StabilityTolerances tol;
};

/// Analyses the model with one link per sensor (links[i] for model.sensors[i]; none = lossless, an
/// i.i.d. link with arrival 1) and the estimator (nullable: kfio). When no sensor has a link the
/// report holds the thresholds only (verdicts "not applicable: no channel given").
StabilityReport analyzeStability(const Model& model, const std::vector<std::optional<ChannelSettings>>& links,
                                 const EstimatorSettings* estimator = nullptr, const AnalysisOptions& options = {});

/// The same with an independent copy of one channel on every sensor (nullable: thresholds only).
StabilityReport analyzeStability(const Model& model, const ChannelSettings* sensor_link,
                                 const EstimatorSettings* estimator = nullptr, const AnalysisOptions& options = {});

/// For every sensor of the model with these links (one per sensor): the rate it needs, the other
/// sensors' links fixed (the report's per-sensor margins, computed the same way).
std::vector<SensorMargin> sensorMargins(const Model& model, const std::vector<LinkModel>& links,
                                        const AnalysisOptions& options = {});

/// The verdict of docs/stability.md 2.1 for the model's sensors `set` with links (one per sensor of
/// the set): the function that analyzeStability and the per-sensor margins use.
Verdict stabilityVerdict(const Model& model, const std::vector<int>& set, const std::vector<LinkModel>& links,
                         const AnalysisOptions& options = {});

}  // namespace networked_estimation
