// Tests of the plant simulator and the control sequences (simulator.hpp). Models are built by
// hand (no YAML). Statistical tolerances are 5 standard errors derived from the sample size.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "networked_estimation/common/error.hpp"
#include "networked_estimation/channel/loss_model.hpp"
#include "networked_estimation/config/param_reader.hpp"
#include "networked_estimation/simulation/sensor_outputs.hpp"
#include "networked_estimation/simulation/simulator.hpp"

#include <yaml-cpp/yaml.h>
#include "test_support.hpp"

namespace ne = networked_estimation;

namespace
{

Eigen::MatrixXd mat(int rows, int cols, std::initializer_list<double> values)
{
  Eigen::MatrixXd M(rows, cols);
  auto it = values.begin();
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j)
      M(i, j) = *it++;
  return M;
}

/// A stable 2-state model with correlated process noise and two measurement channels.
ne::Model twoStateModel()
{
  ne::Model m;
  m.name = "two_state";
  m.period = 0.01;
  m.A = mat(2, 2, {0.9, 0.1, -0.2, 0.7});
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = mat(2, 2, {2.0, 0.6, 0.6, 1.0});
  m.C = mat(2, 2, {1.0, -1.0, 0.5, 2.0});
  m.R = mat(2, 2, {0.5, -0.1, -0.1, 0.3});
  m.x0 = Eigen::Vector2d(1.0, -2.0);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors = {ne::Sensor{"y", 0, 2}};
  return m;
}

/// Scalar model x_k = a x_{k-1} + w, y_k = c x_k + v with negligible noise, for exact recursions.
ne::Model scalarModel(double a, double c)
{
  ne::Model m;
  m.name = "scalar";
  m.A = mat(1, 1, {a});
  m.B = mat(1, 1, {1.0});
  m.Q = mat(1, 1, {1e-24});
  m.C = mat(1, 1, {c});
  m.R = mat(1, 1, {1e-24});
  m.x0 = Eigen::VectorXd::Constant(1, 1.0);
  m.P0 = Eigen::MatrixXd::Zero(1, 1);
  m.sensors = {ne::Sensor{"y", 0, 1}};
  return m;
}

/// Sample covariance (known zero mean) of the columns of X, and the 5-se check of each entry
/// against S: for zero-mean Gaussians Var(x_i x_j) = S_ii S_jj + S_ij^2, so the se of the mean of
/// N products is sqrt((S_ii S_jj + S_ij^2) / N).
void expectCovariance(const Eigen::MatrixXd& X, const Eigen::MatrixXd& S, const std::string& what)
{
  const double N = static_cast<double>(X.cols());
  const Eigen::MatrixXd emp = X * X.transpose() / N;
  for (int i = 0; i < S.rows(); ++i)
    for (int j = 0; j < S.cols(); ++j)
    {
      const double se = std::sqrt((S(i, i) * S(j, j) + S(i, j) * S(i, j)) / N);
      EXPECT_NEAR(emp(i, j), S(i, j), 5.0 * se) << what << "(" << i << "," << j << ")";
    }
}

std::vector<Eigen::VectorXd> trajectory(ne::PlantSimulator& sim, int steps)
{
  std::vector<Eigen::VectorXd> xs;
  for (int i = 0; i < steps; ++i)
    xs.push_back(sim.step().x);
  return xs;
}

