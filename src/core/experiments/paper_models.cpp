// The papers' example models (paper_models.hpp).
#include "experiments/paper_models.hpp"

namespace networked_estimation
{
namespace mc
{

Model zhouExampleModel(double delta)
{
  Model m;
  m.name = "zhou_example";
  m.period = 0.01;
  m.A.resize(2, 2);
  m.A << 0.9802, 0.0196, 0.0, 0.9802;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q.resize(2, 2);
  m.Q << 1.9608, 0.0195, 0.0195, 1.9605;
  m.C.resize(1, 2);
  m.C << 1, -1;
  m.R = Eigen::MatrixXd::Identity(1, 1);
  m.x0 = Eigen::Vector2d(1, 0);
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors.push_back({"y", 0, 1});
  Uncertainty u;
  u.dA = Eigen::MatrixXd::Zero(2, 2);
  u.dA(0, 1) = 0.099;
  u.dB = Eigen::MatrixXd::Zero(2, 2);
  u.dC = Eigen::MatrixXd::Zero(1, 2);
  u.range = delta;
  m.uncertainty.push_back(u);
  m.Bu.resize(2, 0);
  validateModel(m, "zhou_example");
  return m;
}

Model aoeExampleModel(double rhoA)
{
  Model m;
  m.name = "aoe_example";
  m.period = 0.01;
  m.A.resize(2, 2);
  m.A << rhoA, 0, 0, 1.005;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q = 20.0 * Eigen::MatrixXd::Identity(2, 2);
  m.C.resize(2, 2);
  m.C << 1, -1, 0, 1;
  m.R = 20.0 * Eigen::MatrixXd::Identity(2, 2);
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.sensors.push_back({"y", 0, 2});
  m.Bu.resize(2, 1);
  m.Bu << -1, 1;
  validateModel(m, "aoe_example");
  return m;
}

const std::vector<double>& yangRates()
{
  static const std::vector<double> rates = {0.2443, 0.4572, 0.7435, 0.6174, 0.1747, 0.6024, 0.8031, 0.3663};
  return rates;
}

Model yangExampleModel()
{
  Model m;
  m.name = "yang_example1";
  m.period = 1.0;
  m.A.resize(2, 2);
  m.A << -0.82, 0.53, 0.34, 0.78;
  m.B = Eigen::MatrixXd::Identity(2, 2);
  m.Q.resize(2, 2);
  m.Q << 0.53, 0.21, 0.21, 0.50;
  const std::vector<std::vector<double>> H = {
      {-0.69, 0.67},           {1.18, -0.36, 0.70, -0.38}, {-1.58, 1.43},           {-1.71, -2.12},
      {-0.65, 0.49, -2.01, 0.46}, {1.79, 2.2, 0.59, 0.31},     {1.28, 2.07, -1.00, -0.92}, {0.18, 0.21, 2.04, 0.91},
  };
  int rows = 0;
  for (const auto& h : H)
    rows += static_cast<int>(h.size()) / 2;
  m.C.resize(rows, 2);
  int off = 0;
  for (std::size_t i = 0; i < H.size(); ++i)
  {
    const int p = static_cast<int>(H[i].size()) / 2;
    for (int r = 0; r < p; ++r)
    {
      m.C(off + r, 0) = H[i][2 * r];
      m.C(off + r, 1) = H[i][2 * r + 1];
    }
    m.sensors.push_back({"s" + std::to_string(i + 1), off, p});
    off += p;
  }
  m.R = Eigen::MatrixXd::Identity(rows, rows);
  m.x0 = Eigen::Vector2d::Zero();
  m.P0 = Eigen::MatrixXd::Identity(2, 2);
  m.Bu.resize(2, 0);
  validateModel(m, "yang_example1");
  return m;
}

}  // namespace mc

}  // namespace networked_estimation
