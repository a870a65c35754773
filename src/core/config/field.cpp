// The checked-field reader (see field.hpp).
#include "config/field.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>

#include "config/yaml_reader.hpp"
#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{
namespace detail
{

namespace
{
/// Expected size in a message: a free dimension (< 0) takes the found value.
std::string expectedDims(int rows, int cols, Eigen::Index found_rows, Eigen::Index found_cols)
{
  return dims(rows >= 0 ? rows : found_rows, cols >= 0 ? cols : found_cols);
}
}  // namespace

Field::Field(YAML::Node node, const std::string& source, Origin origin)
  : origin_(std::make_shared<const Document>(Document{source, origin})), node_(std::move(node))
{
}

Field::Field(std::shared_ptr<const Document> origin, YAML::Node node, std::string key)
  : origin_(std::move(origin)), node_(std::move(node)), key_(std::move(key))
{
}

std::string Field::found() const
{
  if (origin_->origin == Origin::PARAMETERS && (isList() || isMap()))
  {
    YAML::Emitter out;
    out << YAML::Flow << node_;
    return std::string("'") + out.c_str() + "'";
  }
  return describe(node_);
}

int Field::line() const
{
  return origin_->origin == Origin::FILE ? lineOf(node_) : 0;
}

void Field::fail(const std::string& problem) const
{
  throw ConfigError(message(origin_->source, line(), key_, problem));
}

void Field::failAt(const std::string& key, const std::string& problem) const
{
  throw ConfigError(message(origin_->source, line(), key, problem));
}

Field Field::operator[](const std::string& name) const
{
  // A const node's operator[] does not insert the key when it is absent.
  const YAML::Node& map = node_;
  return Field(origin_, isMap() ? map[name] : YAML::Node(YAML::NodeType::Undefined), childKey(key_, name));
}

Field Field::operator[](std::size_t i) const
{
  const YAML::Node& list = node_;
  return Field(origin_, isList() ? list[i] : YAML::Node(YAML::NodeType::Undefined), indexKey(key_, i));
}

std::vector<Field> Field::elements() const
{
  std::vector<Field> out;
  if (isList())
  {
    out.reserve(node_.size());
    for (std::size_t i = 0; i < node_.size(); ++i)
    {
      out.push_back((*this)[i]);
    }
  }
  return out;
}

Field Field::required(const std::string& name, const std::string& why) const
{
  const Field child = (*this)[name];
  if (!child.present())
  {
    failAt(child.key(), "missing required key" + (why.empty() ? "" : " (" + why + ")"));
  }
  return child;
}

void Field::requireMap() const
{
  if (!isMap())
  {
    fail("expected a map, found " + found());
  }
}

void Field::requireTopMap() const
{
  if (!node_.IsDefined() || node_.IsNull())
  {
    fail("empty document (expected a map of keys)");
  }
  if (!node_.IsMap())
  {
    fail("expected a map of keys at the top level, found " + found());
  }
}

void Field::checkKeys(const std::vector<std::string>& known) const
{
  std::set<std::string> seen;
  for (auto it = node_.begin(); it != node_.end(); ++it)
  {
    const YAML::Node key_node = it->first;
    const Field at(origin_, key_node, key_);
    if (!key_node.IsScalar())
    {
      at.fail("keys must be plain names, found " + at.found());
    }
    const std::string name = key_node.Scalar();
    const std::string path = childKey(key_, name);
    if (std::find(known.begin(), known.end(), name) == known.end())
    {
      at.failAt(path, "unknown key (known keys: " + joinList(known) + ")");
    }
    if (!seen.insert(name).second)
    {
      at.failAt(path, "duplicate key");
    }
  }
}

double Field::rawNumber() const
{
  if (!isScalar())
  {
    fail("expected a number, found " + found());
  }
  double value = 0.0;
  if (YAML::convert<double>::decode(node_, value))
  {
    return value;
  }
  // The stream conversion fails on overflow: tell that apart from text.
  const std::string& text = node_.Scalar();
  char* end = nullptr;
  errno = 0;
  std::strtod(text.c_str(), &end);
  if (!text.empty() && end == text.c_str() + text.size() && errno == ERANGE)
  {
    fail("number out of range, found '" + text + "'");
  }
  fail("expected a number, found '" + text + "'");
}

double Field::number() const
{
  const double value = rawNumber();
  if (!std::isfinite(value))
  {
    fail("expected a finite number, found '" + node_.Scalar() + "'");
  }
  return value;
}

double Field::probability() const
{
  const double value = number();
  if (!(value >= 0.0 && value <= 1.0))
  {
    fail("expected a probability in [0, 1], found " + node_.Scalar());
  }
  return value;
}

double Field::nonNegative(const std::string& what) const
{
  const double value = number();
  if (!(value >= 0.0))
  {
    fail("expected a non-negative " + what + ", found " + node_.Scalar());
  }
  return value;
}

std::uint64_t Field::integer(std::uint64_t min) const
{
  const std::string expected = min == 0 ? "a non-negative integer" : "an integer >= " + std::to_string(min);
  if (!isScalar())
  {
    fail("expected " + expected + ", found " + found());
  }
  const std::string text = node_.Scalar();
  const bool digits_only =
      !text.empty() &&
      std::all_of(text.begin() + (text[0] == '+' ? 1 : 0), text.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
      text != "+";
  if (!digits_only)
  {
    double value = 0.0;
    if (YAML::convert<double>::decode(node_, value) && std::isfinite(value) && value == std::floor(value))
    {
      fail("expected " + expected + ", found " + text);  // e.g. -3
    }
    fail("expected " + expected + ", found '" + text + "'");  // e.g. 2.5, abc
  }
  errno = 0;
  const unsigned long long value = std::strtoull(text.c_str(), nullptr, 10);
  if (errno == ERANGE)
  {
    fail("integer out of range (at most " + std::to_string(std::numeric_limits<std::uint64_t>::max()) + "), found " +
         text);
  }
  if (value < min)
  {
    fail("expected " + expected + ", found " + text);
  }
  return static_cast<std::uint64_t>(value);
}

bool Field::boolean() const
{
  bool value = false;
  if (isScalar() && booleanText(node_.Scalar(), value))
  {
    return value;
  }
  fail("expected true or false, found " + found());
}

std::string Field::string() const
{
  if (!isScalar())
  {
    fail("expected a string, found " + found());
  }
  return node_.Scalar();
}

std::size_t Field::oneOf(const std::string& what, const std::vector<std::string>& names) const
{
  const std::string value = string();
  const auto it = std::find(names.begin(), names.end(), value);
  if (it == names.end())
  {
    fail("unknown " + what + " '" + value + "' (expected one of: " + joinList(names) + ")");
  }
  return static_cast<std::size_t>(it - names.begin());
}

Eigen::MatrixXd Field::matrix(int rows, int cols, const std::string& hint) const
{
  if (!isList())
  {
    fail("expected a matrix (list of rows), found " + found());
  }
  if (node_.size() == 0)
  {
    fail("empty matrix (expected a non-empty list of rows" + (hint.empty() ? "" : ", " + hint) + ")");
  }
  const std::size_t found_rows = node_.size();
  std::size_t found_cols = 0;
  for (std::size_t i = 0; i < found_rows; ++i)
  {
    const Field row(origin_, node_[i], key_);
    if (!row.isList())
    {
      row.fail("row " + std::to_string(i) + ": expected a list of numbers, found " + row.found());
    }
    if (row.size() == 0)
    {
      row.fail("row " + std::to_string(i) + " is empty");
    }
    if (i == 0)
    {
      found_cols = row.size();
    }
    else if (row.size() != found_cols)
    {
      row.fail("ragged rows (row 0 has " + std::to_string(found_cols) + " entries, row " + std::to_string(i) + " has " +
               std::to_string(row.size()) + ")");
    }
  }
  Eigen::MatrixXd M(found_rows, found_cols);
  for (std::size_t i = 0; i < found_rows; ++i)
  {
    const YAML::Node row = node_[i];
    for (std::size_t j = 0; j < found_cols; ++j)
    {
      M(i, j) = entry(row[j], "entry (" + std::to_string(i) + "," + std::to_string(j) + ")");
    }
  }
  const auto r = static_cast<Eigen::Index>(found_rows);
  const auto c = static_cast<Eigen::Index>(found_cols);
  if ((rows >= 0 && r != rows) || (cols >= 0 && c != cols))
  {
    fail("expected " + expectedDims(rows, cols, r, c) + (hint.empty() ? "" : " (" + hint + ")") + ", found " +
         dims(r, c));
  }
  return M;
}

Eigen::VectorXd Field::vector(int size, const std::string& hint) const
{
  if (!isList())
  {
    fail("expected a list of numbers, found " + found());
  }
  if (static_cast<int>(node_.size()) != size)
  {
    fail("expected " + std::to_string(size) + " entries" + (hint.empty() ? "" : " (" + hint + ")") + ", found " +
         std::to_string(node_.size()));
  }
  Eigen::VectorXd v(size);
  for (int i = 0; i < size; ++i)
  {
    v(i) = entry(node_[i], "entry " + std::to_string(i));
  }
  return v;
}

void Field::checkCovariance(const Eigen::MatrixXd& M, const std::string& label, Definiteness definiteness) const
{
  const CovarianceCheck check = networked_estimation::checkCovariance(M, definiteness);
  if (!check.ok())
  {
    fail(check.describe(label));
  }
}

double Field::entry(const YAML::Node& node, const std::string& where) const
{
  const Field at(origin_, node, key_);
  if (!node.IsScalar())
  {
    at.fail(where + ": expected a number, found " + at.found());
  }
  double value = 0.0;
  if (!YAML::convert<double>::decode(node, value))
  {
    at.fail(where + ": expected a number, found '" + node.Scalar() + "'");
  }
  if (!std::isfinite(value))
  {
    at.fail(where + ": not finite (found " + node.Scalar() + ")");
  }
  return value;
}

}  // namespace detail
}  // namespace networked_estimation
