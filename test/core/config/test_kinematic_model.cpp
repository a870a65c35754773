// Kinematic models (kinematic_model.hpp) and the model writer (model_writer.hpp): A and Q against
// their closed forms and against a numerical integral, the file round trip, every refusal, and a
// Kalman filter on the generated model that is consistent (NEES) on a simulated robot.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/config/kinematic_model.hpp"
#include "networked_estimation/config/model_writer.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/simulation/simulator.hpp"

using namespace networked_estimation;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

KinematicSpec spec(const std::string& motion, int dims, double rate, double q)
{
  KinematicSpec s;
  s.name = "robot";
  s.motion = motion;
  s.dims = dims;
  s.rate = rate;
  s.density = q;
  s.sensors = {{"gnss", "position", 2.0}, {"odom", "velocity", 0.1}};
  return s;
}

/// The per-axis closed forms of the documentation, written out.
void closedForm(int order, double T, double q, MatrixXd& A, MatrixXd& Q)
{
  if (order == 2)
  {
    A.resize(2, 2);
    A << 1, T, 0, 1;
    Q.resize(2, 2);
    Q << T * T * T / 3, T * T / 2, T * T / 2, T;
  }
  else
  {
    const double T2 = T * T, T3 = T2 * T, T4 = T3 * T, T5 = T4 * T;
    A.resize(3, 3);
    A << 1, T, T2 / 2, 0, 1, T, 0, 0, 1;
    Q.resize(3, 3);
    Q << T5 / 20, T4 / 8, T3 / 6, T4 / 8, T3 / 3, T2 / 2, T3 / 6, T2 / 2, T;
  }
  Q *= q;
}

/// A per-axis block placed into the full state [positions, velocities, (accelerations)].
MatrixXd embed(const MatrixXd& block, int dims)
{
  const int order = static_cast<int>(block.rows());
  MatrixXd M = MatrixXd::Zero(order * dims, order * dims);
  for (int i = 0; i < order; ++i)
    for (int j = 0; j < order; ++j)
      for (int a = 0; a < dims; ++a)
        M(i * dims + a, j * dims + a) = block(i, j);
  return M;
}

/// |X - Y| <= tol |Y| entry by entry (a zero of Y must be an exact zero of X).
::testing::AssertionResult relativelyNear(const MatrixXd& X, const MatrixXd& Y, double tol)
{
  if (X.rows() != Y.rows() || X.cols() != Y.cols())
    return ::testing::AssertionFailure() << "size " << X.rows() << "x" << X.cols() << " vs " << Y.rows() << "x"
                                         << Y.cols();
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    for (Eigen::Index j = 0; j < X.cols(); ++j)
      if (!(std::abs(X(i, j) - Y(i, j)) <= tol * std::abs(Y(i, j))))
        return ::testing::AssertionFailure() << "entry (" << i << "," << j << "): " << X(i, j) << " vs " << Y(i, j);
  return ::testing::AssertionSuccess();
}

bool bitEqual(const MatrixXd& X, const MatrixXd& Y)
{
  return X.rows() == Y.rows() && X.cols() == Y.cols() && (X.array() == Y.array()).all();
}

