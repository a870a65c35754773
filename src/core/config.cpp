// Reading and validating the model file, the estimator settings and the channel settings
// (formats.md "Model file", "Estimator settings", "Channel settings").
//
// Every rejection is a ConfigError shaped "<source>:<line>: <key>: <problem>" (the line is omitted
// when unknown), where <key> is the full key path (e.g. "sensors[1].R", "control_link.failure").
#include "networked_estimation/error.hpp"
#include "networked_estimation/model.hpp"
#include "networked_estimation/settings.hpp"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

namespace networked_estimation
{
namespace
{

// ---------------------------------------------------------------------------------------------
// Formatting
// ---------------------------------------------------------------------------------------------

/// Shortest decimal text that reads back as exactly `v` (at most `max_digits` significant digits).
std::string formatNumber(double v, int max_digits = 17)
{
  if (std::isnan(v))
  {
    return "nan";
  }
  if (std::isinf(v))
  {
    return v > 0 ? "inf" : "-inf";
  }
  char buf[64];
  for (int digits = 1; digits <= max_digits; ++digits)
  {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, v);
    if (digits == max_digits || std::strtod(buf, nullptr) == v)
    {
      break;
    }
  }
  return buf;
}

std::string dims(Eigen::Index rows, Eigen::Index cols)
{
  return std::to_string(rows) + "x" + std::to_string(cols);
}

std::string joinList(const std::vector<std::string>& items)
{
  std::string out;
  for (std::size_t i = 0; i < items.size(); ++i)
  {
    out += (i == 0 ? "" : ", ") + items[i];
  }
  return out;
}

/// Key path of a child: "a" + "b" -> "a.b"; "" + "b" -> "b".
std::string childKey(const std::string& prefix, const std::string& key)
{
  return prefix.empty() ? key : prefix + "." + key;
}

std::string indexKey(const std::string& prefix, std::size_t i)
{
  return prefix + "[" + std::to_string(i) + "]";
}

/// What a node holds, for "found ..." in messages.
std::string describe(const YAML::Node& node)
{
  if (!node.IsDefined())
  {
    return "nothing";
  }
  switch (node.Type())
  {
    case YAML::NodeType::Null:
      return "null";
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list";
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

/// "<source>:<line>: <key>: <problem>", or without ":<line>" when line <= 0, without "<key>: "
/// when key is empty.
std::string message(const std::string& source, int line, const std::string& key,
                    const std::string& problem)
{
  std::string out = source;
  if (line > 0)
  {
    out += ":" + std::to_string(line);
  }
  out += ": ";
  if (!key.empty())
  {
    out += key + ": ";
  }
  return out + problem;
}

int lineOf(const YAML::Node& node)
{
  if (!node.IsDefined())
  {
    return 0;
  }
  const YAML::Mark mark = node.Mark();
  return mark.line >= 0 ? mark.line + 1 : 0;
}

// ---------------------------------------------------------------------------------------------
// Checks on matrices, shared by parseModel (with line numbers) and validateModel (without).
// Each returns the problem text, or "" when the matrix is fine.
// ---------------------------------------------------------------------------------------------

std::string finitenessProblem(const Eigen::MatrixXd& M, const std::string& label)
{
  for (Eigen::Index i = 0; i < M.rows(); ++i)
  {
    for (Eigen::Index j = 0; j < M.cols(); ++j)
    {
      if (!std::isfinite(M(i, j)))
      {
        return "not finite (" + label + "(" + std::to_string(i) + "," + std::to_string(j) +
               ") = " + formatNumber(M(i, j)) + ")";
      }
    }
  }
  return "";
}

/// Relative tolerance 1e-9 * (largest absolute entry).
std::string symmetryProblem(const Eigen::MatrixXd& M, const std::string& label)
{
  const double tol = 1e-9 * (M.size() > 0 ? M.cwiseAbs().maxCoeff() : 0.0);
  for (Eigen::Index i = 0; i < M.rows(); ++i)
  {
    for (Eigen::Index j = i + 1; j < M.cols(); ++j)
    {
      if (std::abs(M(i, j) - M(j, i)) > tol)
      {
        const std::string a = label + "(" + std::to_string(i) + "," + std::to_string(j) + ")";
        const std::string b = label + "(" + std::to_string(j) + "," + std::to_string(i) + ")";
        return "not symmetric (" + a + " = " + formatNumber(M(i, j)) + " but " + b + " = " +
               formatNumber(M(j, i)) + ")";
      }
    }
  }
  return "";
}

/// For a square, finite, symmetric M. strict: positive definite (smallest eigenvalue
/// > 1e-12 * largest absolute one); otherwise positive semidefinite (>= -1e-12 * largest).
std::string definitenessProblem(const Eigen::MatrixXd& M, bool strict)
{
  const Eigen::MatrixXd S = 0.5 * (M + M.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(S, Eigen::EigenvaluesOnly);
  if (solver.info() != Eigen::Success)
  {
    return "eigenvalues could not be computed";
  }
  const Eigen::VectorXd& ev = solver.eigenvalues();  // ascending
  const double smallest = ev(0);
  const double scale = ev.cwiseAbs().maxCoeff();
  if (strict)
  {
    if (smallest > 1e-12 * scale)
    {
      return "";
    }
    std::string out = "not positive definite (smallest eigenvalue " + formatNumber(smallest, 6);
    if (smallest >= 0.0)
    {
      out += ", largest " + formatNumber(ev(ev.size() - 1), 6);
    }
    return out + ")";
  }
  if (smallest >= -1e-12 * scale)
  {
    return "";
  }
  return "not positive semidefinite (smallest eigenvalue " + formatNumber(smallest, 6) + ")";
}

// ---------------------------------------------------------------------------------------------
// Reader: typed access to YAML nodes, throwing ConfigError with source, line and key path.
// ---------------------------------------------------------------------------------------------

/// Expected size in a message: a free dimension (< 0) takes the found value.
std::string expectedDims(int rows, int cols, Eigen::Index found_rows, Eigen::Index found_cols)
{
  return dims(rows >= 0 ? rows : found_rows, cols >= 0 ? cols : found_cols);
}

class Reader
{
 public:
  explicit Reader(const std::string& source) : source_(source) {}

  const std::string& source() const { return source_; }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key,
                         const std::string& problem) const
  {
    throw ConfigError(message(source_, lineOf(at), key, problem));
  }

  /// The document root must be a map.
  void requireTopMap(const YAML::Node& node) const
  {
    if (!node.IsDefined() || node.IsNull())
    {
      fail(node, "", "empty document (expected a map of keys)");
    }
    if (!node.IsMap())
    {
      fail(node, "", "expected a map of keys at the top level, found " + describe(node));
    }
  }

  /// A nested value that must be a map.
  void requireMap(const YAML::Node& node, const std::string& key) const
  {
    if (!node.IsMap())
    {
      fail(node, key, "expected a map, found " + describe(node));
    }
  }

  /// Rejects non-scalar, duplicate and unknown keys of `map` (whose own key path is `prefix`).
  void checkKeys(const YAML::Node& map, const std::string& prefix,
                 const std::vector<std::string>& known) const
  {
    std::set<std::string> seen;
    for (auto it = map.begin(); it != map.end(); ++it)
    {
      const YAML::Node key_node = it->first;
      if (!key_node.IsScalar())
      {
        fail(key_node, prefix, "keys must be plain names, found " + describe(key_node));
      }
      const std::string name = key_node.Scalar();
      const std::string path = childKey(prefix, name);
      if (std::find(known.begin(), known.end(), name) == known.end())
      {
        fail(key_node, path, "unknown key (known keys: " + joinList(known) + ")");
      }
      if (!seen.insert(name).second)
      {
        fail(key_node, path, "duplicate key");
      }
    }
  }

  /// Child `key` of `map`; throws "missing required key" (with `why` appended) when absent.
  YAML::Node require(const YAML::Node& map, const std::string& prefix, const std::string& key,
                     const std::string& why = "") const
  {
    const YAML::Node child = map[key];
    if (!child.IsDefined())
    {
      fail(map, childKey(prefix, key),
           "missing required key" + (why.empty() ? "" : " (" + why + ")"));
    }
    return child;
  }

  /// Any number, including .nan / .inf (no finiteness check).
  double rawNumber(const YAML::Node& node, const std::string& key) const
  {
    if (!node.IsScalar())
    {
      fail(node, key, "expected a number, found " + describe(node));
    }
    double value = 0.0;
    if (YAML::convert<double>::decode(node, value))
    {
      return value;
    }
    // The stream conversion fails on overflow: tell that apart from text.
    const std::string& text = node.Scalar();
    char* end = nullptr;
    errno = 0;
    std::strtod(text.c_str(), &end);
    if (!text.empty() && end == text.c_str() + text.size() && errno == ERANGE)
    {
      fail(node, key, "number out of range, found '" + text + "'");
    }
    fail(node, key, "expected a number, found '" + text + "'");
  }

  /// A finite number.
  double number(const YAML::Node& node, const std::string& key) const
  {
    const double value = rawNumber(node, key);
    if (!std::isfinite(value))
    {
      fail(node, key, "expected a finite number, found '" + node.Scalar() + "'");
    }
    return value;
  }

  double probability(const YAML::Node& node, const std::string& key) const
  {
    const double value = number(node, key);
    if (!(value >= 0.0 && value <= 1.0))
    {
      fail(node, key, "expected a probability in [0, 1], found " + node.Scalar());
    }
    return value;
  }

  double nonNegative(const YAML::Node& node, const std::string& key, const std::string& what) const
  {
    const double value = number(node, key);
    if (!(value >= 0.0))
    {
      fail(node, key, "expected a non-negative " + what + ", found " + node.Scalar());
    }
    return value;
  }

  /// A decimal integer in [min, 2^64 - 1].
  std::uint64_t integer(const YAML::Node& node, const std::string& key, std::uint64_t min) const
  {
    const std::string expected =
        min == 0 ? "a non-negative integer" : "an integer >= " + std::to_string(min);
    if (!node.IsScalar())
    {
      fail(node, key, "expected " + expected + ", found " + describe(node));
    }
    std::string text = node.Scalar();
    const bool digits_only = !text.empty() &&
                             std::all_of(text.begin() + (text[0] == '+' ? 1 : 0), text.end(),
                                         [](char c)
                                         {
                                           return c >= '0' && c <= '9';
                                         }) &&
                             text != "+";
    if (!digits_only)
    {
      double value = 0.0;
      if (YAML::convert<double>::decode(node, value) && std::isfinite(value) &&
          value == std::floor(value))
      {
        fail(node, key, "expected " + expected + ", found " + text);  // e.g. -3
      }
      fail(node, key, "expected " + expected + ", found '" + text + "'");  // e.g. 2.5, abc
    }
    errno = 0;
    const unsigned long long value = std::strtoull(text.c_str(), nullptr, 10);
    if (errno == ERANGE)
    {
      fail(node, key,
           "integer out of range (at most " +
               std::to_string(std::numeric_limits<std::uint64_t>::max()) + "), found " + text);
    }
    if (value < min)
    {
      fail(node, key, "expected " + expected + ", found " + text);
    }
    return static_cast<std::uint64_t>(value);
  }

  /// true or false (also True/TRUE/False/FALSE, YAML 1.2); not yes/no/on/off/1/0.
  bool boolean(const YAML::Node& node, const std::string& key) const
  {
    if (node.IsScalar())
    {
      const std::string& t = node.Scalar();
      if (t == "true" || t == "True" || t == "TRUE")
      {
        return true;
      }
      if (t == "false" || t == "False" || t == "FALSE")
      {
        return false;
      }
    }
    fail(node, key, "expected true or false, found " + describe(node));
  }

  std::string string(const YAML::Node& node, const std::string& key) const
  {
    if (!node.IsScalar())
    {
      fail(node, key, "expected a string, found " + describe(node));
    }
    return node.Scalar();
  }

  /// One of `names`; returns its index.
  std::size_t choice(const YAML::Node& node, const std::string& key, const std::string& what,
                     const std::vector<std::string>& names) const
  {
    const std::string value = string(node, key);
    const auto it = std::find(names.begin(), names.end(), value);
    if (it == names.end())
    {
      fail(node, key,
           "unknown " + what + " '" + value + "' (expected one of: " + joinList(names) + ")");
    }
    return static_cast<std::size_t>(it - names.begin());
  }

  /// A non-empty matrix written as a list of rows of finite numbers. rows / cols < 0 leave that
  /// dimension free; `hint` explains the expected size, e.g. "n = 2 columns".
  Eigen::MatrixXd matrix(const YAML::Node& node, const std::string& key, int rows, int cols,
                         const std::string& hint) const
  {
    if (!node.IsSequence())
    {
      fail(node, key, "expected a matrix (list of rows), found " + describe(node));
    }
    if (node.size() == 0)
    {
      fail(node, key,
           "empty matrix (expected a non-empty list of rows" + (hint.empty() ? "" : ", " + hint) +
               ")");
    }
    const std::size_t found_rows = node.size();
    std::size_t found_cols = 0;
    for (std::size_t i = 0; i < found_rows; ++i)
    {
      const YAML::Node row = node[i];
      if (!row.IsSequence())
      {
        fail(row, key,
             "row " + std::to_string(i) + ": expected a list of numbers, found " + describe(row));
      }
      if (row.size() == 0)
      {
        fail(row, key, "row " + std::to_string(i) + " is empty");
      }
      if (i == 0)
      {
        found_cols = row.size();
      }
      else if (row.size() != found_cols)
      {
        fail(row, key,
             "ragged rows (row 0 has " + std::to_string(found_cols) + " entries, row " +
                 std::to_string(i) + " has " + std::to_string(row.size()) + ")");
      }
    }
    Eigen::MatrixXd M(found_rows, found_cols);
    for (std::size_t i = 0; i < found_rows; ++i)
    {
      const YAML::Node row = node[i];
      for (std::size_t j = 0; j < found_cols; ++j)
      {
        M(i, j) = entry(row[j], key, "entry (" + std::to_string(i) + "," + std::to_string(j) + ")");
      }
    }
    const auto r = static_cast<Eigen::Index>(found_rows);
    const auto c = static_cast<Eigen::Index>(found_cols);
    if ((rows >= 0 && r != rows) || (cols >= 0 && c != cols))
    {
      fail(node, key,
           "expected " + expectedDims(rows, cols, r, c) + (hint.empty() ? "" : " (" + hint + ")") +
               ", found " + dims(r, c));
    }
    return M;
  }

  /// A flat list of exactly `size` finite numbers.
  Eigen::VectorXd vector(const YAML::Node& node, const std::string& key, int size,
                         const std::string& hint) const
  {
    if (!node.IsSequence())
    {
      fail(node, key, "expected a list of numbers, found " + describe(node));
    }
    if (static_cast<int>(node.size()) != size)
    {
      fail(node, key,
           "expected " + std::to_string(size) + " entries" +
               (hint.empty() ? "" : " (" + hint + ")") + ", found " + std::to_string(node.size()));
    }
    Eigen::VectorXd v(size);
    for (int i = 0; i < size; ++i)
    {
      v(i) = entry(node[i], key, "entry " + std::to_string(i));
    }
    return v;
  }

 private:
  /// One finite matrix / vector entry; `where` is e.g. "entry (0,1)".
  double entry(const YAML::Node& node, const std::string& key, const std::string& where) const
  {
    if (!node.IsScalar())
    {
      fail(node, key, where + ": expected a number, found " + describe(node));
    }
    double value = 0.0;
    if (!YAML::convert<double>::decode(node, value))
    {
      fail(node, key, where + ": expected a number, found '" + node.Scalar() + "'");
    }
    if (!std::isfinite(value))
    {
      fail(node, key, where + ": not finite (found " + node.Scalar() + ")");
    }
    return value;
  }

  std::string source_;
};

/// Checks symmetry and definiteness of a parsed matrix, failing at `node`.
void checkCovariance(const Reader& in, const YAML::Node& node, const std::string& key,
                     const std::string& label, const Eigen::MatrixXd& M, bool strict)
{
  std::string problem = symmetryProblem(M, label);
  if (problem.empty())
  {
    problem = definitenessProblem(M, strict);
  }
  if (!problem.empty())
  {
    in.fail(node, key, problem);
  }
}

std::string countText(const char* what, int value)
{
  return std::string(what) + " = " + std::to_string(value);
}

/// Reads a file into a YAML document, turning I/O and syntax errors into ConfigError.
YAML::Node loadYamlFile(const std::string& path)
{
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
  {
    throw ConfigError(path + ": cannot open file (it is a directory)");
  }
  std::ifstream file(path);
  if (!file)
  {
    throw ConfigError(path + ": cannot open file");
  }
  try
  {
    return YAML::Load(file);
  }
  catch (const YAML::ParserException& e)
  {
    const int line = e.mark.line >= 0 ? e.mark.line + 1 : 0;
    throw ConfigError(message(path, line, "", "YAML syntax error: " + e.msg));
  }
  catch (const YAML::Exception& e)
  {
    throw ConfigError(message(path, 0, "", std::string("YAML error: ") + e.what()));
  }
}

const std::vector<std::string>& algorithmNames()
{
  static const std::vector<std::string> names = {"kf", "kfio", "rseio", "aoe", "oe", "ack_kf"};
  return names;
}

const std::vector<Algorithm>& algorithmValues()
{
  static const std::vector<Algorithm> values = {Algorithm::KF,  Algorithm::KFIO, Algorithm::RSEIO,
                                                Algorithm::AOE, Algorithm::OE,   Algorithm::ACK_KF};
  return values;
}

// ---------------------------------------------------------------------------------------------
// Model
// ---------------------------------------------------------------------------------------------

Model parseModelImpl(const YAML::Node& node, const std::string& source)
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(
      node, "",
      {"name", "period", "A", "B", "Q", "C", "R", "sensors", "x0", "P0", "uncertainty", "control"});

  Model model;
  if (node["name"])
  {
    model.name = in.string(node["name"], "name");
  }
  if (node["period"])
  {
    model.period = in.number(node["period"], "period");
    if (!(model.period > 0.0))
    {
      in.fail(node["period"], "period",
              "expected a positive number of seconds, found " + node["period"].Scalar());
    }
  }

  // A: n x n
  const YAML::Node a_node = in.require(node, "", "A");
  model.A = in.matrix(a_node, "A", -1, -1, "");
  if (model.A.rows() != model.A.cols())
  {
    in.fail(a_node, "A",
            "expected a square matrix (n x n), found " + dims(model.A.rows(), model.A.cols()));
  }
  const int n = static_cast<int>(model.A.rows());
  const std::string n_rows = countText("n", n) + " rows";
  const std::string n_cols = countText("n", n) + " columns";

  // B: n x nw (identity by default), Q: nw x nw
  if (node["B"])
  {
    model.B = in.matrix(node["B"], "B", n, -1, n_rows);
  }
  else
  {
    model.B = Eigen::MatrixXd::Identity(n, n);
  }
  const int nw = static_cast<int>(model.B.cols());
  const YAML::Node q_node = in.require(node, "", "Q");
  model.Q = in.matrix(q_node, "Q", nw, nw,
                      countText("nw", nw) + (node["B"] ? ", the columns of B" : ", B = identity"));
  checkCovariance(in, q_node, "Q", "Q", model.Q, true);

  // C / R, or sensors
  const bool has_c = static_cast<bool>(node["C"]);
  const bool has_r = static_cast<bool>(node["R"]);
  const YAML::Node sensors_node = node["sensors"];
  if (sensors_node)
  {
    if (has_c || has_r)
    {
      in.fail(sensors_node, "sensors",
              "cannot be combined with C/R (give either C and R, or sensors)");
    }
    if (!sensors_node.IsSequence() || sensors_node.size() == 0)
    {
      in.fail(
          sensors_node, "sensors",
          "expected a non-empty list of sensors ({name, C, R}), found " +
              (sensors_node.IsSequence() ? std::string("an empty list") : describe(sensors_node)));
    }
    std::vector<Eigen::MatrixXd> cs;
    std::vector<Eigen::MatrixXd> rs;
    int m = 0;
    for (std::size_t i = 0; i < sensors_node.size(); ++i)
    {
      const YAML::Node s = sensors_node[i];
      const std::string prefix = indexKey("sensors", i);
      in.requireMap(s, prefix);
      in.checkKeys(s, prefix, {"name", "C", "R"});
      const YAML::Node name_node = in.require(s, prefix, "name");
      Sensor sensor;
      sensor.name = in.string(name_node, prefix + ".name");
      if (sensor.name.empty())
      {
        in.fail(name_node, prefix + ".name", "sensor name must not be empty");
      }
      for (std::size_t k = 0; k < model.sensors.size(); ++k)
      {
        if (model.sensors[k].name == sensor.name)
        {
          in.fail(name_node, prefix + ".name",
                  "duplicate sensor name '" + sensor.name + "' (also " + indexKey("sensors", k) +
                      ".name)");
        }
      }
      const YAML::Node c_node = in.require(s, prefix, "C");
      const Eigen::MatrixXd c = in.matrix(c_node, prefix + ".C", -1, n, n_cols);
      const int size = static_cast<int>(c.rows());
      const YAML::Node r_node = in.require(s, prefix, "R");
      const Eigen::MatrixXd r =
          in.matrix(r_node, prefix + ".R", size, size,
                    "size = " + std::to_string(size) + ", the rows of " + prefix + ".C");
      checkCovariance(in, r_node, prefix + ".R", "R", r, true);
      sensor.offset = m;
      sensor.size = size;
      m += size;
      model.sensors.push_back(sensor);
      cs.push_back(c);
      rs.push_back(r);
    }
    model.C = Eigen::MatrixXd::Zero(m, n);
    model.R = Eigen::MatrixXd::Zero(m, m);
    for (std::size_t i = 0; i < model.sensors.size(); ++i)
    {
      const Sensor& s = model.sensors[i];
      model.C.block(s.offset, 0, s.size, n) = cs[i];
      model.R.block(s.offset, s.offset, s.size, s.size) = rs[i];
    }
  }
  else
  {
    if (!has_c && !has_r)
    {
      in.fail(node, "C", "missing required key (give C and R, or sensors)");
    }
    if (!has_c)
    {
      in.fail(node, "C", "missing required key (R is given)");
    }
    if (!has_r)
    {
      in.fail(node, "R", "missing required key (C is given)");
    }
    model.C = in.matrix(node["C"], "C", -1, n, n_cols);
    const int m = static_cast<int>(model.C.rows());
    model.R = in.matrix(node["R"], "R", m, m, countText("m", m) + ", the rows of C");
    checkCovariance(in, node["R"], "R", "R", model.R, true);
    Sensor sensor;
    sensor.name = "y";
    sensor.offset = 0;
    sensor.size = m;
    model.sensors.push_back(sensor);
  }
  const int m = static_cast<int>(model.C.rows());

  // x0, P0
  if (node["x0"])
  {
    model.x0 = in.vector(node["x0"], "x0", n, countText("n", n));
  }
  else
  {
    model.x0 = Eigen::VectorXd::Zero(n);
  }
  if (node["P0"])
  {
    model.P0 = in.matrix(node["P0"], "P0", n, n, countText("n", n));
    checkCovariance(in, node["P0"], "P0", "P0", model.P0, false);
  }
  else
  {
    model.P0 = Eigen::MatrixXd::Identity(n, n);
  }

  // uncertainty
  if (const YAML::Node u_node = node["uncertainty"])
  {
    if (!u_node.IsSequence())
    {
      in.fail(u_node, "uncertainty",
              "expected a list of {dA, dB, dC, range}, found " + describe(u_node));
    }
    for (std::size_t j = 0; j < u_node.size(); ++j)
    {
      const YAML::Node e = u_node[j];
      const std::string prefix = indexKey("uncertainty", j);
      in.requireMap(e, prefix);
      in.checkKeys(e, prefix, {"dA", "dB", "dC", "range"});
      Uncertainty u;
      u.dA = e["dA"] ? in.matrix(e["dA"], prefix + ".dA", n, n, countText("n", n))
                     : Eigen::MatrixXd::Zero(n, n);
      u.dB = e["dB"] ? in.matrix(e["dB"], prefix + ".dB", n, nw,
                                 countText("n", n) + ", " + countText("nw", nw))
                     : Eigen::MatrixXd::Zero(n, nw);
      u.dC = e["dC"] ? in.matrix(e["dC"], prefix + ".dC", m, n,
                                 countText("m", m) + " stacked rows, " + countText("n", n))
                     : Eigen::MatrixXd::Zero(m, n);
      if (e["range"])
      {
        u.range = in.nonNegative(e["range"], prefix + ".range", "number");
      }
      model.uncertainty.push_back(u);
    }
  }

  // control
  if (const YAML::Node c_node = node["control"])
  {
    in.requireMap(c_node, "control");
    in.checkKeys(c_node, "control", {"Bu"});
    const YAML::Node bu = in.require(c_node, "control", "Bu");
    model.Bu = in.matrix(bu, "control.Bu", n, -1, n_rows);
  }
  else
  {
    model.Bu = Eigen::MatrixXd::Zero(n, 0);
  }

  validateModel(model, source);
  return model;
}

// ---------------------------------------------------------------------------------------------
// Settings
// ---------------------------------------------------------------------------------------------

EstimatorSettings parseEstimatorSettingsImpl(const YAML::Node& node, const std::string& source)
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(node, "", {"algorithm", "mu", "control_link", "max_components"});

  EstimatorSettings settings;
  const YAML::Node algorithm = in.require(node, "", "algorithm");
  settings.algorithm =
      algorithmValues()[in.choice(algorithm, "algorithm", "algorithm", algorithmNames())];

  if (const YAML::Node mu = node["mu"])
  {
    settings.mu = in.number(mu, "mu");
    if (!(settings.mu > 0.0 && settings.mu <= 1.0))
    {
      in.fail(mu, "mu", "expected a number in (0, 1], found " + mu.Scalar());
    }
  }
  else if (settings.algorithm == Algorithm::RSEIO)
  {
    in.fail(node, "mu", "missing required key (algorithm rseio needs mu in (0, 1])");
  }

  if (const YAML::Node link = node["control_link"])
  {
    in.requireMap(link, "control_link");
    in.checkKeys(link, "control_link", {"recovery", "failure"});
    settings.recovery =
        in.probability(in.require(link, "control_link", "recovery"), "control_link.recovery");
    settings.failure =
        in.probability(in.require(link, "control_link", "failure"), "control_link.failure");
    settings.has_control_link = true;
  }

  if (const YAML::Node max = node["max_components"])
  {
    const std::uint64_t value = in.integer(max, "max_components", 1);
    if (value > std::numeric_limits<std::size_t>::max())
    {
      in.fail(max, "max_components", "integer out of range, found " + max.Scalar());
    }
    settings.max_components = static_cast<std::size_t>(value);
  }
  return settings;
}

ChannelSettings parseChannelSettingsImpl(const YAML::Node& node, const std::string& source)
{
  const Reader in(source);
  in.requireTopMap(node);
  in.checkKeys(node, "",
               {"model", "loss", "p", "r", "loss_bad", "loss_good", "seed", "delay", "jitter",
                "distribution", "reorder", "duplicate", "queue_limit"});

  ChannelSettings settings;
  static const std::vector<std::string> model_names = {"bernoulli", "gilbert_elliott"};
  const YAML::Node model = in.require(node, "", "model");
  const std::size_t model_index = in.choice(model, "model", "loss model", model_names);
  settings.model = model_index == 0 ? LossModelKind::BERNOULLI : LossModelKind::GILBERT_ELLIOTT;

  // Keys of the other model are rejected.
  const std::vector<std::string> other_keys =
      model_index == 0 ? std::vector<std::string>{"p", "r", "loss_bad", "loss_good"}
                       : std::vector<std::string>{"loss"};
  for (auto it = node.begin(); it != node.end(); ++it)
  {
    const std::string key = it->first.Scalar();
    if (std::find(other_keys.begin(), other_keys.end(), key) != other_keys.end())
    {
      in.fail(it->first, key,
              "key '" + key + "' applies only to model " + model_names[1 - model_index] +
                  " (model is " + model_names[model_index] + ")");
    }
  }

  if (settings.model == LossModelKind::BERNOULLI)
  {
    settings.loss =
        in.probability(in.require(node, "", "loss", "model bernoulli needs loss"), "loss");
  }
  else
  {
    settings.p =
        in.probability(in.require(node, "", "p", "model gilbert_elliott needs p and r"), "p");
    settings.r =
        in.probability(in.require(node, "", "r", "model gilbert_elliott needs p and r"), "r");
    if (node["loss_bad"])
    {
      settings.loss_bad = in.probability(node["loss_bad"], "loss_bad");
    }
    if (node["loss_good"])
    {
      settings.loss_good = in.probability(node["loss_good"], "loss_good");
    }
  }

  if (node["seed"])
  {
    settings.seed = in.integer(node["seed"], "seed", 0);
  }
  if (node["delay"])
  {
    settings.delay = in.nonNegative(node["delay"], "delay", "number of seconds");
  }
  if (node["jitter"])
  {
    settings.jitter = in.nonNegative(node["jitter"], "jitter", "number of seconds");
  }
  if (node["distribution"])
  {
    static const std::vector<std::string> names = {"uniform", "normal", "pareto"};
    static const DelayDistribution values[] = {
        DelayDistribution::UNIFORM, DelayDistribution::NORMAL, DelayDistribution::PARETO};
    settings.distribution =
        values[in.choice(node["distribution"], "distribution", "distribution", names)];
  }
  if (node["reorder"])
  {
    settings.reorder = in.boolean(node["reorder"], "reorder");
  }
  if (node["duplicate"])
  {
    settings.duplicate = in.probability(node["duplicate"], "duplicate");
  }
  if (const YAML::Node limit = node["queue_limit"])
  {
    const std::uint64_t value = in.integer(limit, "queue_limit", 1);
    if (value > std::numeric_limits<std::size_t>::max())
    {
      in.fail(limit, "queue_limit", "integer out of range, found " + limit.Scalar());
    }
    settings.queue_limit = static_cast<std::size_t>(value);
  }
  return settings;
}

/// Runs a parser, turning any stray yaml-cpp exception into a ConfigError naming the source.
template <typename F>
auto guarded(const std::string& source, F&& parse) -> decltype(parse())
{
  try
  {
    return parse();
  }
  catch (const YAML::Exception& e)
  {
    throw ConfigError(message(source, 0, "", std::string("YAML error: ") + e.what()));
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Public API
// ---------------------------------------------------------------------------------------------

Model parseModel(const YAML::Node& node, const std::string& source)
{
  return guarded(source,
                 [&]
                 {
                   return parseModelImpl(node, source);
                 });
}

Model loadModel(const std::string& path)
{
  const YAML::Node root = loadYamlFile(path);
  Model model = parseModel(root, path);
  if (!root["name"])
  {
    model.name = std::filesystem::path(path).stem().string();
  }
  return model;
}

void validateModel(const Model& model, const std::string& source)
{
  const auto fail = [&source](const std::string& key, const std::string& problem)
  {
    throw ConfigError(message(source, 0, key, problem));
  };
  const auto checkSize = [&fail](const std::string& key, const Eigen::MatrixXd& M,
                                 Eigen::Index rows, Eigen::Index cols, const std::string& hint)
  {
    if (M.rows() != rows || M.cols() != cols)
    {
      fail(key, "expected " + dims(rows, cols) + (hint.empty() ? "" : " (" + hint + ")") +
                    ", found " + dims(M.rows(), M.cols()));
    }
  };
  const auto checkFinite =
      [&fail](const std::string& key, const std::string& label, const Eigen::MatrixXd& M)
  {
    const std::string problem = finitenessProblem(M, label);
    if (!problem.empty())
    {
      fail(key, problem);
    }
  };
  const auto checkCov = [&fail, &checkFinite](const std::string& key, const std::string& label,
                                              const Eigen::MatrixXd& M, bool strict)
  {
    checkFinite(key, label, M);
    std::string problem = symmetryProblem(M, label);
    if (problem.empty())
    {
      problem = definitenessProblem(M, strict);
    }
    if (!problem.empty())
    {
      fail(key, problem);
    }
  };

  if (!std::isfinite(model.period) || model.period < 0.0)
  {
    fail("period", "expected a positive number of seconds (or 0 for unset), found " +
                       formatNumber(model.period));
  }

  // A
  if (model.A.size() == 0)
  {
    fail("A", "empty matrix");
  }
  if (model.A.rows() != model.A.cols())
  {
    fail("A", "expected a square matrix (n x n), found " + dims(model.A.rows(), model.A.cols()));
  }
  checkFinite("A", "A", model.A);
  const Eigen::Index n = model.A.rows();
  const std::string n_text = countText("n", static_cast<int>(n));

  // B, Q
  if (model.B.rows() != n || model.B.cols() == 0)
  {
    fail("B", "expected " + std::to_string(n) + " rows and at least one column (" + n_text +
                  "), found " + dims(model.B.rows(), model.B.cols()));
  }
  checkFinite("B", "B", model.B);
  const Eigen::Index nw = model.B.cols();
  checkSize("Q", model.Q, nw, nw, countText("nw", static_cast<int>(nw)) + ", the columns of B");
  checkCov("Q", "Q", model.Q, true);

  // C, R, sensors
  if (model.C.rows() == 0 || model.C.cols() != n)
  {
    fail("C", "expected at least one row and " + std::to_string(n) + " columns (" + n_text +
                  "), found " + dims(model.C.rows(), model.C.cols()));
  }
  checkFinite("C", "C", model.C);
  const Eigen::Index m = model.C.rows();
  checkSize("R", model.R, m, m, countText("m", static_cast<int>(m)) + ", the rows of C");
  checkCov("R", "R", model.R, true);

  if (model.sensors.empty())
  {
    fail("sensors", "at least one sensor is required");
  }
  Eigen::Index next = 0;
  std::set<std::string> names;
  for (std::size_t i = 0; i < model.sensors.size(); ++i)
  {
    const Sensor& s = model.sensors[i];
    const std::string key = indexKey("sensors", i);
    if (s.name.empty())
    {
      fail(key + ".name", "sensor name must not be empty");
    }
    if (!names.insert(s.name).second)
    {
      fail(key + ".name", "duplicate sensor name '" + s.name + "'");
    }
    if (s.offset != next || s.size < 1)
    {
      fail(key, "expected offset " + std::to_string(next) +
                    " and size >= 1 (sensors cover the rows "
                    "of C in order), found offset " +
                    std::to_string(s.offset) + " and size " + std::to_string(s.size));
    }
    next += s.size;
  }
  if (next != m)
  {
    fail("sensors",
         "the sensors cover " + std::to_string(next) + " rows but C has " + std::to_string(m));
  }
  for (const Sensor& a : model.sensors)
  {
    for (const Sensor& b : model.sensors)
    {
      if (&a != &b && !model.R.block(a.offset, b.offset, a.size, b.size).isZero(0.0))
      {
        fail("R", "not block diagonal over sensors (R couples sensors '" + a.name + "' and '" +
                      b.name + "')");
      }
    }
  }

  // x0, P0
  if (model.x0.size() != n)
  {
    fail("x0", "expected " + std::to_string(n) + " entries (" + n_text + "), found " +
                   std::to_string(model.x0.size()));
  }
  checkFinite("x0", "x0", model.x0);
  checkSize("P0", model.P0, n, n, n_text);
  checkCov("P0", "P0", model.P0, false);

  // uncertainty
  for (std::size_t j = 0; j < model.uncertainty.size(); ++j)
  {
    const Uncertainty& u = model.uncertainty[j];
    const std::string key = indexKey("uncertainty", j);
    checkSize(key + ".dA", u.dA, n, n, n_text);
    checkFinite(key + ".dA", "dA", u.dA);
    checkSize(key + ".dB", u.dB, n, nw, n_text + ", " + countText("nw", static_cast<int>(nw)));
    checkFinite(key + ".dB", "dB", u.dB);
    checkSize(key + ".dC", u.dC, m, n,
              countText("m", static_cast<int>(m)) + " stacked rows, " + n_text);
    checkFinite(key + ".dC", "dC", u.dC);
    if (!std::isfinite(u.range) || u.range < 0.0)
    {
      fail(key + ".range", "expected a non-negative number, found " + formatNumber(u.range));
    }
  }

  // control
  if (model.Bu.rows() != n)
  {
    fail("control.Bu", "expected " + std::to_string(n) + " rows (" + n_text + "; use an " +
                           std::to_string(n) + "x0 matrix without control), found " +
                           dims(model.Bu.rows(), model.Bu.cols()));
  }
  checkFinite("control.Bu", "Bu", model.Bu);
}

std::string toString(Algorithm a)
{
  const auto& values = algorithmValues();
  for (std::size_t i = 0; i < values.size(); ++i)
  {
    if (values[i] == a)
    {
      return algorithmNames()[i];
    }
  }
  return "unknown";
}

Algorithm algorithmFromString(const std::string& name, const std::string& source)
{
  const auto& names = algorithmNames();
  const auto it = std::find(names.begin(), names.end(), name);
  if (it == names.end())
  {
    throw ConfigError(
        message(source, 0, "algorithm",
                "unknown algorithm '" + name + "' (expected one of: " + joinList(names) + ")"));
  }
  return algorithmValues()[static_cast<std::size_t>(it - names.begin())];
}

EstimatorSettings parseEstimatorSettings(const YAML::Node& node, const std::string& source)
{
  return guarded(source,
                 [&]
                 {
                   return parseEstimatorSettingsImpl(node, source);
                 });
}

EstimatorSettings loadEstimatorSettings(const std::string& path)
{
  return parseEstimatorSettings(loadYamlFile(path), path);
}

ChannelSettings parseChannelSettings(const YAML::Node& node, const std::string& source)
{
  return guarded(source,
                 [&]
                 {
                   return parseChannelSettingsImpl(node, source);
                 });
}

ChannelSettings loadChannelSettings(const std::string& path)
{
  return parseChannelSettings(loadYamlFile(path), path);
}

namespace
{
/// The shortest text that reads back as exactly this double (0.05, not 0.050000000000000003).
YAML::Node shortest(double v)
{
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  return YAML::Node(std::string(buf, res.ptr));
}
}  // namespace

YAML::Node toYaml(const ChannelSettings& settings)
{
  static const char* distributions[] = {"uniform", "normal", "pareto"};
  YAML::Node node;
  if (settings.model == LossModelKind::BERNOULLI)
  {
    node["model"] = "bernoulli";
    node["loss"] = shortest(settings.loss);
  }
  else
  {
    node["model"] = "gilbert_elliott";
    node["p"] = shortest(settings.p);
    node["r"] = shortest(settings.r);
    node["loss_bad"] = shortest(settings.loss_bad);
    node["loss_good"] = shortest(settings.loss_good);
  }
  node["seed"] = settings.seed;
  node["delay"] = shortest(settings.delay);
  node["jitter"] = shortest(settings.jitter);
  node["distribution"] = distributions[static_cast<int>(settings.distribution)];
  node["reorder"] = settings.reorder;
  node["duplicate"] = shortest(settings.duplicate);
  node["queue_limit"] = static_cast<std::uint64_t>(settings.queue_limit);
  return node;
}

ChannelSettings mergeChannelSettings(const ChannelSettings& base, const YAML::Node& changes,
                                     const std::string& source)
{
  return guarded(source, [&] {
    if (!changes.IsMap())
      throw ConfigError(source + ": expected a map of settings to change, e.g. {loss: 0.5}");
    YAML::Node merged = toYaml(base);
    if (changes["model"])
    {
      for (const char* key : {"loss", "p", "r", "loss_bad", "loss_good"})
        merged.remove(key);
    }
    for (auto it = changes.begin(); it != changes.end(); ++it)
      merged[it->first.Scalar()] = it->second;
    return parseChannelSettingsImpl(merged, source);
  });
}

}  // namespace networked_estimation
