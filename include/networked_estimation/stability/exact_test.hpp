// Marelli et al.'s exact test (Theorem 14, docs/stability.md 3.5, 3.5b): the growth rate Phi_k of
// each FMO block with |alpha| >= 1 for the sensors' links (and a sensor schedule), the verdict, and the
// exact critical arrival and recovery rates. ROS-free.
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <string>
#include <vector>

#include "networked_estimation/config/schedule.hpp"
#include "networked_estimation/stability/eigen_structure.hpp"
#include "networked_estimation/stability/link_model.hpp"

namespace networked_estimation
{

// Marelli et al.: exact test (Theorem 14). Phi_k from the kernel lattice of Proposition 24, extended
// to blocks that are not diagonalizable (docs/stability.md 3.5c: ours, not the papers').

/// How the growth rate Phi_k of one FMO block with |alpha| >= 1 is computed.
struct BlockStructure
{
  FmoBlock block;
  enum class Method
  {
    LATTICE,            ///< kernel lattice: Proposition 24 (diagonalizable block) or its extension to Jordan
                        ///< structure (docs/stability.md 3.5c)
    SINGLE_EIGENVALUE,  ///< one eigenvalue, every sensor that sees the block observes it alone (Corollary 26
                        ///< generalised): the lattice is the block alone, Phi = prod of those sensors' persistences
    UNAVAILABLE         ///< the lattice exceeds the cap; `reason` says so
  };
  Method method = Method::UNAVAILABLE;
  std::string reason;
  std::vector<bool> relevant;  ///< sensor j sees the block (H_j V_k != 0)
  /// For every non-trivial lattice element K (the first is the whole block) and every sensor j and
  /// phase s < N_k: seen[K][j][s] = packets of sensor j at phase s inform on K (K is not inside the
  /// subspace they leave unobservable; diagonalizable blocks: H_j V_k A_k^s B_K != 0).
  std::vector<std::vector<std::vector<bool>>> seen;
};

/// Analyses the blocks of eigenvalues with modulus >= 1 for the (whitened) sensor matrices H.
/// lattice_cap bounds the number of lattice elements (beyond it the block is UNAVAILABLE).
std::vector<BlockStructure> analyseBlocks(const Eigen::MatrixXd& A, const std::vector<Eigen::MatrixXd>& H,
                                          const StabilityTolerances& tol = {}, std::size_t lattice_cap = 512);
/// The same with A's blocks already found (blocks = fmoBlocks(A, 1.0, tol)): several sets of sensors
/// of one model share them.
std::vector<BlockStructure> analyseBlocks(const Eigen::MatrixXd& A, const std::vector<FmoBlock>& blocks,
                                          const std::vector<Eigen::MatrixXd>& H, const StabilityTolerances& tol = {},
                                          std::size_t lattice_cap = 512);

/// Phi_k of one block and whether it is exactly 1, decided on the links' structure (some set of link
/// states keeps every informing packet lost forever), not by rounding. phi NaN for an UNAVAILABLE
/// block (or a random schedule's joint chain beyond max_states, with `why` set).
struct BlockGrowth
{
  double phi = std::numeric_limits<double>::quiet_NaN();
  bool one = false;
};
BlockGrowth blockGrowth(const BlockStructure& block, const std::vector<LinkModel>& links);
/// The same under a sensor schedule (nullptr or inactive: without one); see blockPhiScheduled.
BlockGrowth blockGrowth(const BlockStructure& block, const std::vector<LinkModel>& links, const Schedule* schedule,
                        std::string* why = nullptr, std::size_t max_states = 512);

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
/// NaN for an UNAVAILABLE block. Without a schedule this is blockPhi.
double blockPhiScheduled(const BlockStructure& block, const std::vector<LinkModel>& links, const Schedule& schedule,
                         std::string* why = nullptr, std::size_t max_states = 512);

/// The schedule of a subset of the sensors (masks restricted to `set`, in its order).
Schedule restrictSchedule(const Schedule& schedule, const std::vector<int>& set);

/// Theorem 14: STABLE when |alpha_k|^2 Phi_k < 1 for every block, UNSTABLE when > 1 for some,
/// UNDECIDED at equality, NOT_APPLICABLE when a block with |alpha| >= 1 is UNAVAILABLE. A block on the
/// unit circle (|alpha| = 1 within tol.modulus) is decided exactly (docs/stability.md 3.5d): bounded
/// when Phi < 1, unbounded when Phi is exactly 1. With an
/// active `schedule` (over the same sensors as `links`), Phi_k is blockPhiScheduled's.
Verdict marelliTest(const std::vector<BlockStructure>& blocks, const std::vector<LinkModel>& links,
                    const StabilityTolerances& tol = {}, const Schedule* schedule = nullptr);

/// Critical common i.i.d. arrival rate (every sensor at rate lambda): inf{lambda : Theorem 14 stable}.
/// Closed form 1 - |alpha|^{-2/e} per block with e = min over lattice elements of (sensor, shift)
/// pairs that see it / N_k. Returns 1 + 0 * inf semantics: +inf when some block is unobservable
/// (never stable), NaN when some block is UNAVAILABLE, 0 without unstable blocks (and when every such
/// block is on the unit circle: then every positive rate is stable, and rate 0 is not).
double exactCriticalArrivalRate(const std::vector<BlockStructure>& blocks);

/// Critical common recovery rate r of on/off Gilbert-Elliott links with failure rate p (every
/// sensor): inf{r : Theorem 14 stable}, by bisection on the exact Phi (to 1e-12). Same special
/// values as exactCriticalArrivalRate.
double exactCriticalRecoveryRate(const std::vector<BlockStructure>& blocks, double p);

/// Corollary 26 (22): Phi = (prod_t P(C_t = C^(a) | C_s = C^(a), s < t))^{1/tau}.
double corollary26Phi(const std::vector<double>& conditional_bad_probabilities);

}  // namespace networked_estimation
