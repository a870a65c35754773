// The plant and its sensors (docs/formats.md, "Model file"): linear,
//
//   x_k = A x_{k-1} + nu_k Bu u_k + B w_{k-1}      w ~ N(0, Q)
//   y_k = C x_k + v_k                               v ~ N(0, R), received iff gamma_k = 1
//
// or a built-in robot motion (key `motion`, motion/motion.hpp), x_k = f(x_{k-1}, dt) + w, w ~ N(0, Q dt)
// with Q per second, no A, B = I, no control, the same sensors.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "networked_estimation/config/schedule.hpp"
#include "networked_estimation/motion/motion.hpp"

namespace YAML
{
class Node;
}

namespace networked_estimation
{

/// One sensor: a block of rows of the stacked C and R.
struct Sensor
{
  std::string name;
  int offset = 0;  ///< first row in the stacked y / C / R
  int size = 0;    ///< number of rows (measurement dimension of this sensor)
};

/// One uncertain parameter eps_j: derivatives of A, B, C at eps = 0 (zero when absent in the file).
struct Uncertainty
{
  Eigen::MatrixXd dA;  ///< n x n
  Eigen::MatrixXd dB;  ///< n x nw
  Eigen::MatrixXd dC;  ///< m x n (stacked over sensors)
  double range = 0.0;  ///< simulation only: eps_j ~ Uniform[-range, range], fresh every step
};

struct Model
{
  std::string name;
  double period = 0.0;                   ///< seconds between samples k and k+1
  Eigen::MatrixXd A;                     ///< n x n
  Eigen::MatrixXd B;                     ///< n x nw (identity when absent)
  Eigen::MatrixXd Q;                     ///< nw x nw, positive definite
  Eigen::MatrixXd C;                     ///< m x n, stacked over sensors
  Eigen::MatrixXd R;                     ///< m x m, block diagonal over sensors, positive definite
  Eigen::VectorXd x0;                    ///< initial estimate and mean of the simulated initial state
  Eigen::MatrixXd P0;                    ///< initial covariance, positive semidefinite
  std::vector<Sensor> sensors;           ///< at least one; a single C/R file has one sensor "y"
  std::vector<Uncertainty> uncertainty;  ///< n_e entries (may be empty)
  Eigen::MatrixXd Bu;                    ///< n x p control input matrix (p = 0 without control)
  Schedule schedule;                     ///< which sensors transmit at each step (none: all, always)
  std::vector<std::string> states;       ///< names of the state entries (n of them), or empty
  /// The angular state components (indices, ascending): an angle lives in (-pi, pi], the
  /// estimators wrap it after every step and wrap the innovation of every row that measures it
  /// (angularRows; docs/algorithms.md 2.7, docs/formats.md 1.2b).
  std::vector<int> angles;
  /// LINEAR (A predicts), or a built-in motion: then A is empty, B = I, Q is per second, no
  /// control and no uncertainty; states and angles are the motion's (docs/algorithms.md 7).
  Motion motion = Motion::LINEAR;
  /// omni_3d only: z, roll, pitch, their rates and az held at 0 (robot_localization's two_d_mode).
  bool two_d_mode = false;

  int n() const { return motion == Motion::LINEAR ? static_cast<int>(A.rows()) : motionStates(motion); }
  /// Whether the model has a built-in nonlinear motion (no A).
  bool nonlinear() const { return motion != Motion::LINEAR; }
  int nw() const { return static_cast<int>(B.cols()); }
  int m() const { return static_cast<int>(C.rows()); }
  int p() const { return static_cast<int>(Bu.cols()); }
  int ne() const { return static_cast<int>(uncertainty.size()); }
  bool hasControl() const { return Bu.cols() > 0; }
};

/// Parses and validates a model. `source` names the file (or parameter namespace) in messages.
/// Throws ConfigError naming the key and the problem.
Model parseModel(const YAML::Node& node, const std::string& source);

/// Reads a YAML file and parses it with parseModel. Throws ConfigError (also for a missing file
/// or a YAML syntax error, with its line).
Model loadModel(const std::string& path);

/// The index of the sensor called `name`; throws ConfigError "<key>: '<name>' is not a sensor of the
/// model (sensors: a, b)" when there is none.
std::size_t sensorIndex(const Model& model, const std::string& name, const std::string& key);

/// The rows of C that measure an angle, ascending: row i is the unit vector e_j (C(i, j) = 1, every
/// other entry 0) of an angular state j (model.angles). Their innovations are wrapped.
std::vector<int> angularRows(const Model& model);

/// The name of state i: model.states[i], or "state <i>" when the model names none.
std::string stateName(const Model& model, int i);

/// Checks the invariants of an already built Model (dimensions, symmetry, definiteness, finite
/// values). parseModel calls it; code that builds a Model by hand should too.
void validateModel(const Model& model, const std::string& source);

}  // namespace networked_estimation
