// Plant simulator: the linear plant of a Model with parametric uncertainty (fresh eps_j uniform in
// [-range_j, range_j] at every step), process and measurement noise, and a known control sequence
// delivered through a lossy actuator link (zero input applied when a command is lost, as in Lin et al.).
// The model's angular states and the outputs that measure them are wrapped into (-pi, pi] at every
// step (docs/formats.md 1.2b), as a real plant's heading and its sensors' readings are.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/common/random.hpp"

namespace networked_estimation
{

/// The known command sequence u_k (k = 1, 2, ...), the same value in every input channel.
struct ControlSequence
{
  enum class Kind
  {
    CONSTANT,  ///< u_k = value
    STEP,      ///< u_k = 0 for k < step_at, value for k >= step_at
    PAPER      ///< u_k = value * (1 + exp(-k/10)), Lin et al.'s example (value = 1 gives the paper's)
  };
  Kind kind = Kind::PAPER;
  double value = 1.0;
  long step_at = 1;

  /// u_k as a p-vector.
  Eigen::VectorXd at(long k, int p) const;

  /// Parses "constant:V", "step:K:V", "paper" or "paper:V". Throws ConfigError naming `what`.
  static ControlSequence parse(const std::string& text, const std::string& what);
};

/// One simulated sample k.
struct SimulatedSample
{
  long k = 0;
  Eigen::VectorXd x;  ///< true state x_k
  Eigen::VectorXd y;  ///< y_k = C(eps_k) x_k + v_k (always computed, whether delivered or not)
  Eigen::VectorXd v;  ///< measurement noise v_k (what the papers' model delivers on a loss)
  Eigen::VectorXd u;  ///< commanded u_k (p-vector, empty without control)
  bool nu = true;     ///< u_k reached the actuator
};

/// Rounding floor. An unstable plant's state grows until the noise is lost in its rounding: past
/// that point y_k = C x_k + v_k carries v_k in its last bits only (or not at all), and an estimator
/// "reconstructs" x_k to rounding, so every error statistic is silently wrong (an MSE of 0). The
/// simulator refuses to go there: step() and stepApplied() throw DivergenceError at the first k with
///
///   ||x_k||_inf > limit = 1e-3 * sigma / eps,   eps = 2^-52 (DBL_EPSILON, 2.2e-16),
///   sigma = min( sqrt(lambda_min(R)) / c,  sqrt(lambda_min+(B Q B')) ),
///   c = ||C||_inf + sum_j range_j ||dC_j||_inf   (a bound on ||C(eps_k)||_inf),
///
/// sigma being the smallest standard deviation of the noise in state units: the measurement noise
/// through the largest output gain, and the process noise over its smallest non-zero direction
/// (lambda_min+: the smallest eigenvalue above n eps lambda_max; a direction without process noise
/// has none to lose). Beyond the limit the rounding of x_k and of C x_k (about ||x_k|| eps and
/// c ||x_k|| eps) is at least a thousandth of a noise the estimator is supposed to see; the factor
/// 1e3 leaves room for the amplification of that rounding by the filter's own arithmetic (the
/// innovation y - C xhat cancels two numbers of size c ||x||). Both noises count: past the floor of
/// the process noise the simulated plant no longer realises Q either. R must be positive definite
/// (the constructor refuses a singular R, so sigma > 0); c = 0 (no output depends on x) drops the
/// measurement term. A non-finite state is refused the same way, whatever the limit. The limit is
/// computed once at construction; each step costs one norm. After the error, do not step again.
class PlantSimulator
{
public:
  /// Streams: the initial state, process noise, measurement noise and eps each draw from their
  /// own generator derived from `seed`; the actuator link uses `actuator` (may be null = lossless).
  PlantSimulator(const Model& model, std::uint64_t seed, ControlSequence control = {},
                 std::unique_ptr<LossModel> actuator = nullptr);

  /// Advances from x_{k-1} to x_k and returns sample k (k starts at 1).
  /// x_0 ~ N(model.x0, model.P0) is drawn at construction.
  /// Throws DivergenceError (naming the model, k, ||x_k||_inf and the limit) when x_k crosses the
  /// rounding floor (see above) or is not finite.
  const SimulatedSample& step();

  /// Advances with a command applied from outside (the ROS graph, where the actuator link is a
  /// LossyChannel): `applied` is the u_k that reached the actuator (p values), or null when no
  /// command arrived (zero input, nu = false). The control sequence and actuator link given to the
  /// constructor are not used. Throws InputError when `applied` has the wrong size or is not finite.
  const SimulatedSample& stepApplied(const Eigen::VectorXd* applied);

  /// Starts over at k = 0 exactly as a PlantSimulator(model, seed, control, actuator) would, the
  /// actuator link (if any) reseeded with `actuator_seed`, without allocating (Monte Carlo runs).
  void restart(std::uint64_t seed, std::uint64_t actuator_seed = 0);

  const Eigen::VectorXd& state() const { return x_; }
  long k() const { return k_; }

  /// The rounding floor: the largest ||x_k||_inf accepted (1e-3 sigma / eps, see above).
  double stateLimit() const { return state_limit_; }
  /// Replaces the limit, e.g. by infinity in a test that uses noise below rounding on purpose (exact
  /// recursions). A non-finite state is still refused.
  void setStateLimit(double limit) { state_limit_ = limit; }

private:
  const SimulatedSample& advance(bool nu);
  void start();  ///< x_0 and eps_0 from the freshly seeded generators
  [[noreturn]] void throwBeyondFloor() const;

  const Model& model_;
  ControlSequence control_;
  std::unique_ptr<LossModel> actuator_;
  Rng rng_x0_, rng_w_, rng_v_, rng_eps_;
  Eigen::MatrixXd sqrtQ_, sqrtR_;  ///< lower Cholesky factors
  Eigen::MatrixXd sqrtP0_;         ///< psdSqrt(P0): x_0 = x0 + sqrtP0 z
  Eigen::VectorXd z0_;
  Eigen::VectorXd x_;
  long k_ = 0;
  SimulatedSample sample_;
  // Added by the simulator implementation: eps of the last sample (used in A, B of the next
  // transition) and preallocated work buffers so that step() does not allocate.
  Eigen::VectorXd eps_;
  Eigen::MatrixXd Ae_, Be_, Ce_;
  Eigen::VectorXd zw_, zv_, w_, xn_;
  std::vector<int> angle_rows_;  ///< angularRows(model): the outputs wrapped into (-pi, pi]
  // The rounding floor: limit on ||x_k||_inf and the noise standard deviation it derives from.
  double state_limit_ = 0.0, noise_sd_ = 0.0;
  const char* noise_kind_ = "";
};

}  // namespace networked_estimation
