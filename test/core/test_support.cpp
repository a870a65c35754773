// Definitions of test_support.hpp, compiled once into the test support library.
#include "test_support.hpp"

namespace networked_estimation
{
namespace test
{

Model scalarTwoSensorModel(double a, const std::string& first, const std::string& second, bool control)
{
  Model m;
  m.name = "two";
  m.A = Eigen::MatrixXd::Constant(1, 1, a);
  m.B = Eigen::MatrixXd::Identity(1, 1);
  m.Q = Eigen::MatrixXd::Identity(1, 1);
  m.C = Eigen::MatrixXd::Ones(2, 1);
  m.R = Eigen::MatrixXd::Identity(2, 2);
  m.sensors = {{first, 0, 1}, {second, 1, 1}};
  m.x0 = Eigen::VectorXd::Zero(1);
  m.P0 = Eigen::MatrixXd::Identity(1, 1);
  m.Bu = control ? Eigen::MatrixXd::Ones(1, 1) : Eigen::MatrixXd(1, 0);
  validateModel(m, "two");
  return m;
}

Eigen::MatrixXd randomMatrix(Rng& rng, int r, int c, double scale)
{
  Eigen::MatrixXd M(r, c);
  for (int i = 0; i < r; ++i)
    for (int j = 0; j < c; ++j)
      M(i, j) = scale * rng.uniform(-1.0, 1.0);
  return M;
}

Eigen::MatrixXd randomSpd(Rng& rng, int n, double lo, double hi)
{
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(randomMatrix(rng, n, n));
  const Eigen::MatrixXd U = qr.householderQ();
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i)
    d[i] = rng.uniform(lo, hi);
  Eigen::MatrixXd S = U * d.asDiagonal() * U.transpose();
  return 0.5 * (S + S.transpose());
}

void singleSensor(Model& m)
{
  m.sensors.clear();
  m.sensors.push_back({"y", 0, static_cast<int>(m.C.rows())});
}

Model zhouModel(double range)
{
  return mc::zhouExampleModel(range);
}

Model aoeModel(double rhoA)
{
  return mc::aoeExampleModel(rhoA);
}

Model randomModel(Rng& rng, int n, int nw, std::vector<int> sensor_sizes, int ne, int p)
{
  Model m;
  m.name = "random";
  m.period = 0.01;
  m.A = randomMatrix(rng, n, n, 0.6);
  m.B = randomMatrix(rng, n, nw);
  m.Q = randomSpd(rng, nw);
  int mtot = 0;
  for (int s : sensor_sizes)
    mtot += s;
  m.C = randomMatrix(rng, mtot, n);
  m.R = Eigen::MatrixXd::Zero(mtot, mtot);
  int off = 0;
  for (std::size_t i = 0; i < sensor_sizes.size(); ++i)
  {
    const int s = sensor_sizes[i];
    m.R.block(off, off, s, s) = randomSpd(rng, s);
    m.sensors.push_back({"s" + std::to_string(i), off, s});
    off += s;
  }
  m.x0 = randomMatrix(rng, n, 1);
  m.P0 = randomSpd(rng, n);
  for (int k = 0; k < ne; ++k)
  {
    Uncertainty u;
    u.dA = randomMatrix(rng, n, n, 0.3);
    u.dB = randomMatrix(rng, n, nw, 0.3);
    u.dC = randomMatrix(rng, mtot, n, 0.3);
    u.range = 0.5;
    m.uncertainty.push_back(u);
  }
  m.Bu = randomMatrix(rng, n, p);
  return m;
}

double maxAbsDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b)
{
  return (a - b).cwiseAbs().maxCoeff();
}

double minEig(const Eigen::MatrixXd& S)
{
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (S + S.transpose())).eigenvalues().minCoeff();
}

}  // namespace test
}  // namespace networked_estimation
