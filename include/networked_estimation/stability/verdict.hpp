// The outcome of a stability test (Verdict) and the numerical tolerances every test uses
// (docs/stability.md 2, 3.10). ROS-free.
#pragma once

#include <map>
#include <string>

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
/// "x, y grow regardless of the links" ("x grows ..." for one state): dead-reckoned states.
std::string growRegardless(const std::string& states);

/// Numerical tolerances (all relative unless stated).
struct StabilityTolerances
{
  double rank = 1e-9;           ///< singular values below rank * largest (or * scale) count as zero
  double eigen_cluster = 1e-5;  ///< eigenvalues closer than this (relative) are one repeated eigenvalue
  double modulus = 1e-6;        ///< equal moduli (FMO grouping, strong observability)
  int max_denominator = 24;     ///< FMO grouping: argument differences / 2 pi = p / q with q <= this
  double decision = 1e-9;       ///< |alpha|^2 Phi within this of 1 is undecided (Theorem 14 equality)
};

}  // namespace networked_estimation
