// The robot motions omni_2d / omni_3d and ekfio (docs/algorithms.md 7): the hand-derived Jacobian
// against finite differences, ekfio = kfio on linear models, its consistency on the simulated
// robot, the step's own dt, two_d_mode, the Estimator's online path, and every refusal.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "estimators/estimator_factory.hpp"  // private header: makeEstimator with the choice of form
#include "networked_estimation/common/angles.hpp"
#include "networked_estimation/common/error.hpp"
#include "networked_estimation/common/random.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/config/model_writer.hpp"
#include "networked_estimation/config/omni_model.hpp"
#include "networked_estimation/estimators/estimator.hpp"
#include "networked_estimation/motion/linearised_model.hpp"
#include "networked_estimation/motion/motion.hpp"
#include "networked_estimation/online/online_estimator.hpp"
#include "networked_estimation/simulation/simulator.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "test_support.hpp"

using namespace networked_estimation;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace
{

const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A random state of a motion: positions and velocities of order 1-5, angles anywhere but a pitch
/// within 1.2 rad of level (away from the Euler singularity at pi/2).
VectorXd randomState(Motion motion, Rng& rng)
{
  const int n = motionStates(motion);
  VectorXd x(n);
  for (int i = 0; i < n; ++i)
    x[i] = rng.uniform(-5.0, 5.0);
  for (const int a : motionAngles(motion))
    x[a] = rng.uniform(-kPi, kPi);
  if (motion == Motion::OMNI_3D)
    x[4] = rng.uniform(-1.2, 1.2);
  return x;
}

// F = df/dx against central differences (f(x + h e_j) - f(x - h e_j)) / 2h with h = 1e-5: the
// truncation error is h^2/6 |f'''| <= 1e-10 * 100 for these states (f is a polynomial of degree 2 in
// the velocities and accelerations times sines and cosines, and 1 / cos(pitch) <= 2.8), the rounding
// error eps |f| / h <= 2.2e-16 * 50 / 1e-5 = 1.1e-9; the tolerance 1e-6 is well above both and far
// below what a wrong entry gives (a sign or a missing term moves an entry by dt times a state of
// order 1, at least 1e-3 here).
TEST(Motion, JacobianEqualsFiniteDifferences)
{
  Rng rng(41);
  for (const Motion motion : {Motion::OMNI_2D, Motion::OMNI_3D})
  {
    const int n = motionStates(motion);
    double largest_off_identity = 0.0;
    for (int trial = 0; trial < 200; ++trial)
    {
      const VectorXd x = randomState(motion, rng);
      const double dt = rng.uniform(1e-3, 0.5);
      VectorXd fx, fp, fm;
      MatrixXd F;
      propagate(motion, x, dt, fx, &F);
      ASSERT_EQ(F.rows(), n);
      const double h = 1e-5;
      for (int j = 0; j < n; ++j)
      {
        VectorXd xp = x, xm = x;
        xp[j] += h;
        xm[j] -= h;
        propagate(motion, xp, dt, fp, nullptr);
        propagate(motion, xm, dt, fm, nullptr);
        const VectorXd column = (fp - fm) / (2.0 * h);
        for (int i = 0; i < n; ++i)
          EXPECT_NEAR(F(i, j), column[i], 1e-6) << toString(motion) << " F(" << i << "," << j << ") trial " << trial;
      }
      largest_off_identity = std::max(largest_off_identity, (F - MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff());
    }
    EXPECT_GT(largest_off_identity, 1.0) << "the Jacobian couples the states";
  }
}

// The planar part of omni_3d (z, roll, pitch and their rates and az zero) is omni_2d.
TEST(Motion, Omni3dInThePlaneIsOmni2d)
{
  Rng rng(5);
  const int map[8] = {0, 1, 5, 6, 7, 11, 12, 13};  // omni_2d's states in omni_3d
  for (int trial = 0; trial < 50; ++trial)
  {
    const VectorXd x2 = randomState(Motion::OMNI_2D, rng);
    VectorXd x3 = VectorXd::Zero(15);
    for (int i = 0; i < 8; ++i)
      x3[map[i]] = x2[i];
    const double dt = rng.uniform(0.001, 0.3);
    VectorXd f2, f3;
    MatrixXd F2, F3;
    propagate(Motion::OMNI_2D, x2, dt, f2, &F2);
    propagate(Motion::OMNI_3D, x3, dt, f3, &F3);
    for (int i = 0; i < 8; ++i)
    {
      EXPECT_NEAR(f3[map[i]], f2[i], 1e-14);
      for (int j = 0; j < 8; ++j)
        EXPECT_NEAR(F3(map[i], map[j]), F2(i, j), 1e-14);
    }
  }
}

// Known motions: facing +y (yaw pi/2) at 1 m/s forward, a step of 2 s goes 2 m along +y; a roll of
// pi/2 turns a body yaw rate into a pitch rate of the Euler angles (E's second row: -sin(roll) vyaw).
TEST(Motion, KnownSteps)
{
  VectorXd x = VectorXd::Zero(8), out;
  x[2] = kPi / 2;
  x[3] = 1.0;
  propagate(Motion::OMNI_2D, x, 2.0, out, nullptr);
  EXPECT_NEAR(out[0], 0.0, 1e-15);
  EXPECT_NEAR(out[1], 2.0, 1e-15);
  x[6] = 0.5;  // ax: d = v dt + a dt^2 / 2 = 2 + 1
  propagate(Motion::OMNI_2D, x, 2.0, out, nullptr);
  EXPECT_NEAR(out[1], 3.0, 1e-15);
  EXPECT_NEAR(out[3], 2.0, 1e-15);
  VectorXd y = VectorXd::Zero(15);
  y[3] = kPi / 2;
  y[11] = 0.1;
  propagate(Motion::OMNI_3D, y, 1.0, out, nullptr);
  EXPECT_NEAR(out[4], -0.1, 1e-15);
  EXPECT_NEAR(out[5], 0.0, 1e-15);
}

// ---------------------------------------------------------------------------------------------
// Models

OmniSpec omni2dSpec()
{
  OmniSpec s;
  s.name = "rover";
  s.motion = "omni_2d";
  s.rate = 20;
  // per second: small pose noise, velocities and accelerations that wander
  s.process_noise = {1e-4, 1e-4, 1e-4, 0.01, 0.01, 0.01, 0.1, 0.1};
  s.sensors = {{"gps", {"x", "y"}, {0.5}},
               {"imu", {"yaw", "vyaw", "ax", "ay"}, {0.02, 0.01, 0.1, 0.1}},
               {"odom", {"vx", "vy", "vyaw"}, {0.05}}};
  s.x0 = {0, 0, 3.0, 1.0, 0, 0.8, 0, 0};
  s.p0 = {0.01};
  return s;
}

OmniSpec omni3dSpec()
{
  OmniSpec s;
  s.name = "drone";
  s.motion = "omni_3d";
  s.rate = 20;
  s.process_noise = {1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 1e-4, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.1, 0.1, 0.1};
  s.sensors = {{"gps", {"x", "y", "z"}, {0.5}},
               {"imu",
                {"roll", "pitch", "yaw", "vroll", "vpitch", "vyaw", "ax", "ay", "az"},
                {0.02, 0.02, 0.02, 0.01, 0.01, 0.01, 0.1, 0.1, 0.1}},
               {"odom", {"vx", "vy", "vz"}, {0.05}}};
  s.x0 = {0, 0, 0, 0.1, -0.1, 3.0, 1.0, 0, 0, 0.05, -0.05, 0.8, 0, 0, 0};
  s.p0 = {0.01};
  return s;
}

TEST(MotionModel, TheFileDeclaresTheMotion)
{
  const std::string text =
      "period: 0.05\nmotion: omni_2d\nQ: [[1,0,0,0,0,0,0,0],[0,1,0,0,0,0,0,0],[0,0,1,0,0,0,0,0],[0,0,0,1,0,0,0,0],"
      "[0,0,0,0,1,0,0,0],[0,0,0,0,0,1,0,0],[0,0,0,0,0,0,1,0],[0,0,0,0,0,0,0,1]]\n"
      "sensors:\n  - {name: odom, C: [[0,0,0,1,0,0,0,0],[0,0,0,0,0,1,0,0]], R: [[0.01,0],[0,0.01]]}\n";
  const Model m = parseModel(YAML::Load(text), "m.yaml");
  EXPECT_EQ(m.motion, Motion::OMNI_2D);
  EXPECT_EQ(m.n(), 8);
  EXPECT_EQ(m.states, motionStateNames(Motion::OMNI_2D));
  EXPECT_EQ(m.angles, (std::vector<int>{2}));
  EXPECT_EQ(m.A.size(), 0);
  EXPECT_TRUE(m.P0.isIdentity(0.0));
  const auto error = [&](const std::string& extra)
  {
    try
    {
      parseModel(YAML::Load(text + extra), "m.yaml");
    }
    catch (const ConfigError& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(error("A: [[1]]\n").find("A: not used with motion omni_2d"), std::string::npos) << error("A: [[1]]\n");
  EXPECT_NE(error("B: [[1]]\n").find("B: not used with motion omni_2d"), std::string::npos);
  EXPECT_NE(error("control: {Bu: [[1],[0],[0],[0],[0],[0],[0],[0]]}\n").find("control: not used with motion omni_2d"),
            std::string::npos);
  EXPECT_NE(error("uncertainty: [{}]\n").find("uncertainty: not used with motion omni_2d"), std::string::npos);
  EXPECT_NE(error("two_d_mode: true\n").find("two_d_mode: only for omni_3d"), std::string::npos);
  EXPECT_NE(error("states: [a, b, c, d, e, f, g, h]\n").find("states: omni_2d's states are x, y, yaw"),
            std::string::npos);
  EXPECT_NE(error("angles: [x]\n").find("angles: omni_2d's angles are [yaw]"), std::string::npos);
  EXPECT_EQ(error("states: [x, y, yaw, vx, vy, vyaw, ax, ay]\nangles: [yaw]\n"), "accepted");
  EXPECT_NE(error("motion: omni_4d\n").find("duplicate key"), std::string::npos);  // YAML: motion twice
  const std::string no_period = text.substr(text.find('\n') + 1);
  try
  {
    parseModel(YAML::Load(no_period), "m.yaml");
    ADD_FAILURE() << "accepted a motion without a period";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("period: required with motion"), std::string::npos) << e.what();
  }
  try
  {
    parseModel(YAML::Load("motion: omni_4d\nperiod: 1\nQ: [[1]]\nC: [[1]]\nR: [[1]]\n"), "m.yaml");
    ADD_FAILURE() << "accepted omni_4d";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("motion: expected omni_2d or omni_3d, found 'omni_4d'"), std::string::npos)
        << e.what();
  }
  try
  {
    parseModel(YAML::Load("motion: omni_2d\nperiod: 1\nQ: [[1]]\nC: [[1]]\nR: [[1]]\n"), "m.yaml");
    ADD_FAILURE() << "accepted a 1x1 Q";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("Q: expected 8x8"), std::string::npos) << e.what();
  }
}

TEST(MotionModel, WrittenAndReadBack)
{
  for (OmniSpec spec : {omni2dSpec(), omni3dSpec()})
  {
    spec.two_d_mode = spec.motion == "omni_3d";
    const Model m = makeOmniModel(spec);
    std::ostringstream text;
    writeModelYaml(text, m, omniModelComment(spec));
    const Model r = parseModel(YAML::Load(text.str()), "back.yaml");
    EXPECT_EQ(r.motion, m.motion);
    EXPECT_EQ(r.two_d_mode, m.two_d_mode);
    EXPECT_EQ(r.period, m.period);
    EXPECT_EQ(r.Q, m.Q);
    EXPECT_EQ(r.C, m.C);
    EXPECT_EQ(r.R, m.R);
    EXPECT_EQ(r.x0, m.x0);
    EXPECT_EQ(r.P0, m.P0);
    EXPECT_EQ(text.str().find("\nA:"), std::string::npos) << text.str();
  }
  OmniSpec bad = omni2dSpec();
  bad.sensors[1].states[0] = "heading";
  EXPECT_THROW(makeOmniModel(bad), ConfigError);
  try
  {
    makeOmniModel(bad);
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("sensors[1].states: 'heading' is not a state of omni_2d"), std::string::npos);
  }
  bad = omni2dSpec();
  bad.process_noise = {1, 2};
  EXPECT_THROW(makeOmniModel(bad), ConfigError);
  bad = omni2dSpec();
  bad.two_d_mode = true;
  EXPECT_THROW(makeOmniModel(bad), ConfigError);
}

