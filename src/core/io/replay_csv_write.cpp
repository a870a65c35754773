// Writing the replay input, replay output and truth CSV files (replay_csv.hpp): numbers with %.17g,
// which reads back to the same double.
#include <cmath>
#include <cstdio>
#include <ostream>

#include "networked_estimation/io/replay_csv.hpp"

namespace networked_estimation
{

namespace
{

void writeNumber(std::ostream& os, double value)
{
  char buf[40];
  const int len = std::snprintf(buf, sizeof buf, "%.17g", value);
  os.write(buf, len);
}

}  // namespace

std::vector<std::string> replayRColumns(const Model& model)
{
  std::vector<std::string> names;
  for (const Sensor& s : model.sensors)
    for (int a = s.offset; a < s.offset + s.size; ++a)
      for (int b = a; b < s.offset + s.size; ++b)
        names.push_back("r" + std::to_string(a + 1) + "_" + std::to_string(b + 1));
  return names;
}

void writeReplayRowR(std::ostream& os, const Model& model, const Eigen::MatrixXd& R, const std::vector<bool>& given)
{
  for (std::size_t si = 0; si < model.sensors.size(); ++si)
  {
    const Sensor& s = model.sensors[si];
    for (int a = s.offset; a < s.offset + s.size; ++a)
      for (int b = a; b < s.offset + s.size; ++b)
      {
        os << ',';
        if (R.size() > 0 && si < given.size() && given[si])
          writeNumber(os, R(a, b));
      }
  }
}

std::string formatDouble(double value)
{
  char buf[40];
  const int len = std::snprintf(buf, sizeof buf, "%.17g", value);
  return std::string(buf, static_cast<std::size_t>(len));
}

void writeReplayInputHeader(std::ostream& os, int m, int p, bool with_nu, const std::vector<std::string>& r_columns)
{
  os << "k,gamma";
  for (int i = 1; i <= m; ++i)
    os << ",y" << i;
  for (int j = 1; j <= p; ++j)
    os << ",u" << j;
  if (with_nu)
    os << ",nu";
  for (const std::string& r : r_columns)
    os << ',' << r;
  os << '\n';
}

void writeReplayInputRow(std::ostream& os, long k, bool gamma, const Eigen::VectorXd& y, const Eigen::VectorXd& u,
                         bool with_nu, int nu, const std::vector<bool>* off, const std::string& tail)
{
  os << k << ',' << (gamma ? '1' : '0');
  for (Eigen::Index i = 0; i < y.size(); ++i)
  {
    os << ',';
    if (off && (*off)[static_cast<std::size_t>(i)])
      os << '-';
    else if (!std::isnan(y[i]))
      writeNumber(os, y[i]);
  }
  for (Eigen::Index j = 0; j < u.size(); ++j)
  {
    os << ',';
    writeNumber(os, u[j]);
  }
  if (with_nu)
    os << ',' << nu;
  os << tail << '\n';
}

void writeReplayOutputHeader(std::ostream& os, int n)
{
  os << "k,gamma";
  for (int i = 1; i <= n; ++i)
    os << ",x" << i;
  for (int i = 1; i <= n; ++i)
    for (int j = 1; j <= n; ++j)
      os << ",P" << i << j;
  os << ",trace\n";
}

void writeReplayOutputRow(std::ostream& os, long k, bool gamma, const Eigen::VectorXd& x, const Eigen::MatrixXd& P)
{
  os << k << ',' << (gamma ? '1' : '0');
  for (Eigen::Index i = 0; i < x.size(); ++i)
  {
    os << ',';
    writeNumber(os, x[i]);
  }
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    for (Eigen::Index j = 0; j < P.cols(); ++j)
    {
      os << ',';
      writeNumber(os, P(i, j));
    }
  os << ',';
  writeNumber(os, P.trace());
  os << '\n';
}

void writeTruthHeader(std::ostream& os, int n)
{
  os << "k";
  for (int i = 1; i <= n; ++i)
    os << ",x" << i;
  os << ",nu\n";
}

void writeTruthRow(std::ostream& os, long k, const Eigen::VectorXd& x, bool nu)
{
  os << k;
  for (Eigen::Index i = 0; i < x.size(); ++i)
  {
    os << ',';
    writeNumber(os, x[i]);
  }
  os << ',' << (nu ? '1' : '0') << '\n';
}

}  // namespace networked_estimation
