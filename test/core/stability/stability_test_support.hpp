// Models and links for the stability tests: small models built in C++ (Q = I, R = I) and
// per-sensor channel settings.
#pragma once

#include <Eigen/Dense>
#include <initializer_list>
#include <optional>
#include <string>
#include <vector>

#include "networked_estimation/config/channel_settings.hpp"
#include "networked_estimation/config/model.hpp"
#include "networked_estimation/stability/stability.hpp"
#include "test_support.hpp"

namespace networked_estimation
{
namespace test
{

using Eigen::MatrixXd;

inline MatrixXd mat(int r, int c, std::initializer_list<double> v)
{
  MatrixXd M(r, c);
  auto it = v.begin();
  for (int i = 0; i < r; ++i)
    for (int j = 0; j < c; ++j)
      M(i, j) = *it++;
  return M;
}

/// Single-sensor model with Q = I, R = I.
inline Model simpleModel(const MatrixXd& A, const MatrixXd& C)
{
  Model m;
  m.name = "t";
  m.period = 1.0;
  m.A = A;
  m.B = MatrixXd::Identity(A.rows(), A.rows());
  m.Q = MatrixXd::Identity(A.rows(), A.rows());
  m.C = C;
  m.R = MatrixXd::Identity(C.rows(), C.rows());
  m.x0 = Eigen::VectorXd::Zero(A.rows());
  m.P0 = MatrixXd::Identity(A.rows(), A.rows());
  singleSensor(m);
  m.Bu.resize(A.rows(), 0);
  validateModel(m, "t");
  return m;
}

inline MareResult::Status mareAt(const MatrixXd& A, const MatrixXd& C, double lambda)
{
  const Mare mare(A, MatrixXd::Identity(A.rows(), A.rows()), {C}, {lambda});
  MareOptions o;
  o.max_iterations = 200000;
  return solveMare(mare, o).status;
}

inline ChannelSettings bernoulli(double loss)
{
  ChannelSettings c;
  c.model = LossModelKind::BERNOULLI;
  c.loss = loss;
  return c;
}

inline ChannelSettings gilbert(double p, double r, double loss_bad = 1.0, double loss_good = 0.0)
{
  ChannelSettings c;
  c.model = LossModelKind::GILBERT_ELLIOTT;
  c.p = p;
  c.r = r;
  c.loss_bad = loss_bad;
  c.loss_good = loss_good;
  return c;
}

/// Model with one sensor per row block of C (names s1, s2, ...), Q = I, R = I.
inline Model multiModel(const MatrixXd& A, const std::vector<MatrixXd>& Cs)
{
  Model m;
  m.name = "multi";
  m.period = 1.0;
  const int n = static_cast<int>(A.rows());
  int rows = 0;
  for (const MatrixXd& c : Cs)
    rows += static_cast<int>(c.rows());
  m.A = A;
  m.B = MatrixXd::Identity(n, n);
  m.Q = MatrixXd::Identity(n, n);
  m.C.resize(rows, n);
  m.sensors.clear();
  int r0 = 0;
  for (std::size_t i = 0; i < Cs.size(); ++i)
  {
    m.C.middleRows(r0, Cs[i].rows()) = Cs[i];
    m.sensors.push_back({"s" + std::to_string(i + 1), r0, static_cast<int>(Cs[i].rows())});
    r0 += static_cast<int>(Cs[i].rows());
  }
  m.R = MatrixXd::Identity(rows, rows);
  m.x0 = Eigen::VectorXd::Zero(n);
  m.P0 = MatrixXd::Identity(n, n);
  m.Bu.resize(n, 0);
  validateModel(m, "multi");
  return m;
}

/// Per-sensor Bernoulli links at these arrival rates (a negative rate: lossless, no channel).
inline std::vector<std::optional<ChannelSettings>> iidLinks(const std::vector<double>& rates)
{
  std::vector<std::optional<ChannelSettings>> out;
  for (double r : rates)
    out.push_back(r < 0 ? std::nullopt : std::optional<ChannelSettings>(bernoulli(1.0 - r)));
  return out;
}

}  // namespace test
}  // namespace networked_estimation