// ---------------------------------------------------------------------------------------------
// ekfio

EstimatorSettings ekfioSettings()
{
  EstimatorSettings s;
  s.algorithm = Algorithm::EKFIO;
  return s;
}

std::string buildError(const Model& m, Algorithm a)
{
  EstimatorSettings s;
  s.algorithm = a;
  s.has_control_link = true;
  try
  {
    makeEstimator(m, s);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "accepted";
}

TEST(Ekfio, TheLinearEstimatorsRefuseAMotion)
{
  const Model m = makeOmniModel(omni2dSpec());
  EXPECT_NE(buildError(m, Algorithm::RSEIO).find("rseio needs a linear model"), std::string::npos)
      << buildError(m, Algorithm::RSEIO);
  EXPECT_NE(buildError(m, Algorithm::RSEIO).find("sensitivity"), std::string::npos);
  EXPECT_NE(buildError(m, Algorithm::AOE).find("aoe needs a linear model"), std::string::npos);
  EXPECT_NE(buildError(m, Algorithm::OE).find("oe needs a linear model"), std::string::npos);
  for (const Algorithm a : {Algorithm::KF, Algorithm::KFIO, Algorithm::ACK_KF})
    EXPECT_NE(buildError(m, a).find(toString(a) + " needs a linear model"), std::string::npos) << buildError(m, a);
  EXPECT_NE(buildError(m, Algorithm::KFIO).find("use ekfio"), std::string::npos);
  EXPECT_EQ(buildError(m, Algorithm::EKFIO), "accepted");
}

/// max |a - b| / max(1, max |b|).
double relDiff(const MatrixXd& a, const MatrixXd& b)
{
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

// On a linear model ekfio's prediction is kfio's (the same operations) and its update the same
// code: random models with one to three sensors, per-sensor losses, a command, per-step R and an
// angle, stepped 300 times, agree to 1e-12 at every step (with kfio's dynamic form exactly; with
// its fixed-size form, where makeEstimator picks one, to rounding).
TEST(Ekfio, EqualsKfioOnLinearModels)
{
  Rng rng(2024);
  int cases = 0;
  for (int trial = 0; trial < 24; ++trial)
  {
    const int n = 1 + trial % 5;
    std::vector<int> sizes = {1 + trial % 2};
    if (trial % 3 > 0)
      sizes.push_back(1);
    if (trial % 3 > 1)
      sizes.push_back(2);
    Model m = test::randomModel(rng, n, n, sizes, 0, trial % 2);
    if (trial % 4 == 0 && n >= 2)
    {
      // state 0 an angle: periodic A (column 0 = e_0) and a unit row measuring it
      m.A.col(0) = VectorXd::Unit(n, 0);
      m.C.col(0).setZero();
      m.C.row(0) = Eigen::RowVectorXd::Unit(n, 0);
      m.angles = {0};
    }
    validateModel(m, "random");
    EstimatorSettings kfio;
    kfio.algorithm = Algorithm::KFIO;
    auto e = makeEstimator(m, ekfioSettings());
    auto k_dyn = detail::makeEstimator(m, kfio, detail::SizeChoice::DYNAMIC);
    auto k_auto = makeEstimator(m, kfio);
    EXPECT_EQ(e->algorithm(), Algorithm::EKFIO);
    for (int step = 0; step < 300; ++step)
    {
      Sample s;
      s.y = VectorXd(m.m());
      for (int i = 0; i < m.m(); ++i)
        s.y[i] = 5.0 * rng.normal();
      for (const Sensor& sn : m.sensors)
        if (rng.bernoulli(0.3))
          s.y.segment(sn.offset, sn.size).setConstant(kNaN);
      s.gamma = !rng.bernoulli(0.2);
      if (m.hasControl())
        s.u = VectorXd::Constant(m.p(), rng.normal());
      if (step % 7 == 3)
        s.R = m.R * (1.0 + rng.uniform());
      e->step(s);
      k_dyn->step(s);
      k_auto->step(s);
      ASSERT_LT(relDiff(e->state(), k_dyn->state()), 1e-12) << "trial " << trial << " step " << step;
      ASSERT_LT(relDiff(e->covariance(), k_dyn->covariance()), 1e-12);
      ASSERT_LT(relDiff(e->state(), k_auto->state()), 1e-12);
      ASSERT_LT(relDiff(e->covariance(), k_auto->covariance()), 1e-12);
    }
    ++cases;
  }
  EXPECT_EQ(cases, 24);
}

// Sample::dt is the step's duration (0: the model's period); a bad one is refused before anything
// changes.
TEST(Ekfio, TheStepTakesItsOwnDuration)
{
  const Model m = makeOmniModel(omni2dSpec());
  for (const double dt : {0.0, 0.013, 0.3})
  {
    auto e = makeEstimator(m, ekfioSettings());
    Sample s;
    s.gamma = false;
    s.dt = dt;
    e->step(s);
    const double used = dt > 0.0 ? dt : m.period;
    VectorXd x;
    MatrixXd F;
    propagate(Motion::OMNI_2D, m.x0, used, x, &F);
    x[2] = wrapAngle(x[2]);
    MatrixXd P = F * m.P0 * F.transpose() + used * m.Q;
    EXPECT_LT((e->state() - x).cwiseAbs().maxCoeff(), 1e-15) << dt;
    EXPECT_LT((e->covariance() - P).cwiseAbs().maxCoeff(), 1e-15) << dt;
  }
  auto e = makeEstimator(m, ekfioSettings());
  Sample s;
  s.gamma = false;
  for (const double bad : {-0.01, kNaN, std::numeric_limits<double>::infinity()})
  {
    s.dt = bad;
    EXPECT_THROW(e->step(s), InputError);
    EXPECT_EQ(e->steps(), 0);
    EXPECT_EQ(e->state(), m.x0);
  }
}

/// One run of the simulated robot (the simulator integrates the same motion) under ekfio; returns
/// the NEES e' P^-1 e at the last step (the angles' errors wrapped).
double lastNees(const Model& m, const Model& filter, std::uint64_t seed, long steps, double loss)
{
  PlantSimulator sim(m, seed);
  Rng rng(deriveSeed(seed, 7));
  auto e = makeEstimator(filter, ekfioSettings());
  VectorXd err;
  for (long k = 1; k <= steps; ++k)
  {
    const SimulatedSample& t = sim.step();
    Sample s;
    s.y = t.y;
    for (const Sensor& sn : m.sensors)
      if (rng.bernoulli(loss))
        s.y.segment(sn.offset, sn.size).setConstant(kNaN);
    s.gamma = s.y.array().isFinite().any();
    e->step(s);
    err = t.x - e->state();
    wrapEntries(err, m.angles);
  }
  return err.dot(e->covariance().ldlt().solve(err));
}

// Consistency: over R independent runs the mean of the last step's NEES is n for a filter whose
// covariance is the error's, with standard deviation sqrt(2n / R) (NEES is then chi-square with n
// degrees of freedom). ekfio's covariance is the linearised one; with the noise of these robots (a
// few centimetres and hundredths of a radian) the linearisation error is far below the statistical
// spread, so the band is 4 standard deviations of the mean (a false alarm about once in 16000 for an
// exact filter; the seeds are fixed). A filter that believes a process noise 100 times too small
// lands far above it.
TEST(Ekfio, ConsistentOnTheSimulatedRobot)
{
  const int runs = 200;
  for (const OmniSpec& spec : {omni2dSpec(), omni3dSpec()})
  {
    const Model m = makeOmniModel(spec);
    Model wrong = m;
    wrong.Q *= 0.01;
    const int n = m.n();
    double sum = 0.0, sum_wrong = 0.0;
    for (int r = 0; r < runs; ++r)
    {
      sum += lastNees(m, m, deriveSeed(99, static_cast<std::uint64_t>(r)), 200, 0.3);
      sum_wrong += lastNees(m, wrong, deriveSeed(99, static_cast<std::uint64_t>(r)), 200, 0.3);
    }
    const double mean = sum / runs;
    const double band = 4.0 * std::sqrt(2.0 * n / runs);
    EXPECT_NEAR(mean, n, band) << spec.motion;
    EXPECT_GT(sum_wrong / runs, n + 10.0 * band) << spec.motion;
    RecordProperty(spec.motion + " mean NEES", std::to_string(mean));
    RecordProperty(spec.motion + " mean NEES, Q / 100", std::to_string(sum_wrong / runs));
  }
}

// two_d_mode: omni_3d held on the plane is omni_2d, entry for entry, for sensors of planar states.
TEST(Ekfio, TwoDModeIsTheOmni2dFilter)
{
  OmniSpec s3 = omni3dSpec();
  s3.two_d_mode = true;
  s3.sensors = {{"gps", {"x", "y"}, {0.5}},
                {"imu", {"yaw", "vyaw", "ax", "ay"}, {0.02, 0.01, 0.1, 0.1}},
                {"odom", {"vx", "vy", "vyaw"}, {0.05}}};
  s3.process_noise = {1e-4, 1e-4, 7, 7, 7, 1e-4, 0.01, 0.01, 7, 7, 7, 0.01, 0.1, 0.1, 7};  // 7: held, unused
  s3.x0 = {0, 0, 0, 0, 0, 3.0, 1.0, 0, 0, 0, 0, 0.8, 0, 0, 0};
  const Model m3 = makeOmniModel(s3);
  const Model m2 = makeOmniModel(omni2dSpec());
  auto e3 = makeEstimator(m3, ekfioSettings());
  auto e2 = makeEstimator(m2, ekfioSettings());
  const int map[8] = {0, 1, 5, 6, 7, 11, 12, 13};
  PlantSimulator sim(m2, 3);
  Rng rng(8);
  for (int k = 0; k < 300; ++k)
  {
    const SimulatedSample& t = sim.step();
    Sample s;
    s.y = t.y;
    if (rng.bernoulli(0.3))
      s.y.head(2).setConstant(kNaN);
    s.dt = k % 3 == 0 ? 0.07 : 0.0;
    e2->step(s);
    e3->step(s);
    for (const int held : planarConstrained())
    {
      EXPECT_EQ(e3->state()[held], 0.0);
      EXPECT_TRUE(e3->covariance().row(held).isZero(0.0));
    }
    for (int i = 0; i < 8; ++i)
    {
      EXPECT_NEAR(e3->state()[map[i]], e2->state()[i], 1e-9);
      for (int j = 0; j < 8; ++j)
        EXPECT_NEAR(e3->covariance()(map[i], map[j]), e2->covariance()(i, j), 1e-9);
    }
  }
}

// The simulator integrates the same motion: x_k - f(x_{k-1}, T) is the process noise, N(0, Q T).
// Its normalised square r' (Q T)^-1 r is chi-square with n = 8 degrees of freedom; the mean over
// 4000 independent steps is within 4 sqrt(2 n / 4000) = 0.25 of 8 (the yaw's residual wrapped).
TEST(Ekfio, TheSimulatorIntegratesTheMotion)
{
  const Model m = makeOmniModel(omni2dSpec());
  PlantSimulator sim(m, 12);
  VectorXd prev = sim.state(), f;
  const Eigen::LDLT<MatrixXd> qt(m.Q * m.period);
  double sum = 0.0;
  const int steps = 4000;
  for (int k = 0; k < steps; ++k)
  {
    propagate(Motion::OMNI_2D, prev, m.period, f, nullptr);
    const SimulatedSample& t = sim.step();
    VectorXd r = t.x - f;
    wrapEntries(r, m.angles);
    sum += r.dot(qt.solve(r));
    prev = t.x;
  }
  EXPECT_NEAR(sum / steps, 8.0, 4.0 * std::sqrt(16.0 / steps));
}

// The Estimator's core with ekfio: the rejection thresholds gate on the motion's prior, and late
// data fused by rewinding gives exactly the offline estimate.
TEST(Ekfio, OnlineRewindEqualsOffline)
{
  const Model m = makeOmniModel(omni2dSpec());
  PlantSimulator sim(m, 31);
  std::vector<VectorXd> ys;
  for (int k = 0; k < 300; ++k)
    ys.push_back(sim.step().y);
  auto offline = makeEstimator(m, ekfioSettings());
  std::vector<VectorXd> states;
  for (const VectorXd& y : ys)
  {
    Sample s;
    s.y = y;
    offline->step(s);
    states.push_back(offline->state());
  }
  OnlineOptions o;
  o.late_policy = LatePolicy::REWIND;
  o.history_length = 10;
  o.rejection_threshold = {6.0, 6.0, 6.0};
  OnlineEstimator online(m, ekfioSettings(), o);
  online.start(1);
  for (long k = 1; k <= 300; ++k)
  {
    const VectorXd& y = ys[static_cast<std::size_t>(k - 1)];
    for (std::size_t i = 0; i < m.sensors.size(); ++i)
      if (i != 0 || k % 4 != 0)  // every fourth gps fix comes one step late
        online.offerMeasurement({k, i, y.data() + m.sensors[i].offset, static_cast<std::size_t>(m.sensors[i].size)});
    if ((k - 1) % 4 == 0 && k > 1)
    {
      const VectorXd& late = ys[static_cast<std::size_t>(k - 2)];
      EXPECT_EQ(online.offerMeasurement({k - 1, 0, late.data(), 2}).offer, Offer::LATE_FUSED);
    }
    online.process();
    if (k % 4 != 0)
    {
      EXPECT_LT((online.estimator().state() - states[static_cast<std::size_t>(k - 1)]).cwiseAbs().maxCoeff(), 1e-12)
          << k;
    }
  }
  EXPECT_EQ(online.counters().gated, 0u);
}

// The rejection threshold gates on the motion's prior, ekfio's own prediction (Estimator::predict):
// f(x0, T) and F P0 F' + Q T, checked against that closed form; a heading reading 1 rad off (50 of
// its 0.02 rad sigmas) is refused, the same reading at the predicted heading is fused.
TEST(Ekfio, TheRejectionThresholdGatesOnTheMotionPrior)
{
  const Model m = makeOmniModel(omni2dSpec());
  ASSERT_FALSE(m.two_d_mode);
  auto est = makeEstimator(m, ekfioSettings());
  Sample loss;  // the prior of step 1 (dt 0: the model's period, as the online estimator's)
  loss.gamma = false;
  loss.y = VectorXd::Constant(m.m(), std::numeric_limits<double>::quiet_NaN());
  const Prior& prior = est->predict(loss);
  VectorXd xp;
  MatrixXd F;
  propagate(m.motion, m.x0, m.period, xp, &F);
  const MatrixXd Pp = F * m.P0 * F.transpose() + m.Q * m.period;
  EXPECT_LE((prior.mean() - xp).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + xp.cwiseAbs().maxCoeff()));
  EXPECT_LE((prior.covariance() - Pp).cwiseAbs().maxCoeff(), 1e-12 * Pp.cwiseAbs().maxCoeff());
  OnlineOptions o;
  o.rejection_threshold = {5.0, 5.0, 5.0};
  for (const double offset : {0.0, 1.0})
  {
    OnlineEstimator online(m, ekfioSettings(), o);
    online.start(1);
    const double imu[4] = {wrapAngle(prior.mean()[2] + offset), prior.mean()[5], prior.mean()[6], prior.mean()[7]};
    online.offerMeasurement({1, 1, imu, 4});
    online.process();
    EXPECT_EQ(online.counters().gated, offset > 0.0 ? 1u : 0u) << offset;
    EXPECT_EQ(static_cast<bool>(online.lastArrived()[1]), offset == 0.0) << offset;
  }
}

// The link verdict of a motion is that of its linearisation at a state: A = F there, Q dt, the same
// sensors; analyzeStability examines it like any linear model (a local verdict).
TEST(Ekfio, TheLinearisationIsTheJacobianModel)
{
  for (OmniSpec spec : {omni2dSpec(), omni3dSpec()})
  {
    spec.two_d_mode = false;
    const Model m = makeOmniModel(spec);
    const Model lin = linearisedModel(m, m.x0, 0.1);
    VectorXd next;
    MatrixXd F;
    propagate(m.motion, m.x0, 0.1, next, &F);
    EXPECT_FALSE(lin.nonlinear());
    EXPECT_EQ(lin.A, F);
    EXPECT_EQ(lin.Q, m.Q * 0.1);
    EXPECT_EQ(lin.C, m.C);
    EXPECT_EQ(lin.period, 0.1);
    const StabilityReport rep = analyzeStability(lin, nullptr, nullptr);
    EXPECT_EQ(static_cast<int>(rep.eigenvalues.size()), m.n());
    EXPECT_THROW(linearisedModel(m, VectorXd::Zero(3), 0.1), ConfigError);
    EXPECT_THROW(linearisedModel(m, m.x0, 0.0), ConfigError);
  }
}

// predict_to_current_time's prediction (predictAhead): a linear model over k = round(dt / period)
// whole periods is A applied k times to x and P -> A P A' + B Q B' k times, with zero input
// (computed here by hand from the model's matrices); dt between two grid times goes to the nearest.
// Exact up to rounding: the same products in the same order (tolerance 1e-12 on entries of order 1).
TEST(PredictAhead, ALinearModelIsItsAAppliedKTimes)
{
  Rng rng(57);
  const Model m = test::randomModel(rng, 3, 2, {1}, 0, 1);  // with a control input: not applied
  const double T = 0.05;
  const VectorXd x = VectorXd::LinSpaced(3, 1.0, -2.0);
  MatrixXd P = MatrixXd::Identity(3, 3) * 0.5;
  P(0, 1) = P(1, 0) = 0.1;
  VectorXd want_x = x;
  MatrixXd want_P = P;
  for (int k = 0; k <= 6; ++k)
  {
    for (const double frac : {0.0, 0.3, -0.4})
    {
      if (k == 0 && frac < 0.0)
        continue;
      VectorXd xp;
      MatrixXd Pp;
      const double ahead = predictAhead(m, T, x, P, (k + frac) * T, xp, Pp);
      EXPECT_NEAR(ahead, k * T, 1e-15) << k << " " << frac;
      EXPECT_LT(test::maxAbsDiff(xp, want_x), 1e-12) << k << " " << frac;
      EXPECT_LT(test::maxAbsDiff(Pp, want_P), 1e-12) << k << " " << frac;
    }
    want_x = m.A * want_x;
    want_P = m.A * want_P * m.A.transpose() + m.B * m.Q * m.B.transpose();
  }
  // k = 0: the step's own estimate.
  VectorXd xp;
  MatrixXd Pp;
  EXPECT_EQ(predictAhead(m, T, x, P, 0.0, xp, Pp), 0.0);
  EXPECT_EQ(xp, x);
  EXPECT_EQ(Pp, P);
}

// A built-in motion predicts once over dt (not a whole period: dt = 0 is no prediction at all):
// x -> f(x, dt), P -> F P F' + Q dt with F = df/dx at x (propagate), two_d_mode's constraint after.
TEST(PredictAhead, ABuiltInMotionPredictsOverDt)
{
  OmniSpec planar = omni3dSpec();  // two_d_mode: as in TwoDModeIsTheOmni2dFilter
  planar.two_d_mode = true;
  planar.sensors = {{"gps", {"x", "y"}, {0.5}},
                    {"imu", {"yaw", "vyaw", "ax", "ay"}, {0.02, 0.01, 0.1, 0.1}},
                    {"odom", {"vx", "vy", "vyaw"}, {0.05}}};
  planar.process_noise = {1e-4, 1e-4, 7, 7, 7, 1e-4, 0.01, 0.01, 7, 7, 7, 0.01, 0.1, 0.1, 7};
  planar.x0 = {0, 0, 0, 0, 0, 3.0, 1.0, 0, 0, 0, 0, 0.8, 0, 0, 0};
  for (const OmniSpec& spec : {omni2dSpec(), omni3dSpec(), planar})
  {
    {
      const bool two_d = spec.two_d_mode;
      const Model m = makeOmniModel(spec);
      for (const double dt : {0.013, 0.37, 2.0})
      {
        VectorXd xp, want_x;
        MatrixXd Pp, F;
        EXPECT_EQ(predictAhead(m, 0.05, m.x0, m.P0, dt, xp, Pp), dt);
        propagate(m.motion, m.x0, dt, want_x, &F);
        MatrixXd want_P = F * m.P0 * F.transpose() + m.Q * dt;
        if (two_d)
          for (const int i : planarConstrained())
          {
            want_x[i] = 0.0;
            want_P.row(i).setZero();
            want_P.col(i).setZero();
          }
        EXPECT_LT(test::maxAbsDiff(xp, want_x), 1e-12) << spec.motion << " dt " << dt;
        EXPECT_LT(test::maxAbsDiff(Pp, want_P), 1e-12) << spec.motion << " dt " << dt;
      }
      VectorXd xp;
      MatrixXd Pp;
      EXPECT_EQ(predictAhead(m, 0.05, m.x0, m.P0, 0.0, xp, Pp), 0.0);
      EXPECT_EQ(xp, m.x0);
      EXPECT_EQ(Pp, m.P0);
    }
  }
}

// Bad input is refused naming it: a negative or non-finite dt, a period that is not positive, and
// more whole periods of a linear model than kMaxPredictAheadSteps (k matrix products per call).
TEST(PredictAhead, Refusals)
{
  Rng rng(58);
  const Model lin = test::randomModel(rng, 2, 1, {1}, 0, 0);
  const Model omni = makeOmniModel(omni2dSpec());
  VectorXd xp;
  MatrixXd Pp;
  const VectorXd x = VectorXd::Zero(2);
  const MatrixXd P = MatrixXd::Identity(2, 2);
  auto message = [&](const Model& m, const VectorXd& x0, const MatrixXd& P0, double period, double dt)
  {
    try
    {
      predictAhead(m, period, x0, P0, dt, xp, Pp);
    }
    catch (const InputError& e)
    {
      return std::string(e.what());
    }
    return std::string("<no error>");
  };
  EXPECT_EQ(message(lin, x, P, 0.1, -0.5).rfind("dt: expected a finite time >= 0 s", 0), 0u)
      << message(lin, x, P, 0.1, -0.5);
  EXPECT_EQ(message(omni, omni.x0, omni.P0, 0.1, kNaN).rfind("dt: expected a finite time >= 0 s", 0), 0u);
  EXPECT_EQ(message(lin, x, P, 0.0, 0.5).rfind("period: expected a finite step period > 0 s", 0), 0u);
  const std::string far = message(lin, x, P, 0.1, 0.1 * (kMaxPredictAheadSteps + 1));
  EXPECT_NE(far.find("periods past the step; at most 1000 are predicted"), std::string::npos) << far;
  EXPECT_EQ(message(lin, x, P, 0.1, 0.1 * kMaxPredictAheadSteps), "<no error>");
}

}  // namespace