/// The ConfigError message of makeKinematicModel(s), or "" when it does not throw.
std::string refusal(const KinematicSpec& s)
{
  try
  {
    makeKinematicModel(s);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(KinematicModel, AAndQEqualTheClosedForms)
{
  for (const char* motion : {"constant_velocity", "constant_acceleration"})
  {
    const int order = std::string(motion) == "constant_velocity" ? 2 : 3;
    for (int dims = 1; dims <= 3; ++dims)
    {
      for (const double rate : {10.0, 50.0, 100.0})
      {
        SCOPED_TRACE(std::string(motion) + " dims " + std::to_string(dims) + " rate " + std::to_string(rate));
        const Model m = makeKinematicModel(spec(motion, dims, rate, 0.7));
        MatrixXd A1, Q1;
        closedForm(order, 1.0 / rate, 0.7, A1, Q1);
        // pow(T, k) / k! against products of T: a few roundings apart, 1e-14 relative.
        EXPECT_TRUE(relativelyNear(m.A, embed(A1, dims), 1e-14));
        EXPECT_TRUE(relativelyNear(m.Q, embed(Q1, dims), 1e-14));
        EXPECT_TRUE(bitEqual(m.B, MatrixXd::Identity(order * dims, order * dims)));
        EXPECT_EQ(m.period, 1.0 / rate);
        EXPECT_EQ(m.n(), order * dims);
      }
    }
  }
}

TEST(KinematicModel, SensorsSelectTheirQuantityOnEveryAxis)
{
  KinematicSpec s = spec("constant_acceleration", 3, 50, 1.0);
  s.sensors = {{"gnss", "position", 2.0}, {"odom", "velocity", 0.1}, {"imu", "acceleration", 0.05}};
  const Model m = makeKinematicModel(s);
  ASSERT_EQ(m.sensors.size(), 3u);
  ASSERT_EQ(m.m(), 9);
  const double sigma[] = {2.0, 0.1, 0.05};
  for (int k = 0; k < 3; ++k)
  {
    EXPECT_EQ(m.sensors[k].name, s.sensors[k].name);
    EXPECT_EQ(m.sensors[k].offset, 3 * k);
    EXPECT_EQ(m.sensors[k].size, 3);
    MatrixXd C = MatrixXd::Zero(3, 9);
    C.block(0, 3 * k, 3, 3).setIdentity();  // state [x, y, z, vx, vy, vz, ax, ay, az]
    EXPECT_TRUE(bitEqual(m.C.middleRows(3 * k, 3), C)) << k;
    EXPECT_TRUE(bitEqual(m.R.block(3 * k, 3 * k, 3, 3), sigma[k] * sigma[k] * MatrixXd::Identity(3, 3))) << k;
  }
  EXPECT_TRUE(m.R.block(0, 3, 3, 6).isZero(0.0));
  EXPECT_TRUE(bitEqual(m.x0, VectorXd::Zero(9)));
  EXPECT_TRUE(bitEqual(m.P0, MatrixXd::Identity(9, 9)));
  EXPECT_EQ(kinematicStateNames(3, 3), (std::vector<std::string>{"x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az"}));

  s.x0 = VectorXd::LinSpaced(9, -4, 4);
  s.p0_position = 9;
  s.p0_velocity = 0.25;
  s.p0_acceleration = 0;  // positive semidefinite is enough for P0
  const Model g = makeKinematicModel(s);
  EXPECT_TRUE(bitEqual(g.x0, s.x0));
  VectorXd d(9);
  d << 9, 9, 9, 0.25, 0.25, 0.25, 0, 0, 0;
  EXPECT_TRUE(bitEqual(g.P0, MatrixXd(d.asDiagonal())));
}

// Q = integral_0^T e^{F s} G q G' e^{F' s} ds by composite Simpson, independent of the closed
// forms: F and G are built for the full state, e^{F s} is the Taylor series, exact because F is
// nilpotent (F^order = 0). The integrand's entries are polynomials in s of degree 2 (order - 1) at
// most; Simpson is exact to degree 3, and the one quartic entry (constant_acceleration, a position
// with itself: q s^4 / 4) has the error q T^5 / (30 N^4), 2/3 N^-4 = 4e-14 of its value at
// N = 2000. Rounding over the 2001 terms adds at most ~N eps = 4e-13 relative. Tolerance 1e-11
// relative per entry; the zero entries (between axes) must come out exactly zero.
TEST(KinematicModel, QEqualsTheIntegralOfTheContinuousModel)
{
  for (const char* motion : {"constant_velocity", "constant_acceleration"})
  {
    const int order = std::string(motion) == "constant_velocity" ? 2 : 3;
    for (int dims = 1; dims <= 3; ++dims)
    {
      for (const double rate : {5.0, 40.0})
      {
        SCOPED_TRACE(std::string(motion) + " dims " + std::to_string(dims) + " rate " + std::to_string(rate));
        const double q = 0.3, T = 1.0 / rate;
        const Model m = makeKinematicModel(spec(motion, dims, rate, q));
        const int n = order * dims;
        MatrixXd F = MatrixXd::Zero(n, n), G = MatrixXd::Zero(n, dims);
        for (int a = 0; a < dims; ++a)
        {
          for (int i = 0; i + 1 < order; ++i)
            F(i * dims + a, (i + 1) * dims + a) = 1.0;  // d/dt derivative i = derivative i + 1
          G((order - 1) * dims + a, a) = 1.0;           // the white noise drives the highest one
        }
        const auto expm = [&F, n](double s)
        {
          MatrixXd E = MatrixXd::Identity(n, n), term = MatrixXd::Identity(n, n);
          for (int k = 1; k <= n; ++k)
          {
            term = term * F * (s / k);
            E += term;
          }
          return E;
        };
        EXPECT_TRUE(relativelyNear(m.A, expm(T), 1e-14));
        const int N = 2000;
        const double h = T / N;
        MatrixXd integral = MatrixXd::Zero(n, n);
        for (int k = 0; k <= N; ++k)
        {
          const MatrixXd EG = expm(k * h) * G;
          const double weight = (k == 0 || k == N) ? 1.0 : (k % 2 ? 4.0 : 2.0);
          integral += weight * q * EG * EG.transpose();
        }
        integral *= h / 3.0;
        EXPECT_TRUE(relativelyNear(integral, m.Q, 1e-11));
      }
    }
  }
}

/// Q scaled to unit diagonal, D^-1/2 Q D^-1/2 with D = diag(Q).
static MatrixXd correlation(const MatrixXd& Q)
{
  const VectorXd s = Q.diagonal().cwiseSqrt().cwiseInverse();
  return s.asDiagonal() * Q * s.asDiagonal();
}

/// Smallest over largest eigenvalue of a symmetric matrix.
static double eigenvalueRatio(const MatrixXd& M)
{
  const VectorXd ev = Eigen::SelfAdjointEigenSolver<MatrixXd>(M, Eigen::EigenvaluesOnly).eigenvalues();
  return ev(0) / ev(ev.size() - 1);
}

// The model checks test definiteness on Q scaled to unit diagonal, which does not depend on the
// rate (Q = q S C S with S = diag(T^(r-1/2-i))). So every rate is accepted, also where Q's own
// eigenvalues span more than 12 orders of magnitude (above about 193 Hz for constant acceleration
// and 288 kHz for constant velocity, the limits of the former unscaled test), and Q there is still
// the closed form. Only rates at which Q's entries leave double precision are refused.
TEST(KinematicModel, EveryRateIsAccepted)
{
  for (const char* motion : {"constant_velocity", "constant_acceleration"})
  {
    const int order = std::string(motion) == "constant_velocity" ? 2 : 3;
    MatrixXd A10, Q10;
    closedForm(order, 0.1, 0.5, A10, Q10);
    for (const double rate : {193.0, 194.0, 1000.0, 1e4, 2.88e5, 1e6, 1e7})
    {
      for (int dims = 1; dims <= 3; ++dims)
      {
        SCOPED_TRACE(std::string(motion) + " dims " + std::to_string(dims) + " rate " + std::to_string(rate));
        ASSERT_EQ(refusal(spec(motion, dims, rate, 0.5)), "");
        const Model m = makeKinematicModel(spec(motion, dims, rate, 0.5));
        MatrixXd A1, Q1;
        closedForm(order, 1.0 / rate, 0.5, A1, Q1);
        EXPECT_TRUE(relativelyNear(m.A, embed(A1, dims), 1e-14));
        EXPECT_TRUE(relativelyNear(m.Q, embed(Q1, dims), 1e-14));
        // The scaled Q is the same at every rate (to rounding) and well conditioned.
        EXPECT_LT((correlation(Q1) - correlation(Q10)).cwiseAbs().maxCoeff(), 1e-14);
        EXPECT_GT(eigenvalueRatio(correlation(m.Q)), order == 2 ? 0.07 : 0.002);
        // A Cholesky factorisation of Q (the simulator's) succeeds and reproduces it.
        const Eigen::LLT<MatrixXd> llt(m.Q);
        ASSERT_EQ(llt.info(), Eigen::Success);
        const MatrixXd L = llt.matrixL();
        EXPECT_TRUE(relativelyNear(L * L.transpose(), m.Q, 1e-13));
      }
    }
  }
  // Where the former unscaled test refused: Q's eigenvalue ratio is below 1e-12.
  EXPECT_LT(eigenvalueRatio(makeKinematicModel(spec("constant_acceleration", 3, 1000, 0.5)).Q), 1e-12);
  EXPECT_LT(eigenvalueRatio(makeKinematicModel(spec("constant_velocity", 3, 1e7, 0.5)).Q), 1e-12);

  // Refused only where q T^5 (q T^3) underflows or an entry overflows; the message names the rate.
  EXPECT_EQ(refusal(spec("constant_acceleration", 2, 1e61, 1.0)), "");
  EXPECT_EQ(refusal(spec("constant_velocity", 2, 1e102, 1.0)), "");
  EXPECT_EQ(refusal(spec("constant_acceleration", 2, 1e-61, 1.0)), "");
  const std::string high = refusal(spec("constant_acceleration", 2, 1e62, 1.0));
  EXPECT_NE(high.find("rate: 1e+62 Hz with jerk-density 1 gives a constant_acceleration Q whose entries leave the "
                      "range of double precision (per axis from q T^5 = 5e-312 to q T = 1e-62; normal doubles are "
                      "2.2e-308 to 1.8e308 in magnitude); use a less extreme rate or density"),
            std::string::npos)
      << high;
  const std::string cv = refusal(spec("constant_velocity", 2, 1e103, 1.0));
  EXPECT_NE(cv.find("rate: 1e+103 Hz with accel-density 1 gives a constant_velocity Q whose entries leave the range "
                    "of double precision (per axis from q T^3 = "),
            std::string::npos)
      << cv;
  const std::string low = refusal(spec("constant_acceleration", 2, 1e-62, 1.0));
  EXPECT_NE(low.find("rate: 1e-62 Hz with jerk-density 1 gives a constant_acceleration Q whose entries leave the "
                     "range of double precision (per axis from q T^5 = inf to q T = "),
            std::string::npos)
      << low;
}

// A 3-D constant-acceleration model at 1 kHz (IMU rate) with position sensors only, 10^4 steps (10 s):
// the Kalman filter's covariance stays symmetric and positive definite (Cholesky succeeds at every
// step), and it is consistent. NEES at step k over R independent runs has mean n = 9 and standard
// deviation sqrt(2n / R); the tolerance is 4 of them (seeds fixed, so the result is reproducible:
// 9.36, 10.34, 8.87 and 9.41 at steps 10, 100, 1000 and 10^4 with R = 100, tolerance 1.70; 2000 runs
// of 1000 steps gave 9.11, 9.21 and 8.91, tolerance 0.38). The covariance stays exactly symmetric.
TEST(KinematicModel, KalmanFilterIsConsistentAt1kHz)
{
  KinematicSpec s = spec("constant_acceleration", 3, 1000, 2.0);
  s.sensors = {{"gnss", "position", 0.5}};
  const Model model = makeKinematicModel(s);
  const int n = model.n(), runs = 100, steps = 10000;
  const std::vector<int> checkpoints = {10, 100, 1000, 10000};
  std::vector<double> sums(checkpoints.size(), 0.0);
  EstimatorSettings settings;
  settings.algorithm = Algorithm::KF;
  auto kf = makeEstimator(model, settings);
  Sample sample;
  double worst_asymmetry = 0.0;
  for (int r = 0; r < runs; ++r)
  {
    PlantSimulator sim(model, 5000 + r);
    kf->reset();
    std::size_t next = 0;
    for (int k = 1; k <= steps; ++k)
    {
      sample.y = sim.step().y;
      kf->step(sample);
      const MatrixXd& P = kf->covariance();
      ASSERT_TRUE(P.allFinite()) << "run " << r << " step " << k;
      worst_asymmetry = std::max(worst_asymmetry, (P - P.transpose()).cwiseAbs().maxCoeff() / P.cwiseAbs().maxCoeff());
      const Eigen::LLT<MatrixXd> llt(0.5 * (P + P.transpose()));
      ASSERT_EQ(llt.info(), Eigen::Success) << "run " << r << " step " << k;
      if (next < checkpoints.size() && k == checkpoints[next])
      {
        const VectorXd e = sim.state() - kf->state();
        sums[next++] += e.dot(llt.solve(e));
      }
    }
  }
  EXPECT_LT(worst_asymmetry, 1e-12);
  const double tolerance = 4.0 * std::sqrt(2.0 * n / runs);
  for (std::size_t c = 0; c < checkpoints.size(); ++c)
  {
    SCOPED_TRACE("step " + std::to_string(checkpoints[c]));
    EXPECT_NEAR(sums[c] / runs, n, tolerance);
  }
}

TEST(KinematicModel, BadInputNamesTheOption)
{
  struct Case
  {
    std::string expected;
    KinematicSpec s;
  };
  std::vector<Case> cases;
  const auto add = [&cases](const std::string& expected, KinematicSpec s) { cases.push_back({expected, s}); };
  KinematicSpec s = spec("constant_velocity", 2, 50, 0.5);
  add("kinematic model 'robot': motion: expected constant_velocity or constant_acceleration, found 'constant_speed'",
      [s]() mutable
      {
        s.motion = "constant_speed";
        return s;
      }());
  add("dims: expected 1, 2 or 3, found 0",
      [s]() mutable
      {
        s.dims = 0;
        return s;
      }());
  add("dims: expected 1, 2 or 3, found 4",
      [s]() mutable
      {
        s.dims = 4;
        return s;
      }());
  add("rate: expected a finite number of Hz > 0, found 0",
      [s]() mutable
      {
        s.rate = 0;
        return s;
      }());
  add("rate: expected a finite number of Hz > 0, found -50",
      [s]() mutable
      {
        s.rate = -50;
        return s;
      }());
  add("rate: expected a finite number of Hz > 0, found inf",
      [s]() mutable
      {
        s.rate = kInf;
        return s;
      }());
  add("rate: expected a finite number of Hz > 0, found nan",
      [s]() mutable
      {
        s.rate = kNaN;
        return s;
      }());
  add("accel-density: expected a finite spectral density > 0 (m^2/s^3), found 0",
      [s]() mutable
      {
        s.density = 0;
        return s;
      }());
  add("accel-density: expected a finite spectral density > 0 (m^2/s^3), found nan",
      [s]() mutable
      {
        s.density = kNaN;
        return s;
      }());
  add("jerk-density: expected a finite spectral density > 0 (m^2/s^5), found -1",
      [s]() mutable
      {
        s.motion = "constant_acceleration";
        s.density = -1;
        return s;
      }());
  add("sensors: expected at least one sensor, found none",
      [s]() mutable
      {
        s.sensors.clear();
        return s;
      }());
  add("sensors[1].name: duplicate sensor name 'gnss' (also sensors[0].name)",
      [s]() mutable
      {
        s.sensors[1].name = "gnss";
        return s;
      }());
  add("sensors[0].name: expected a non-empty name, found ''",
      [s]() mutable
      {
        s.sensors[0].name = "";
        return s;
      }());
  add("sensors[1].quantity: expected position or velocity for a constant_velocity model, found 'speed'",
      [s]() mutable
      {
        s.sensors[1].quantity = "speed";
        return s;
      }());
  add("sensors[1].quantity: expected position or velocity for a constant_velocity model (acceleration needs a "
      "constant_acceleration model), found 'acceleration'",
      [s]() mutable
      {
        s.sensors[1].quantity = "acceleration";
        return s;
      }());
  add("sensors[1].quantity: expected position, velocity or acceleration for a constant_acceleration model, found "
      "'jerk'",
      [s]() mutable
      {
        s.motion = "constant_acceleration";
        s.sensors[1].quantity = "jerk";
        return s;
      }());
  add("sensors[1].sigma: expected a finite standard deviation > 0 (m/s), found 0",
      [s]() mutable
      {
        s.sensors[1].sigma = 0;
        return s;
      }());
  add("sensors[0].sigma: expected a finite standard deviation > 0 (m), found -2",
      [s]() mutable
      {
        s.sensors[0].sigma = -2;
        return s;
      }());
  add("sensors[0].sigma: expected a finite standard deviation > 0 (m), found inf",
      [s]() mutable
      {
        s.sensors[0].sigma = kInf;
        return s;
      }());
  add("x0: expected 4 entries (n = 4, the state x, y, vx, vy), found 3",
      [s]() mutable
      {
        s.x0 = VectorXd::Zero(3);
        return s;
      }());
  add("p0-velocity: expected a finite variance >= 0 (m/s squared), found -1",
      [s]() mutable
      {
        s.p0_velocity = -1;
        return s;
      }());
  add("p0-position: expected a finite variance >= 0 (m squared), found nan",
      [s]() mutable
      {
        s.p0_position = kNaN;
        return s;
      }());
  for (const Case& c : cases)
  {
    const std::string what = refusal(c.s);
    EXPECT_NE(what.find(c.expected), std::string::npos) << "expected '" << c.expected << "' in '" << what << "'";
  }
  EXPECT_THROW(kinematicOrder("linear"), ConfigError);
  EXPECT_THROW(densityKey(""), ConfigError);
}

TEST(KinematicModel, TheWrittenFileReadsBackBitForBit)
{
  const std::string path = ::testing::TempDir() + "kinematic_model_round_trip.yaml";
  KinematicSpec ca = spec("constant_acceleration", 3, 30, 1.0 / 3.0);
  ca.sensors.push_back({"imu", "acceleration", 0.017});
  ca.x0 = VectorXd::LinSpaced(9, -1.0 / 7.0, 3.3e-5);
  ca.p0_velocity = 0.1;
  KinematicSpec cv = spec("constant_velocity", 2, 7, 0.05);
  cv.name = "a \"quoted\" name: #1";
  KinematicSpec one = spec("constant_velocity", 1, 1000, 2.5e-3);
  for (const KinematicSpec& s : {ca, cv, one})
  {
    SCOPED_TRACE(s.name + " " + s.motion);
    const Model m = makeKinematicModel(s);
    {
      std::ofstream out(path);
      writeModelYaml(out, m, "header line\n\nmake_model --name 'x\ny'\n" + kinematicModelComment(s));
    }
    const Model r = loadModel(path);
    EXPECT_EQ(r.name, m.name);
    EXPECT_EQ(r.period, m.period);
    EXPECT_TRUE(bitEqual(r.A, m.A));
    EXPECT_TRUE(bitEqual(r.B, m.B));
    EXPECT_TRUE(bitEqual(r.Q, m.Q));
    EXPECT_TRUE(bitEqual(r.C, m.C));
    EXPECT_TRUE(bitEqual(r.R, m.R));
    EXPECT_TRUE(bitEqual(r.x0, m.x0));
    EXPECT_TRUE(bitEqual(r.P0, m.P0));
    ASSERT_EQ(r.sensors.size(), m.sensors.size());
    for (std::size_t k = 0; k < m.sensors.size(); ++k)
    {
      EXPECT_EQ(r.sensors[k].name, m.sensors[k].name);
      EXPECT_EQ(r.sensors[k].offset, m.sensors[k].offset);
      EXPECT_EQ(r.sensors[k].size, m.sensors[k].size);
    }
  }
  std::remove(path.c_str());

  std::ostringstream text;
  writeModelYaml(text, makeKinematicModel(cv), kinematicModelComment(cv));
  EXPECT_NE(text.str().find("# State [x, y, vx, vy] (m, m/s): all positions, then all velocities.\n"),
            std::string::npos)
      << text.str();
  EXPECT_NE(text.str().find("q [[T^3/3, T^2/2], [T^2/2, T]]"), std::string::npos);
  EXPECT_EQ(text.str().find("\nB:"), std::string::npos);  // B = identity is left out

  Model invalid = makeKinematicModel(cv);
  invalid.Q(0, 0) = -1.0;
  std::ostringstream ignored;
  EXPECT_THROW(writeModelYaml(ignored, invalid, ""), ConfigError);
}

// Every part of a model is written: control, uncertainty and each kind of schedule read back
// exactly (the Python module pickles models through this text).
TEST(ModelWriter, ControlUncertaintyAndSchedulesReadBack)
{
  const std::string base =
      "name: full\nperiod: 0.1\nA: [[1, 0.1, 0], [0, 1, 0], [0, 0, 0.9]]\nQ: [[0.3, 0, 0], [0, 0.1, 0], [0, 0, 1]]\n"
      "sensors:\n  - {name: a, C: [[1, 0, 0]], R: [[0.7]]}\n  - {name: b, C: [[0, 1, 0], [0, 0, 1]], R: [[1, 0.2], "
      "[0.2, 2]]}\n"
      "x0: [0.1, 0, 0]\nP0: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\ncontrol: {Bu: [[0.5], [1], [0]]}\n"
      "uncertainty:\n  - {dA: [[0, 0.01, 0], [0, 0, 0], [0, 0, 0]], range: 0.3}\n  - {dC: [[0.1, 0, 0], [0, 0, 0], [0, "
      "0, 0]], range: 1}\n";
  const std::vector<std::string> schedules = {
      "",
      "schedule: {pattern: [[a], [b], []]}\n",
      "schedule: {subsets: [[a], [a, b]], probabilities: [0.3, 0.7]}\n",
      "schedule: {subsets: [[a], [b]], transition: [[0.9, 0.1], [0.3, 0.7]]}\n",
  };
  for (const std::string& schedule : schedules)
  {
    const Model m = parseModel(YAML::Load(base + schedule), "full.yaml");
    std::ostringstream text;
    writeModelYaml(text, m, "");
    const Model r = parseModel(YAML::Load(text.str()), "written");
    EXPECT_EQ(r.A, m.A);
    EXPECT_EQ(r.Bu, m.Bu);
    EXPECT_EQ(r.R, m.R);
    ASSERT_EQ(r.uncertainty.size(), 2u);
    for (std::size_t j = 0; j < 2; ++j)
    {
      EXPECT_EQ(r.uncertainty[j].dA, m.uncertainty[j].dA);
      EXPECT_EQ(r.uncertainty[j].dB, m.uncertainty[j].dB);
      EXPECT_EQ(r.uncertainty[j].dC, m.uncertainty[j].dC);
      EXPECT_EQ(r.uncertainty[j].range, m.uncertainty[j].range);
    }
    EXPECT_EQ(static_cast<int>(r.schedule.kind), static_cast<int>(m.schedule.kind)) << schedule;
    EXPECT_EQ(r.schedule.pattern, m.schedule.pattern);
    EXPECT_EQ(r.schedule.subsets, m.schedule.subsets);
    EXPECT_EQ(r.schedule.markov, m.schedule.markov);
    EXPECT_EQ(r.schedule.transition, m.schedule.transition) << text.str();
  }
}

// --heading: the yaw is one more axis of the same motion, last in each group, with its own density,
// an angle of the model (written as `angles: [yaw]`), measured by one-row yaw sensors.
TEST(KinematicModel, HeadingIsAnAxisAndAnAngle)
{
  for (const int order : {2, 3})
  {
    KinematicSpec s = spec(order == 2 ? "constant_velocity" : "constant_acceleration", 2, 20, 0.5);
    s.heading_density = 0.03;
    s.p0_yaw = 0.2;
    s.p0_yaw_rate = 0.3;
    s.p0_yaw_acceleration = 0.4;
    s.sensors = {{"gnss", "position", 2.0}, {"compass", "yaw", 0.05}, {"gyro", "yaw_rate", 0.01}};
    const Model m = makeKinematicModel(s);
    SCOPED_TRACE(s.motion);
    const int D = 3, n = order * D;
    ASSERT_EQ(m.n(), n);
    EXPECT_EQ(m.states, order == 2
                            ? (std::vector<std::string>{"x", "y", "yaw", "vx", "vy", "vyaw"})
                            : (std::vector<std::string>{"x", "y", "yaw", "vx", "vy", "vyaw", "ax", "ay", "ayaw"}));
    EXPECT_EQ(m.angles, (std::vector<int>{2}));
    MatrixXd A1, Q1, Ah, Qh;
    closedForm(order, 0.05, 0.5, A1, Q1);
    closedForm(order, 0.05, 0.03, Ah, Qh);
    for (int i = 0; i < order; ++i)
      for (int j = 0; j < order; ++j)
      {
        EXPECT_NEAR(m.A(i * D + 2, j * D + 2), Ah(i, j), 1e-15);
        EXPECT_NEAR(m.Q(i * D + 2, j * D + 2), Qh(i, j), 1e-15 * Qh.cwiseAbs().maxCoeff());
        EXPECT_NEAR(m.Q(i * D + 0, j * D + 0), Q1(i, j), 1e-15 * Q1.cwiseAbs().maxCoeff());
        EXPECT_EQ(m.A(i * D + 2, j * D + 0), 0.0);  // the heading is its own axis
        EXPECT_EQ(m.Q(i * D + 2, j * D + 1), 0.0);
      }
    EXPECT_EQ(m.P0(2, 2), 0.2);
    EXPECT_EQ(m.P0(D + 2, D + 2), 0.3);
    if (order == 3)
    {
      EXPECT_EQ(m.P0(2 * D + 2, 2 * D + 2), 0.4);
    }
    ASSERT_EQ(m.sensors.size(), 3u);
    EXPECT_EQ(m.sensors[1].size, 1);
    EXPECT_EQ(m.C(2, 2), 1.0);      // compass: the yaw
    EXPECT_EQ(m.C(3, D + 2), 1.0);  // gyro: the yaw rate
    EXPECT_EQ(m.R(2, 2), 0.05 * 0.05);
    EXPECT_EQ(angularRows(m), (std::vector<int>{2}));
    // written and read back: the same names and angles
    std::ostringstream text;
    writeModelYaml(text, m, kinematicModelComment(s));
    EXPECT_NE(text.str().find("angles: [\"yaw\"]"), std::string::npos) << text.str();
    EXPECT_NE(text.str().find("# Heading: yaw, an angle in (-pi, pi]"), std::string::npos) << text.str();
    const Model r = parseModel(YAML::Load(text.str()), "heading.yaml");
    EXPECT_EQ(r.states, m.states);
    EXPECT_EQ(r.angles, m.angles);
    EXPECT_TRUE(bitEqual(r.Q, m.Q));
  }
  KinematicSpec s = spec("constant_velocity", 2, 20, 0.5);
  s.heading_density = 0.1;
  EXPECT_NE(refusal(
                [s]() mutable
                {
                  s.dims = 1;
                  return s;
                }())
                .find("heading: a heading needs a robot in 2-D or 3-D"),
            std::string::npos);
  EXPECT_NE(refusal(
                [s]() mutable
                {
                  s.heading_density = -1;
                  return s;
                }())
                .find("heading: expected a finite spectral density > 0 (rad^2/s^3), found -1"),
            std::string::npos);
  EXPECT_NE(refusal(
                [s]() mutable
                {
                  s.sensors[1].quantity = "yaw_acceleration";
                  return s;
                }())
                .find("(yaw_acceleration needs a constant_acceleration model)"),
            std::string::npos);
  EXPECT_NE(refusal(
                [s]() mutable
                {
                  s.p0_yaw = -1;
                  return s;
                }())
                .find("p0-yaw: expected a finite variance >= 0"),
            std::string::npos);
  KinematicSpec plain = spec("constant_velocity", 2, 20, 0.5);
  plain.sensors[1].quantity = "yaw";
  EXPECT_NE(refusal(plain).find("(yaw needs a heading: --heading)"), std::string::npos);
  EXPECT_TRUE(makeKinematicModel(spec("constant_velocity", 2, 20, 0.5)).angles.empty());
}

// A Kalman filter on the generated model, fed the simulation of that same model (x_0 drawn from
// N(x0, P0), process noise Q, measurement noise R), is exactly consistent: at every step the error
// e_k = x_k - x_{k|k} is N(0, P_{k|k}), so NEES_k = e_k' P_{k|k}^-1 e_k is chi-square with n degrees of
// freedom (mean n, variance 2n). Runs with different seeds are independent: the mean of NEES at the
// last step over R runs has mean n and standard deviation sqrt(2n / R). The tolerance is 4 of them
// (a false alarm about once in 16000; the seeds are fixed, so the result is reproducible: 3.95 for
// n = 4 and 9.30 for n = 9 with R = 1000, against tolerances 0.36 and 0.54). A filter that believes
// a process noise 100 times too small must land far above that band (it gives about 100 and 140).
TEST(KinematicModel, KalmanFilterIsConsistentOnTheSimulatedRobot)
{
  KinematicSpec cv = spec("constant_velocity", 2, 20, 0.5);
  cv.sensors = {{"gnss", "position", 1.0}, {"odom", "velocity", 0.2}};
  KinematicSpec ca = spec("constant_acceleration", 3, 50, 2.0);
  ca.sensors = {{"gnss", "position", 0.5}, {"imu", "acceleration", 0.1}};
  for (const KinematicSpec& s : {cv, ca})
  {
    SCOPED_TRACE(s.motion);
    const Model truth = makeKinematicModel(s);
    Model wrong = truth;
    wrong.Q *= 0.01;
    const int n = truth.n(), runs = 1000, steps = 60;
    EstimatorSettings settings;
    settings.algorithm = Algorithm::KF;
    const auto meanNees = [&](const Model& filter_model)
    {
      auto kf = makeEstimator(filter_model, settings);
      double sum = 0.0;
      Sample sample;
      for (int r = 0; r < runs; ++r)
      {
        PlantSimulator sim(truth, 1000 + r);
        kf->reset();
        double nees = 0.0;
        for (int k = 1; k <= steps; ++k)
        {
          sample.y = sim.step().y;
          kf->step(sample);
          const VectorXd e = sim.state() - kf->state();
          nees = e.dot(kf->covariance().ldlt().solve(e));
        }
        sum += nees;
      }
      return sum / runs;
    };
    const double tolerance = 4.0 * std::sqrt(2.0 * n / runs);
    EXPECT_NEAR(meanNees(truth), n, tolerance);
    EXPECT_GT(meanNees(wrong), n + tolerance);
  }
}