double maxDifference(const std::vector<Eigen::VectorXd>& a, const std::vector<Eigen::VectorXd>& b)
{
  double d = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    d = std::max(d, (a[i] - b[i]).cwiseAbs().maxCoeff());
  return d;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
// ControlSequence

TEST(ControlSequence, Values)
{
  ne::ControlSequence c;
  c.kind = ne::ControlSequence::Kind::CONSTANT;
  c.value = 2.5;
  EXPECT_TRUE(c.at(1, 3).isApprox(Eigen::Vector3d::Constant(2.5)));
  EXPECT_EQ(c.at(7, 0).size(), 0);

  c.kind = ne::ControlSequence::Kind::STEP;
  c.step_at = 10;
  c.value = 1.5;
  EXPECT_EQ(c.at(9, 1)(0), 0.0);
  EXPECT_EQ(c.at(10, 1)(0), 1.5);
  EXPECT_EQ(c.at(11, 2), Eigen::Vector2d(1.5, 1.5));

  c.kind = ne::ControlSequence::Kind::PAPER;
  c.value = 1.0;
  EXPECT_DOUBLE_EQ(c.at(0, 1)(0), 2.0);
  EXPECT_DOUBLE_EQ(c.at(10, 1)(0), 1.0 + std::exp(-1.0));
  c.value = 2.0;
  EXPECT_DOUBLE_EQ(c.at(5, 2)(1), 2.0 * (1.0 + std::exp(-0.5)));
  // Default-constructed: the paper's sequence.
  EXPECT_DOUBLE_EQ(ne::ControlSequence{}.at(20, 1)(0), 1.0 + std::exp(-2.0));
}

TEST(ControlSequence, Parse)
{
  using Kind = ne::ControlSequence::Kind;
  ne::ControlSequence c = ne::ControlSequence::parse("constant:2.5", "control");
  EXPECT_EQ(c.kind, Kind::CONSTANT);
  EXPECT_EQ(c.value, 2.5);

  c = ne::ControlSequence::parse("step:10:1.5", "control");
  EXPECT_EQ(c.kind, Kind::STEP);
  EXPECT_EQ(c.step_at, 10);
  EXPECT_EQ(c.value, 1.5);

  c = ne::ControlSequence::parse("paper", "control");
  EXPECT_EQ(c.kind, Kind::PAPER);
  EXPECT_EQ(c.value, 1.0);

  c = ne::ControlSequence::parse("paper:2", "control");
  EXPECT_EQ(c.kind, Kind::PAPER);
  EXPECT_EQ(c.value, 2.0);

  c = ne::ControlSequence::parse("constant:-1e-3", "control");
  EXPECT_EQ(c.value, -1e-3);
}

TEST(ControlSequence, ParseErrors)
{
  for (const std::string bad :
       {"", "constant", "constant:", "constant:abc", "constant:1:2", "constant:1x", "constant: 1", "constant:inf",
        "constant:nan", "step:10", "step:1.5:2", "step::2", "step:10:nan", "paper:", "paper:1:2", "paper:-inf", "Paper",
        "linear:1", "constant:1e999"})
  {
    try
    {
      ne::ControlSequence::parse(bad, "--control");
      ADD_FAILURE() << "accepted '" << bad << "'";
    }
    catch (const ne::ConfigError& e)
    {
      EXPECT_EQ(std::string(e.what()), "--control: cannot parse control sequence '" + bad +
                                           "' (expected constant:V, step:K:V, paper or paper:V)");
    }
  }
}

// ------------------------------------------------------------------------------------------------
// PlantSimulator: noise structure and reproducibility

TEST(PlantSimulator, NoiseStructureMatchesModel)
{
  const ne::Model m = twoStateModel();
  ne::PlantSimulator sim(m, 2024);
  const int N = 20000;
  Eigen::MatrixXd W(2, N), V(2, N);
  Eigen::VectorXd prev = sim.state();
  for (int i = 0; i < N; ++i)
  {
    const ne::SimulatedSample& s = sim.step();
    ASSERT_EQ(s.k, i + 1);
    ASSERT_EQ(sim.k(), i + 1);
    ASSERT_TRUE(s.nu);
    ASSERT_EQ(s.u.size(), 0);
    ASSERT_TRUE(s.x.isApprox(sim.state()));
    W.col(i) = s.x - m.A * prev;  // = B w with B = I
    V.col(i) = s.v;
    // y = C x + v exactly (up to rounding).
    ASSERT_LT((s.y - m.C * s.x - s.v).cwiseAbs().maxCoeff(), 1e-12);
    prev = s.x;
  }
  expectCovariance(W, m.Q, "w");
  expectCovariance(V, m.R, "v");
  // Whiteness: lag-1 cross products of w have mean 0, se sqrt(Q_ii Q_jj / N).
  const Eigen::MatrixXd lag1 = W.rightCols(N - 1) * W.leftCols(N - 1).transpose() / (N - 1);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(lag1(i, j), 0.0, 5.0 * std::sqrt(m.Q(i, i) * m.Q(j, j) / (N - 1)));
}

TEST(PlantSimulator, ProcessNoiseEntersThroughB)
{
  // n = 2, nw = 1: x_k - A x_{k-1} = B w must be parallel to B = [1, 0.5]', with w ~ N(0, Q).
  ne::Model m = twoStateModel();
  m.B = mat(2, 1, {1.0, 0.5});
  m.Q = mat(1, 1, {3.0});
  ne::PlantSimulator sim(m, 8);
  const int N = 20000;
  Eigen::MatrixXd W(1, N);
  Eigen::VectorXd prev = sim.state();
  for (int i = 0; i < N; ++i)
  {
    const Eigen::VectorXd& x = sim.step().x;
    const Eigen::VectorXd d = x - m.A * prev;
    ASSERT_NEAR(d(1), 0.5 * d(0), 1e-12 * (1.0 + std::abs(d(0))));
    W(0, i) = d(0);
    prev = x;
  }
  expectCovariance(W, m.Q, "w");
}

TEST(PlantSimulator, InitialStateDrawnFromPsdP0)
{
  // Singular P0 = [1 1; 1 1]: x_0 - x0 = z [1, 1]' with z ~ N(0, 1).
  ne::Model m = twoStateModel();
  m.P0 = mat(2, 2, {1.0, 1.0, 1.0, 1.0});
  const int M = 4000;
  double sum = 0.0, sum2 = 0.0;
  for (int s = 0; s < M; ++s)
  {
    ne::PlantSimulator sim(m, static_cast<std::uint64_t>(s));
    const Eigen::VectorXd d = sim.state() - m.x0;
    ASSERT_NEAR(d(0), d(1), 1e-12);
    ASSERT_EQ(sim.k(), 0);
    sum += d(0);
    sum2 += d(0) * d(0);
  }
  // Mean 0 with se 1/sqrt(M); variance 1 with se sqrt(2/M).
  EXPECT_NEAR(sum / M, 0.0, 5.0 / std::sqrt(M));
  EXPECT_NEAR(sum2 / M, 1.0, 5.0 * std::sqrt(2.0 / M));

  // Full P0: the empirical covariance of x_0 - x0 over the seeds matches it.
  m.P0 = mat(2, 2, {2.0, 0.8, 0.8, 0.5});
  Eigen::MatrixXd D(2, M);
  for (int s = 0; s < M; ++s)
    D.col(s) = ne::PlantSimulator(m, static_cast<std::uint64_t>(s) + 100000).state() - m.x0;
  expectCovariance(D, m.P0, "x0");

  // P0 = 0: x_0 = x0 exactly.
  m.P0.setZero();
  ne::PlantSimulator sim(m, 3);
  EXPECT_EQ(sim.state(), m.x0);
}

TEST(PlantSimulator, SameSeedSameTrajectory)
{
  const ne::Model m = twoStateModel();
  ne::PlantSimulator a(m, 77), b(m, 77), c(m, 78);
  std::vector<Eigen::VectorXd> ya, yb, yc;
  for (int i = 0; i < 500; ++i)
  {
    const ne::SimulatedSample& sa = a.step();
    const ne::SimulatedSample& sb = b.step();
    ASSERT_EQ(sa.x, sb.x);
    ASSERT_EQ(sa.y, sb.y);
    ASSERT_EQ(sa.v, sb.v);
    ya.push_back(sa.y);
    yc.push_back(c.step().y);
  }
  EXPECT_GT(maxDifference(ya, yc), 0.1);
}

TEST(PlantSimulator, RejectsBadDimensionsAndIndefiniteNoise)
{
  ne::Model m = twoStateModel();
  m.x0 = Eigen::VectorXd::Zero(3);
  EXPECT_THROW(ne::PlantSimulator(m, 1), ne::ConfigError);
  m = twoStateModel();
  m.Q(0, 0) = -1.0;
  EXPECT_THROW(ne::PlantSimulator(m, 1), ne::ConfigError);
}

// ------------------------------------------------------------------------------------------------
// Control input and actuator link

TEST(PlantSimulator, LostCommandsHaveNoEffect)
{
  ne::Model with = twoStateModel();
  with.Bu = mat(2, 1, {-1.0, 1.0});
  const ne::Model without = twoStateModel();
  ne::ControlSequence control = ne::ControlSequence::parse("constant:3", "test");
  ne::PlantSimulator a(with, 5, control, std::make_unique<ne::BernoulliLoss>(1.0, 9));
  ne::PlantSimulator b(without, 5);
  for (int i = 0; i < 300; ++i)
  {
    const ne::SimulatedSample& sa = a.step();
    const ne::SimulatedSample& sb = b.step();
    ASSERT_FALSE(sa.nu);
    ASSERT_EQ(sa.u, Eigen::VectorXd::Constant(1, 3.0));  // commanded, but never delivered
    ASSERT_EQ(sa.x, sb.x);
    ASSERT_EQ(sa.y, sb.y);
  }
}

TEST(PlantSimulator, DeliveredCommandsFollowDeterministicRecursion)
{
  ne::Model m = twoStateModel();
  m.Bu = mat(2, 2, {-1.0, 0.5, 1.0, 2.0});
  m.Q = 1e-12 * Eigen::MatrixXd::Identity(2, 2);
  m.P0.setZero();
  const ne::ControlSequence control = ne::ControlSequence::parse("paper:2", "test");
  ne::PlantSimulator sim(m, 6, control);  // lossless actuator
  Eigen::VectorXd x = m.x0;
  double worst = 0.0;
  for (long k = 1; k <= 200; ++k)
  {
    const ne::SimulatedSample& s = sim.step();
    ASSERT_TRUE(s.nu);
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(2, 2.0 * (1.0 + std::exp(-k / 10.0)));
    ASSERT_LT((s.u - u).cwiseAbs().maxCoeff(), 1e-15);
    x = m.A * x + m.Bu * u;
    worst = std::max(worst, (s.x - x).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-5);
  // The input actually moved the state (it is not just the zero-input response).
  EXPECT_GT(x.norm(), 1.0);
}

TEST(PlantSimulator, NuFollowsActuatorSequence)
{
  ne::Model m = twoStateModel();
  m.Bu = mat(2, 1, {-1.0, 1.0});
  m.Q = 1e-12 * Eigen::MatrixXd::Identity(2, 2);
  const ne::ControlSequence control = ne::ControlSequence::parse("step:5:2", "test");
  ne::PlantSimulator sim(m, 12, control, std::make_unique<ne::GilbertElliottLoss>(0.2, 0.3, 1.0, 0.0, 31));
  ne::GilbertElliottLoss reference(0.2, 0.3, 1.0, 0.0, 31);
  Eigen::VectorXd prev = sim.state();
  int delivered = 0, lost = 0;
  for (long k = 1; k <= 2000; ++k)
  {
    const ne::SimulatedSample& s = sim.step();
    ASSERT_EQ(s.nu, !reference.nextLost()) << "k = " << k;
    // With negligible process noise, x_k - A x_{k-1} = nu_k Bu u_k.
    const Eigen::VectorXd expected = s.nu ? Eigen::VectorXd(m.Bu * s.u) : Eigen::VectorXd::Zero(2);
    ASSERT_LT((s.x - m.A * prev - expected).cwiseAbs().maxCoeff(), 1e-5) << "k = " << k;
    if (k >= 5)
      (s.nu ? delivered : lost)++;
    prev = s.x;
  }
  EXPECT_GT(delivered, 100);
  EXPECT_GT(lost, 100);
}

// ------------------------------------------------------------------------------------------------
// Parametric uncertainty

TEST(PlantSimulator, ZeroRangeIsNominal)
{
  const ne::Model nominal = twoStateModel();
  ne::Model uncertain = twoStateModel();
  ne::Uncertainty u;
  u.dA = mat(2, 2, {0.0, 0.099, 0.0, 0.0});
  u.dB = mat(2, 2, {0.1, 0.0, 0.0, 0.1});
  u.dC = mat(2, 2, {0.2, 0.0, 0.0, -0.2});
  u.range = 0.0;
  uncertain.uncertainty = {u};
  ne::PlantSimulator a(nominal, 40), b(uncertain, 40);
  std::vector<Eigen::VectorXd> xa, xb, ya, yb;
  for (int i = 0; i < 500; ++i)
  {
    const ne::SimulatedSample& sa = a.step();
    const ne::SimulatedSample& sb = b.step();
    xa.push_back(sa.x);
    ya.push_back(sa.y);
    xb.push_back(sb.x);
    yb.push_back(sb.y);
  }
  EXPECT_EQ(maxDifference(xa, xb), 0.0);
  EXPECT_EQ(maxDifference(ya, yb), 0.0);

  uncertain.uncertainty[0].range = 1.0;
  ne::PlantSimulator c(nominal, 40), d(uncertain, 40);
  const std::vector<Eigen::VectorXd> xc = trajectory(c, 500), xd = trajectory(d, 500);
  EXPECT_GT(maxDifference(xc, xd), 0.1);
}

TEST(PlantSimulator, EpsDrawsAreUniformAndTimedCorrectly)
{
  // x_k = (a + eps_{k-1} da) x_{k-1} + w and y_k = (c + eps_k dc) x_k + v with negligible noise:
  // eps_{k-1} = (x_k / x_{k-1} - a) / da and eps_k = (y_k / x_k - c) / dc.
  const double a = 1.0, da = 0.1, c = 2.0, dc = 0.5, range = 0.5;
  ne::Model m = scalarModel(a, c);
  ne::Uncertainty u;
  u.dA = mat(1, 1, {da});
  u.dC = mat(1, 1, {dc});
  // dB left empty: treated as zero.
  u.range = range;
  m.uncertainty = {u};
  // log|x| random-walks (std ~0.03 per step), so keep the noise far below any |x| reached.
  m.Q(0, 0) = 1e-30;
  m.R(0, 0) = 1e-30;
  ne::PlantSimulator sim(m, 99);
  sim.setStateLimit(std::numeric_limits<double>::infinity());  // noise below rounding on purpose
  const int N = 10000;
  double prev_x = sim.state()(0);
  ASSERT_EQ(prev_x, 1.0);
  double prev_eps_y = std::nan("");
  double sum = 0.0, sum2 = 0.0;
  for (int i = 0; i < N; ++i)
  {
    const ne::SimulatedSample& s = sim.step();
    const double x = s.x(0);
    const double eps_a = (x / prev_x - a) / da;
    const double eps_y = (s.y(0) / x - c) / dc;
    ASSERT_LE(std::abs(eps_a), range + 1e-6);
    ASSERT_LE(std::abs(eps_y), range + 1e-6);
    // The eps of sample k-1 (seen in y_{k-1}) is the one used in the transition to x_k.
    if (i > 0)
    {
      ASSERT_NEAR(eps_a, prev_eps_y, 1e-6) << "k = " << s.k;
    }
    sum += eps_a;
    sum2 += eps_a * eps_a;
    prev_x = x;
    prev_eps_y = eps_y;
  }
  // Uniform[-r, r]: mean 0 with se r / sqrt(3 N); E[eps^2] = r^2 / 3 with
  // Var(eps^2) = r^4 / 5 - r^4 / 9 = 4 r^4 / 45, so se sqrt(4 / 45) r^2 / sqrt(N).
  EXPECT_NEAR(sum / N, 0.0, 5.0 * range / std::sqrt(3.0 * N));
  EXPECT_NEAR(sum2 / N, range * range / 3.0, 5.0 * std::sqrt(4.0 / 45.0) * range * range / std::sqrt(N));
}

// ------------------------------------------------------------------------------------------------
// Rounding floor (simulator.hpp): the state may not outgrow the noise in double precision

namespace
{

/// test/rostest/models/rotation_unstable.yaml: a rotation scaled by rho = 1.2, unit noises, C = [1 0].
ne::Model rotationModel()
{
  ne::Model m;
  m.name = "rotation";
  m.period = 0.01;
  m.A = mat(2, 2, {0.0, -1.2, 1.2, 0.0});
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = Eigen::MatrixXd::Identity(2, 2);
  m.C = mat(1, 2, {1.0, 0.0});
  m.R = mat(1, 1, {1.0});
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors = {ne::Sensor{"y", 0, 1}};
  return m;
}

const double kEps = std::numeric_limits<double>::epsilon();

}  // namespace

TEST(PlantSimulator, UnstablePlantStopsAtTheRoundingFloor)
{
  const ne::Model m = rotationModel();
  ne::PlantSimulator sim(m, 7), applied(m, 7);
  // sigma = min(sqrt(lambda_min(R)) / ||C||_inf, sqrt(lambda_min(B Q B'))) = 1
  EXPECT_NEAR(sim.stateLimit(), 1e-3 / kEps, 1e-9 / kEps);
  long k_thrown = 0;
  std::string message;
  for (long k = 1; k <= 1000 && k_thrown == 0; ++k)
  {
    try
    {
      const ne::SimulatedSample& s = sim.step();
      ASSERT_LE(s.x.lpNorm<Eigen::Infinity>(), sim.stateLimit()) << "k = " << k;
      ASSERT_TRUE(s.y.allFinite()) << "k = " << k;
    }
    catch (const ne::DivergenceError& e)
    {
      k_thrown = k;
      message = e.what();
    }
  }
  // ||x_k|| ~ 1.2^k: the floor 4.5e12 is crossed near k = 155, long before overflow (k ~ 3900).
  ASSERT_GT(k_thrown, 100);
  ASSERT_LT(k_thrown, 200);
  EXPECT_EQ(sim.k(), k_thrown);
  EXPECT_GT(sim.state().lpNorm<Eigen::Infinity>(), sim.stateLimit());
  EXPECT_NE(message.find("model 'rotation'"), std::string::npos) << message;
  EXPECT_NE(message.find("at step k = " + std::to_string(k_thrown) + ","), std::string::npos) << message;
  EXPECT_NE(message.find("||x_k||_inf = "), std::string::npos) << message;
  EXPECT_NE(message.find("beyond the limit 4.5e+12"), std::string::npos) << message;
  EXPECT_NE(message.find("rounding floor"), std::string::npos) << message;

  // stepApplied (the nodelet's path) stops at the same step.
  for (long k = 1; k < k_thrown; ++k)
    ASSERT_NO_THROW(applied.stepApplied(nullptr)) << "k = " << k;
  EXPECT_THROW(applied.stepApplied(nullptr), ne::DivergenceError);
}

TEST(PlantSimulator, StableModelNeverReachesTheRoundingFloor)
{
  // config/models/zhou_example.yaml (as the experiments build it), 10^5 steps.
  const ne::Model m = ne::test::zhouModel(1.0);
  ne::PlantSimulator sim(m, 3);
  double worst = 0.0;
  for (long k = 1; k <= 100000; ++k)
    worst = std::max(worst, sim.step().x.lpNorm<Eigen::Infinity>());
  EXPECT_EQ(sim.k(), 100000);
  EXPECT_LT(worst, 1e-6 * sim.stateLimit());  // stationary: ||x|| of a few tens
}

TEST(PlantSimulator, FloorScalesWithTheSmallestNoiseInStateUnits)
{
  ne::Model m = rotationModel();
  m.C = mat(1, 2, {4.0, -1.0});  // ||C||_inf = 5
  m.R = mat(1, 1, {9.0});        // measurement: 3 / 5
  EXPECT_NEAR(ne::PlantSimulator(m, 1).stateLimit(), 1e-3 * 0.6 / kEps, 1e-9 / kEps);
  m.Q = mat(2, 2, {0.01, 0.0, 0.0, 4.0});  // process noise: sqrt(0.01)
  EXPECT_NEAR(ne::PlantSimulator(m, 1).stateLimit(), 1e-3 * 0.1 / kEps, 1e-9 / kEps);
  // A direction without process noise has none to lose: only the non-zero eigenvalue of B Q B'.
  m.B = mat(2, 1, {0.0, 2.0});
  m.Q = mat(1, 1, {1.0});
  EXPECT_NEAR(ne::PlantSimulator(m, 1).stateLimit(), 1e-3 * 0.6 / kEps, 1e-9 / kEps);
  // The uncertain output gain counts with its range: ||C(eps)||_inf <= 5 + 2 * 0.5.
  ne::Uncertainty u;
  u.dC = mat(1, 2, {0.0, 0.5});
  u.range = 2.0;
  m.uncertainty = {u};
  EXPECT_NEAR(ne::PlantSimulator(m, 1).stateLimit(), 1e-3 * 0.5 / kEps, 1e-9 / kEps);
}

TEST(PlantSimulator, NonFiniteStateIsRefusedWhateverTheLimit)
{
  ne::Model m = scalarModel(1e300, 1.0);
  m.Q(0, 0) = 1.0;
  m.R(0, 0) = 1.0;
  ne::PlantSimulator sim(m, 2);
  sim.setStateLimit(std::numeric_limits<double>::infinity());
  ASSERT_NO_THROW(sim.step());  // x_1 = 1e300
  try
  {
    sim.step();  // x_2 = inf
    FAIL() << "no DivergenceError";
  }
  catch (const ne::DivergenceError& e)
  {
    const std::string message = e.what();
    EXPECT_NE(message.find("model 'scalar' is no longer finite at step k = 2"), std::string::npos) << message;
  }
}

namespace
{

/// parseSimulatorOutputs on a YAML text, for a model of sensors odom (2 rows), imu (1), gps (2) at 50 Hz.
networked_estimation::SimulatorOutputs outputsOf(const std::string& yaml)
{
  using namespace networked_estimation;
  Model m;
  m.name = "robot";
  m.period = 0.02;
  m.A = Eigen::MatrixXd::Identity(3, 3);
  m.B = m.Q = Eigen::MatrixXd::Identity(3, 3);
  m.C = Eigen::MatrixXd::Zero(5, 3);
  m.C(0, 0) = m.C(1, 1) = m.C(2, 2) = m.C(3, 0) = m.C(4, 1) = 1.0;
  m.R = Eigen::MatrixXd::Identity(5, 5);
  m.x0 = Eigen::VectorXd::Zero(3);
  m.P0 = Eigen::MatrixXd::Identity(3, 3);
  m.sensors = {{"odom", 0, 2}, {"imu", 2, 1}, {"gps", 3, 2}};
  m.Bu.resize(3, 0);
  validateModel(m, "robot");
  ParamReader p(YAML::Load(yaml), "plant");
  SimulatorOutputs o = parseSimulatorOutputs(p, m, 0.02, "plant");
  p.rejectUnknown();
  return o;
}

void expectOutputsError(const std::string& yaml, const std::string& text)
{
  try
  {
    outputsOf(yaml);
    ADD_FAILURE() << "no ConfigError for " << yaml;
  }
  catch (const networked_estimation::ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what() << "\n lacks: " << text;
  }
}

}  // namespace

// The PlantSimulator's per-sensor outputs: standard types with fields, rates as whole numbers of
// steps, covariance scales, and every bad setting refused naming its key.
TEST(SimulatorOutputs, TypesRatesAndScales)
{
  using namespace networked_estimation;
  const SimulatorOutputs none = outputsOf("{}");
  ASSERT_EQ(none.sensors.size(), 3u);
  EXPECT_EQ(none.sensors[1].format.type, InputType::MEASUREMENT);
  EXPECT_EQ(none.sensors[1].format.topic, "measurement/imu");
  EXPECT_TRUE(none.sensors[1].dueAt(1) && none.sensors[1].dueAt(2));
  const SimulatorOutputs o = outputsOf(R"({datum: [48.1, 11.5, 500], sensors: {
      imu: {topic: /imu, type: sensor_msgs/Imu, fields: [orientation.yaw], rate: 10},
      gps: {topic: /fix, type: sensor_msgs/NavSatFix, fields: [east, north], rate: 2, covariance_scales: [1, 4],
            frame_id: antenna}}})");
  EXPECT_EQ(o.sensors[1].format.type, InputType::IMU);
  EXPECT_EQ(o.sensors[1].every, 5);
  EXPECT_TRUE(o.sensors[1].dueAt(1));
  EXPECT_FALSE(o.sensors[1].dueAt(5));
  EXPECT_TRUE(o.sensors[1].dueAt(6));
  EXPECT_EQ(o.sensors[2].every, 25);
  EXPECT_EQ(o.sensors[2].frame_id, "antenna");
  EXPECT_EQ(o.sensors[2].scaleOf(0), 1.0);
  EXPECT_EQ(o.sensors[2].scaleOf(3), 4.0);
  EXPECT_EQ(o.datum, (std::vector<double>{48.1, 11.5, 500}));

  expectOutputsError("{sensors: {lidar: {type: sensor_msgs/Range, fields: [range]}}}",
                     "plant: sensors.lidar: 'lidar' is not a sensor of the model (sensors: odom, imu, gps)");
  expectOutputsError("{sensors: {imu: {type: std_msgs/Float64, fields: [data]}}}", "plant: sensors.imu.type");
  expectOutputsError("{sensors: {imu: {type: sensor_msgs/Imu, fields: [orientation.yew]}}}",
                     "'orientation.yew' is not a field of sensor_msgs/Imu");
  expectOutputsError("{sensors: {odom: {type: nav_msgs/Odometry, fields: [pose.pose.position.x]}}}",
                     "sensors.odom.fields: expected 2 fields");
  expectOutputsError("{sensors: {imu: {type: sensor_msgs/Imu, fields: [orientation.yaw], rate: 15}}}",
                     "sensors.imu.rate: expected the model's rate 50");
  expectOutputsError("{sensors: {imu: {type: sensor_msgs/Imu, fields: [orientation.yaw], rate: 0}}}",
                     "sensors.imu.rate");
  expectOutputsError("{sensors: {imu: {type: sensor_msgs/Imu, fields: [orientation.yaw], rate: 100}}}",
                     "sensors.imu.rate");
  expectOutputsError("{sensors: {imu: {type: sensor_msgs/Imu, fields: [orientation.yaw], covariance_scales: [1, 0]}}}",
                     "sensors.imu.covariance_scales[1]: expected a finite number > 0, found 0");
  expectOutputsError("{sensors: {imu: {type: sensor_msgs/Imu, fields: [orientation.yaw], colour: red}}}", "colour");
  expectOutputsError("{sensors: {gps: {type: sensor_msgs/NavSatFix, fields: [east, north]}}}",
                     "plant: sensors.gps: sensor_msgs/NavSatFix needs a datum");
  expectOutputsError("{datum: [95, 0, 0]}",
                     "plant: datum[0] (latitude): expected a finite number of degrees in [-90, 90], found 95");
}
