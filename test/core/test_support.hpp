// Models and random matrices for the core unit tests (built in C++, independent of the parser).
// Their definitions are compiled once, in test_support.cpp (the test support library), not in
// every test that includes this header (a QR and an eigensolver take seconds to compile).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <vector>

#include "networked_estimation/config/model.hpp"
#include "experiments/montecarlo_experiments.hpp"  // private header (src/core): the papers' example models
#include "networked_estimation/common/random.hpp"

namespace networked_estimation
{
namespace test
{

/// x_k = a x_{k-1} + w (Q = 1) seen by two scalar sensors y = x + v (R = I) named `first` and
/// `second`, with a scalar control input (Bu = 1) when `control`; validated.
Model scalarTwoSensorModel(double a, const std::string& first, const std::string& second, bool control = false);
/// r x c with entries uniform in [-scale, scale].
Eigen::MatrixXd randomMatrix(Rng& rng, int r, int c, double scale = 1.0);
/// Random symmetric positive definite matrix with eigenvalues in [lo, hi].
Eigen::MatrixXd randomSpd(Rng& rng, int n, double lo = 0.2, double hi = 3.0);
/// Single sensor "y" covering every row.
void singleSensor(Model& m);
/// Zhou's example (Section IV of his paper), as the Monte Carlo experiments build it.
Model zhouModel(double range = 1.0);
/// Lin et al.'s example with C = [[1, -1], [0, 1]] (our reading of the garbled C; docs/algorithms.md 6.2).
Model aoeModel(double rhoA = 1.2910);
/// A random model with n states, nw noise inputs, sensors of the given sizes, ne uncertain
/// parameters with non-zero dA, dB, dC, and p inputs.
Model randomModel(Rng& rng, int n, int nw, std::vector<int> sensor_sizes, int ne, int p);
/// max |a - b| over the entries.
double maxAbsDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b);
/// Smallest eigenvalue of a symmetric matrix.
double minEig(const Eigen::MatrixXd& S);

}  // namespace test
}  // namespace networked_estimation
