// The shared YAML reader of the configuration files (see yaml_reader.hpp).
#include "config/yaml_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>

namespace networked_estimation
{
namespace detail
{

// ---------------------------------------------------------------------------------------------
// Formatting
// ---------------------------------------------------------------------------------------------

bool booleanText(const std::string& t, bool& out)
{
  if (t == "true" || t == "True" || t == "TRUE")
  {
    out = true;
    return true;
  }
  if (t == "false" || t == "False" || t == "FALSE")
  {
    out = false;
    return true;
  }
  return false;
}

bool integerText(const std::string& t, long long& out)
{
  const std::size_t first = !t.empty() && (t[0] == '+' || t[0] == '-') ? 1 : 0;
  if (first == t.size() ||
      !std::all_of(t.begin() + static_cast<long>(first), t.end(), [](char c) { return c >= '0' && c <= '9'; }))
  {
    return false;
  }
  errno = 0;
  out = std::strtoll(t.c_str(), nullptr, 10);
  return errno != ERANGE;
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
std::string message(const std::string& source, int line, const std::string& key, const std::string& problem)
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

std::string nonFiniteEntry(const Eigen::MatrixXd& M, const std::string& label)
{
  for (const bool infinite : {true, false})
  {
    for (Eigen::Index i = 0; i < M.rows(); ++i)
    {
      for (Eigen::Index j = 0; j < M.cols(); ++j)
      {
        if (infinite ? std::isinf(M(i, j)) : std::isnan(M(i, j)))
        {
          return label + "(" + std::to_string(i) + "," + std::to_string(j) + ") = " + formatNumber(M(i, j));
        }
      }
    }
  }
  return "";
}

// ---------------------------------------------------------------------------------------------
// Reader: typed access to YAML nodes, throwing ConfigError with source, line and key path.
// ---------------------------------------------------------------------------------------------

/// Expected size in a message: a free dimension (< 0) takes the found value.
static std::string expectedDims(int rows, int cols, Eigen::Index found_rows, Eigen::Index found_cols)
{
  return dims(rows >= 0 ? rows : found_rows, cols >= 0 ? cols : found_cols);
}

void Reader::fail(const YAML::Node& at, const std::string& key, const std::string& problem) const
{
  throw ConfigError(message(source_, lineOf(at), key, problem));
}

void Reader::requireTopMap(const YAML::Node& node) const
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

void Reader::requireMap(const YAML::Node& node, const std::string& key) const
{
  if (!node.IsMap())
  {
    fail(node, key, "expected a map, found " + describe(node));
  }
}

void Reader::checkKeys(const YAML::Node& map, const std::string& prefix, const std::vector<std::string>& known) const
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

YAML::Node Reader::require(const YAML::Node& map, const std::string& prefix, const std::string& key,
                           const std::string& why) const
{
  const YAML::Node child = map[key];
  if (!child.IsDefined())
  {
    fail(map, childKey(prefix, key), "missing required key" + (why.empty() ? "" : " (" + why + ")"));
  }
  return child;
}

double Reader::rawNumber(const YAML::Node& node, const std::string& key) const
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

double Reader::number(const YAML::Node& node, const std::string& key) const
{
  const double value = rawNumber(node, key);
  if (!std::isfinite(value))
  {
    fail(node, key, "expected a finite number, found '" + node.Scalar() + "'");
  }
  return value;
}

double Reader::probability(const YAML::Node& node, const std::string& key) const
{
  const double value = number(node, key);
  if (!(value >= 0.0 && value <= 1.0))
  {
    fail(node, key, "expected a probability in [0, 1], found " + node.Scalar());
  }
  return value;
}

double Reader::nonNegative(const YAML::Node& node, const std::string& key, const std::string& what) const
{
  const double value = number(node, key);
  if (!(value >= 0.0))
  {
    fail(node, key, "expected a non-negative " + what + ", found " + node.Scalar());
  }
  return value;
}

std::uint64_t Reader::integer(const YAML::Node& node, const std::string& key, std::uint64_t min) const
{
  const std::string expected = min == 0 ? "a non-negative integer" : "an integer >= " + std::to_string(min);
  if (!node.IsScalar())
  {
    fail(node, key, "expected " + expected + ", found " + describe(node));
  }
  std::string text = node.Scalar();
  const bool digits_only =
      !text.empty() &&
      std::all_of(text.begin() + (text[0] == '+' ? 1 : 0), text.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
      text != "+";
  if (!digits_only)
  {
    double value = 0.0;
    if (YAML::convert<double>::decode(node, value) && std::isfinite(value) && value == std::floor(value))
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
         "integer out of range (at most " + std::to_string(std::numeric_limits<std::uint64_t>::max()) + "), found " +
             text);
  }
  if (value < min)
  {
    fail(node, key, "expected " + expected + ", found " + text);
  }
  return static_cast<std::uint64_t>(value);
}

bool Reader::boolean(const YAML::Node& node, const std::string& key) const
{
  bool value = false;
  if (node.IsScalar() && booleanText(node.Scalar(), value))
  {
    return value;
  }
  fail(node, key, "expected true or false, found " + describe(node));
}

std::string Reader::string(const YAML::Node& node, const std::string& key) const
{
  if (!node.IsScalar())
  {
    fail(node, key, "expected a string, found " + describe(node));
  }
  return node.Scalar();
}

std::size_t Reader::choice(const YAML::Node& node, const std::string& key, const std::string& what,
                           const std::vector<std::string>& names) const
{
  const std::string value = string(node, key);
  const auto it = std::find(names.begin(), names.end(), value);
  if (it == names.end())
  {
    fail(node, key, "unknown " + what + " '" + value + "' (expected one of: " + joinList(names) + ")");
  }
  return static_cast<std::size_t>(it - names.begin());
}

Eigen::MatrixXd Reader::matrix(const YAML::Node& node, const std::string& key, int rows, int cols,
                               const std::string& hint) const
{
  if (!node.IsSequence())
  {
    fail(node, key, "expected a matrix (list of rows), found " + describe(node));
  }
  if (node.size() == 0)
  {
    fail(node, key, "empty matrix (expected a non-empty list of rows" + (hint.empty() ? "" : ", " + hint) + ")");
  }
  const std::size_t found_rows = node.size();
  std::size_t found_cols = 0;
  for (std::size_t i = 0; i < found_rows; ++i)
  {
    const YAML::Node row = node[i];
    if (!row.IsSequence())
    {
      fail(row, key, "row " + std::to_string(i) + ": expected a list of numbers, found " + describe(row));
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
           "ragged rows (row 0 has " + std::to_string(found_cols) + " entries, row " + std::to_string(i) + " has " +
               std::to_string(row.size()) + ")");
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
         "expected " + expectedDims(rows, cols, r, c) + (hint.empty() ? "" : " (" + hint + ")") + ", found " +
             dims(r, c));
  }
  return M;
}

Eigen::VectorXd Reader::vector(const YAML::Node& node, const std::string& key, int size, const std::string& hint) const
{
  if (!node.IsSequence())
  {
    fail(node, key, "expected a list of numbers, found " + describe(node));
  }
  if (static_cast<int>(node.size()) != size)
  {
    fail(node, key,
         "expected " + std::to_string(size) + " entries" + (hint.empty() ? "" : " (" + hint + ")") + ", found " +
             std::to_string(node.size()));
  }
  Eigen::VectorXd v(size);
  for (int i = 0; i < size; ++i)
  {
    v(i) = entry(node[i], key, "entry " + std::to_string(i));
  }
  return v;
}

double Reader::entry(const YAML::Node& node, const std::string& key, const std::string& where) const
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

/// Checks symmetry and definiteness of a parsed matrix, failing at `node`.
void checkCovariance(const Reader& in, const YAML::Node& node, const std::string& key, const std::string& label,
                     const Eigen::MatrixXd& M, bool strict)
{
  const CovarianceCheck check =
      networked_estimation::checkCovariance(M, strict ? Definiteness::POSITIVE : Definiteness::SEMIDEFINITE);
  if (!check.ok())
  {
    in.fail(node, key, check.describe(label));
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

}  // namespace detail
}  // namespace networked_estimation
