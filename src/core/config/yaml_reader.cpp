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
